"""Controller kinds: the registry behind the ``[controller]`` section, the engine, analysis
and tuning.

A *kind* is one module that defines its compiled element(s) (:mod:`acc.engine.element`) and
registers a :class:`ControllerKind`: its name, its option groups (the ``[controller]`` keys
it reads, each group a frozen dataclass with defaults, units in the names and validation),
how to build its records for a batch, and, when it has a linear model, how to fill a
:class:`controllers.linear_loop.LoopSpec` for ``acc analyze`` and ``acc tune``.  See
``docs/adding_a_controller.md``.

The ``[controller]`` section (:class:`ControllerParams`) has the keys every kind shares
(``kind``, reference, programmed feed, override limits and start, anti-windup) plus the keys
of every registered option group; a key of a group the chosen kind does not use is checked
and kept, but has no effect (so a campaign can sweep ``kind`` with other keys fixed).

Built-in kinds (their modules are imported below, one line each):

======================  ======================================================================
``"pi"``                fixed-gain feedrate-override PI (:mod:`controllers.pi`)
``"constant"``          fixed override, the conventional constant feed (:mod:`controllers.pi`)
``"adaptive_pi"``       PI re-designed from the online ``K2, p2`` estimate
``"dob_pi"``            fixed PI around a disturbance observer on the nominal plant
``"dob_adaptive_pi"``   adaptive PI around an observer on the estimated (or nominal) model
                        (the last three: :mod:`controllers.robust_force_controller`)
``"fsp_pi"``            filtered Smith predictor around a PI designed on the delay-free model
``"fsp_adaptive_pi"``   the same with the model and the PI from the online estimate
                        (both: :mod:`controllers.filtered_smith_predictor`)
======================  ======================================================================
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import math
import typing
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from controllers.adaptive_pi import ANTI_WINDUP_KINDS
from controllers.linear_loop import LoopSpec
from controllers.pi_design import PIDesignOptions, PIGains, design_pi
from plants.design_set import DesignSet
from plants.nominal_plant import NominalPlant

#: Records builder of a kind: (params, nominal, control period [s], safe override (runs,)
#: [, design=design sets (runs,), a kind that uses_design_set]) -> (params records, state
#: records), each shape (runs,).
RecordsBuilder = Callable[..., tuple[NDArray, NDArray]]
#: Linear-loop hook: (loop with the plant filled and no controller, the run's controller
#: params, nominal plant) -> the loop with the kind's controller.
LinearLoop = Callable[[LoopSpec, "ControllerParams", NominalPlant], LoopSpec]


@dataclass(frozen=True)
class ControllerKind:
    """One registered controller kind.

    Attributes
    ----------
    name : str
        The ``controller.kind`` value.
    doc : str
        One line: what it is.
    options : tuple of type
        Option-group dataclasses whose keys this kind reads.
    records : callable
        :data:`RecordsBuilder`: the compiled element's records for a batch of runs of this
        kind.
    linear_loop : callable or None
        :data:`LinearLoop`; None: the kind is not analysable (``acc analyze`` lists it as
        such, ``acc tune`` refuses it).
    tunables : tuple of str
        ``[controller]`` keys ``acc tune`` may change (positive reals, tuned in log scale).
    uses_safe_feed : callable or None
        ``(params) -> bool``: whether a run's records depend on its part's safe feed.
    delays_by_nominal_dead_time : bool
        The kind delays its commands by the nominal dead time in whole control periods
        (an estimator or observer); the scenario checks that the dead time is whole.
    uses_design_set : bool
        ``records`` also takes ``design=`` (a sequence of :class:`plants.design_set.DesignSet`,
        one per run): the scenario's declared plant set (the adaptive kinds' safe start).
    """

    name: str
    doc: str
    options: tuple[type, ...]
    records: RecordsBuilder
    linear_loop: LinearLoop | None = None
    tunables: tuple[str, ...] = ()
    uses_safe_feed: Callable[[ControllerParams], bool] | None = None
    delays_by_nominal_dead_time: bool = False
    uses_design_set: bool = False


_KINDS: dict[str, ControllerKind] = {}
#: option key -> its group dataclass
_OPTION_OWNER: dict[str, type] = {}


def register_controller(kind: ControllerKind) -> ControllerKind:
    """Register a controller kind (and its option groups); returns it.

    Raises ValueError if the name is taken by another kind, or an option key is claimed by
    two different groups.
    """
    old = _KINDS.get(kind.name)
    if old is not None and old.records is not kind.records:
        if getattr(old.records, "__qualname__", None) != getattr(kind.records, "__qualname__", 0):
            raise ValueError(f"controller kind {kind.name!r} is already registered")
    for group in kind.options:
        if not dataclasses.is_dataclass(group):
            raise TypeError(f"option group {group!r} of {kind.name!r} must be a dataclass")
        for f in dataclasses.fields(group):
            owner = _OPTION_OWNER.get(f.name)
            if owner is not None and owner.__qualname__ != group.__qualname__:
                raise ValueError(
                    f"option {f.name!r} of {group.__name__} is already {owner.__name__}'s"
                )
            if f.name in COMMON_KEYS:
                raise ValueError(f"option {f.name!r} clashes with a common [controller] key")
            _OPTION_OWNER[f.name] = group
    _KINDS[kind.name] = kind
    _sort_kinds()
    ControllerParams.field_types.cache_clear()
    return kind


def _sort_kinds() -> None:
    """Order the registry: the built-in kinds in the order of :data:`BUILTIN_KIND_MODULES`
    (whichever module was imported first), then the others in registration order."""
    rank = {module: i for i, module in enumerate(BUILTIN_KIND_MODULES)}
    ordered = sorted(_KINDS.values(), key=lambda k: rank.get(
        str(getattr(k.records, "__module__", "")), len(rank)))  # stable: registration order
    _KINDS.clear()
    _KINDS.update((k.name, k) for k in ordered)


def unregister_controller(name: str) -> None:
    """Remove a registered kind and the option groups no other kind uses (tests, plugins)."""
    kind = _KINDS.pop(name)
    still = {g for k in _KINDS.values() for g in k.options}
    for group in kind.options:
        if group not in still:
            for f in dataclasses.fields(group):
                _OPTION_OWNER.pop(f.name, None)
    ControllerParams.field_types.cache_clear()


def controller_kinds() -> dict[str, ControllerKind]:
    """Every registered kind by name: the built-in kinds in the order of
    :data:`BUILTIN_KIND_MODULES` (whichever module was imported first), then the others in
    registration order."""
    _load_builtin()
    return dict(_KINDS)


def controller_kind(name: str) -> ControllerKind:
    """The registered kind ``name`` (KeyError listing the known ones)."""
    kinds = controller_kinds()
    if name not in kinds:
        raise KeyError(f"unknown controller kind {name!r} (known: {', '.join(kinds)})")
    return kinds[name]


def _default(group: type, key: str) -> Any:
    f = next(f for f in dataclasses.fields(group) if f.name == key)
    return f.default


COMMON_KEYS = (
    "kind",
    "reference_force_N",
    "programmed_feed_mm_min",
    "override_min",
    "override_max",
    "initial_override",
    "anti_windup",
)


@dataclass(frozen=True)
class ControllerParams:
    """The ``[controller]`` section: the keys every kind shares, and its options.

    Attributes
    ----------
    kind : str
        A registered controller kind (:func:`controller_kinds`).
    reference_force_N : float
        Force reference [N], > 0.
    programmed_feed_mm_min : float
        Programmed feed the override multiplies [mm/min], > 0.
    override_min, override_max : float
        Override clamp [-], 0 <= min <= max.
    initial_override : float
        Override (integrator) at start [-].
    anti_windup : {"clamping", "none"}
        Integrator anti-windup.
    options : tuple of (str, value)
        Option keys of the registered groups that differ from their defaults, sorted.  Read
        an option as an attribute (``params.dob_tau_s``) or a whole group with
        :meth:`group`; build with :meth:`from_values`.
    """

    kind: str = "pi"
    reference_force_N: float = 500.0
    programmed_feed_mm_min: float = 120.0
    override_min: float = 0.1
    override_max: float = 2.0
    initial_override: float = 1.0
    anti_windup: str = "clamping"
    options: tuple[tuple[str, Any], ...] = field(default=())

    def __post_init__(self) -> None:
        kinds = controller_kinds()
        if self.kind not in kinds:
            raise ValueError(f"kind must be one of {tuple(kinds)}, got {self.kind!r}")
        if not self.reference_force_N > 0:
            raise ValueError(f"reference_force_N must be > 0, got {self.reference_force_N}")
        if not self.programmed_feed_mm_min > 0:
            raise ValueError(
                f"programmed_feed_mm_min must be > 0, got {self.programmed_feed_mm_min}"
            )
        if not 0 <= self.override_min <= self.override_max:
            raise ValueError(
                f"override_min/override_max must satisfy 0 <= min <= max, got "
                f"{self.override_min}, {self.override_max}"
            )
        if self.anti_windup not in ANTI_WINDUP_KINDS:
            raise ValueError(f"anti_windup must be one of {ANTI_WINDUP_KINDS}")
        given = dict(self.options)
        kept = {}
        for key, value in given.items():
            owner = _OPTION_OWNER.get(key)
            if owner is None:
                raise ValueError(f"{key}: unknown option (known: {', '.join(_OPTION_OWNER)})")
            if value != _default(owner, key):
                kept[key] = value
        for group in {_OPTION_OWNER[k] for k in given}:
            self._build(group, given)  # validates the group (ValueError names the key)
        object.__setattr__(self, "options", tuple(sorted(kept.items())))

    @staticmethod
    def _build(group: type, values: dict[str, Any]) -> Any:
        names = {f.name for f in dataclasses.fields(group)}
        return group(**{k: v for k, v in values.items() if k in names})

    def __getattr__(self, name: str) -> Any:
        # only called when the normal lookup fails: an option key
        owner = _OPTION_OWNER.get(name)
        if owner is None or name.startswith("__"):
            raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")
        options = object.__getattribute__(self, "options")
        return dict(options).get(name, _default(owner, name))

    def group(self, group: type) -> Any:
        """The options of one group (its dataclass), defaults filled."""
        return _group(self.options, group)

    @classmethod
    @functools.cache
    def field_types(cls) -> dict[str, Any]:
        """Every key of the section and its type: common keys, then every option key."""
        _load_builtin()
        hints = typing.get_type_hints(cls)
        out = {k: hints[k] for k in COMMON_KEYS}
        for key, group in _OPTION_OWNER.items():
            out[key] = typing.get_type_hints(group)[key]
        return out

    @classmethod
    def from_values(cls, values: dict[str, Any]) -> ControllerParams:
        """Build from ``{key: value}`` (common and option keys alike)."""
        common = {k: v for k, v in values.items() if k in COMMON_KEYS}
        options = {k: v for k, v in values.items() if k not in COMMON_KEYS}
        return cls(**common, options=tuple(sorted(options.items())))

    def replace_values(self, values: dict[str, Any]) -> ControllerParams:
        """A copy with some keys changed, validated."""
        merged = {k: getattr(self, k) for k in COMMON_KEYS}
        merged.update(dict(self.options))
        merged.update(values)
        return self.from_values(merged)

    def to_values(self) -> dict[str, Any]:
        """Every key with its value, defaults filled (None-valued options omitted)."""
        out = {k: getattr(self, k) for k in COMMON_KEYS}
        for key in _OPTION_OWNER:
            value = getattr(self, key)
            if value is not None:
                out[key] = value
        return out



@functools.lru_cache(maxsize=4096)
def _group(options: tuple[tuple[str, Any], ...], group: type) -> Any:
    return ControllerParams._build(group, dict(options))


def resolved_gains(
    params: ControllerParams, nominal: NominalPlant, control_period_s: float
) -> PIGains:
    """The PI gains a run uses: the scenario's, or the designed ones (memoised)."""
    opts = params.group(PIDesignOptions)
    if opts.kp_per_N is not None and opts.ki_per_N_s is not None:
        return PIGains(opts.kp_per_N, opts.ki_per_N_s, math.nan, math.nan)
    return _designed(
        nominal, params.programmed_feed_mm_min, control_period_s, opts.design_phase_margin_deg
    )


@functools.lru_cache(maxsize=4096)
def _designed(
    nominal: NominalPlant, feed_mm_min: float, control_period_s: float, margin_deg: float
) -> PIGains:
    return design_pi(nominal, feed_mm_min, control_period_s, margin_deg)


def dead_time_periods(nominal: NominalPlant, control_period_s: float) -> int:
    """Nominal dead time in whole control periods (rounded to the nearest)."""
    return int(round(nominal.dead_time_s / control_period_s))


def pi_arguments(
    params: Sequence[ControllerParams], nominal: Sequence[NominalPlant], control_period_s: float
) -> dict[str, NDArray]:
    """Per-run PI arguments shared by every PI-based kind, each shape (runs,)."""
    gains = [resolved_gains(p, n, control_period_s) for p, n in zip(params, nominal, strict=True)]
    return {
        "reference_force_N": np.array([p.reference_force_N for p in params]),
        "kp_per_N": np.array([g.kp_per_N for g in gains]),
        "ki_per_N_s": np.array([g.ki_per_N_s for g in gains]),
        "override_min": np.array([p.override_min for p in params]),
        "override_max": np.array([p.override_max for p in params]),
        "initial_override": np.array([p.initial_override for p in params]),
    }


def controller_records(
    params: Sequence[ControllerParams],
    nominal: Sequence[NominalPlant],
    control_period_s: float,
    safe_override: NDArray,
    design: Sequence[DesignSet] | None = None,
) -> tuple[NDArray, NDArray]:
    """Compiled-element records of the controllers of runs that share a kind.

    Parameters
    ----------
    params : sequence of ControllerParams, length runs
    nominal : sequence of NominalPlant, length runs
    control_period_s : float
        Controller period [s].
    safe_override : ndarray, shape (runs,)
        Override of the safe constant feed of each run [-].
    design : sequence of DesignSet, length runs, optional
        Each run's declared plant set (``[design]``); None: the default set.  Passed to the
        kinds that use it (:attr:`ControllerKind.uses_design_set`).

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    kinds = {p.kind for p in params}
    if len(kinds) != 1:
        raise ValueError(f"one batch runs one controller kind, got {sorted(kinds)}")
    kind = controller_kind(kinds.pop())
    safe = np.asarray(safe_override, float)
    if not kind.uses_design_set:
        return kind.records(params, nominal, control_period_s, safe)
    sets = [DesignSet()] * len(params) if design is None else list(design)
    return kind.records(params, nominal, control_period_s, safe, design=sets)


def uses_safe_feed(params: ControllerParams) -> bool:
    """Whether a run's controller records depend on its part's safe feed."""
    hook = controller_kind(params.kind).uses_safe_feed
    return bool(hook(params)) if hook is not None else False


#: Modules that register the built-in kinds (a new built-in kind adds its module here).
BUILTIN_KIND_MODULES = (
    "controllers.pi",
    "controllers.robust_force_controller",
    "controllers.filtered_smith_predictor",
)


@functools.cache
def _load_builtin() -> None:
    for module in BUILTIN_KIND_MODULES:
        importlib.import_module(module)


__all__ = [
    "BUILTIN_KIND_MODULES",
    "COMMON_KEYS",
    "ControllerKind",
    "ControllerParams",
    "controller_kind",
    "controller_kinds",
    "controller_records",
    "dead_time_periods",
    "pi_arguments",
    "register_controller",
    "resolved_gains",
    "unregister_controller",
    "uses_safe_feed",
]
