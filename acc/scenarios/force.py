"""Scenario files: closed TOML with units in key names, validated into frozen dataclasses.

A scenario has the sections below; every key is optional and defaults to the field default
of the section's dataclass (defaults live there and nowhere else).  Unknown sections or
keys, wrong types and impossible values raise :class:`ScenarioError`, whose message names
the file and the key in one line.

=================  =====================================================================
section            dataclass
=================  =====================================================================
``simulation``     :class:`SimulationParams`
``feed_drive``     :class:`plants.feed_drive.FeedDriveParams`
``force_process``  :class:`plants.force_process.ForceProcessTable`
``workpiece``      :class:`plants.workpiece.Workpiece`
``sensor``         :class:`plants.force_sensor.ForceSensorParams`
``nominal_plant``  :class:`plants.nominal_plant.NominalPlant`
``controller``     :class:`controllers.registry.ControllerParams`
``metrics``        :class:`MetricsParams`
``geometry``       :class:`plants.geometric_process.GeometricProcessParams`
``cutting_coef…``  :class:`plants.cutting_coefficients.CuttingCoefficients`
``current_sens…``  :class:`acc.engine.current_sensing.CurrentSensingParams`
``tool_breakage``  :class:`controllers.monitoring.breakage_monitor.BreakageMonitorParams`
``design``         :class:`plants.design_set.DesignSet` (the plants a design must cover)
=================  =====================================================================

and a list of tables ``[[disturbance]]`` (:class:`plants.disturbance.Disturbance`), addressed
as ``disturbance.<name>.<key>`` by ``--set`` and campaigns.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acc.engine.current_sensing import CurrentSensingParams
from acc.errors import ScenarioError, unknown_name
from acc.inputs import parse_assignment, read_toml
from acc.limits import (
    MAGNITUDE_RANGE,
    MAX_INTEGER,
    MAX_LIST_ITEMS,
    MAX_PLANT_STEPS,
    MAX_SHOWN_CHARS,
    abbreviate,
    shorten,
)
from controllers.monitoring.breakage_monitor import BreakageMonitorParams
from controllers.registry import ControllerParams
from plants.cutting_coefficients import CuttingCoefficients
from plants.design_set import DesignSet
from plants.disturbance import Disturbance
from plants.feed_drive import FeedDriveParams, dead_time_steps
from plants.force_process import ForceProcessTable
from plants.force_sensor import ForceSensorParams
from plants.geometric_process import GeometricProcessParams
from plants.nominal_plant import NominalPlant
from plants.workpiece import Workpiece


@dataclass(frozen=True)
class SimulationParams:
    """The ``[simulation]`` section.

    Attributes
    ----------
    plant_step_s : float
        Plant integration step ``dt`` [s], > 0.
    control_period_s : float
        Controller period [s]: a whole multiple of ``plant_step_s``.
    time_limit_s : float
        The run stops here if the part is not finished [s], > 0.
    seed : int
        Root seed of the run's random streams (>= 0).
    dead_time_rounding : {"error", "round"}
        A dead time that is not a whole number of plant steps is an error, or is rounded
        with a warning that says by how much.
    """

    plant_step_s: float = 0.001
    control_period_s: float = 0.01
    time_limit_s: float = 60.0
    seed: int = 2001
    dead_time_rounding: str = "error"

    def __post_init__(self) -> None:
        for name in ("plant_step_s", "control_period_s", "time_limit_s"):
            value = getattr(self, name)
            if not value > 0:
                raise ValueError(f"{name} must be > 0, got {value}")
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value}")
        ratio = self.control_period_s / self.plant_step_s
        if not ratio <= MAX_PLANT_STEPS:
            raise ValueError(
                f"control_period_s = {self.control_period_s} is {ratio:.3g} plant steps "
                f"(limit {MAX_PLANT_STEPS:.0e})"
            )
        if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
            raise ValueError(
                f"control_period_s = {self.control_period_s} is not a whole multiple of "
                f"plant_step_s = {self.plant_step_s} ({ratio:.6g} steps)"
            )
        steps = self.time_limit_s / self.plant_step_s
        if not steps <= MAX_PLANT_STEPS:
            raise ValueError(
                f"time_limit_s = {self.time_limit_s} s at plant_step_s = {self.plant_step_s} s "
                f"is {steps:.3g} plant steps per run (limit {MAX_PLANT_STEPS:.0e}); shorten "
                "the time limit or lengthen the step"
            )
        if self.time_limit_s < self.plant_step_s or self.max_steps < 1:
            raise ValueError(
                f"time_limit_s = {self.time_limit_s} s is shorter than one plant step "
                f"({self.plant_step_s} s)"
            )
        if not 0 <= self.seed <= MAX_INTEGER:
            raise ValueError(f"seed must be in 0..2**63-1, got {self.seed}")
        if self.dead_time_rounding not in ("error", "round"):
            raise ValueError("dead_time_rounding must be 'error' or 'round'")

    @property
    def steps_per_control(self) -> int:
        """Plant steps per control period."""
        return int(round(self.control_period_s / self.plant_step_s))

    @property
    def max_steps(self) -> int:
        """Plant steps up to the time limit."""
        return int(math.ceil(self.time_limit_s / self.plant_step_s - 1e-9))


@dataclass(frozen=True)
class MetricsParams:
    """The ``[metrics]`` section.

    Attributes
    ----------
    settling_band_pct : float
        Settling band around the reference [% of the reference], > 0.
    divergence_factor : float
        A run whose force magnitude exceeds this many references is marked failed
        (unstable) [-], > 1.
    oscillation_window_s : float
        Trailing window of cutting time the oscillation test looks at [s], > 0.
    oscillation_threshold_pct : float
        AC amplitude of the force error over that window above which a run oscillates
        [% of the reference], > 0 (at least three sensor-noise standard deviations).
    oscillation_decay_ratio : float
        A stretch whose AC amplitude over its last window is below this fraction of the
        window before's is a decaying transient, not an oscillation [-], in (0, 1]: a damped
        oscillation ``exp(-sigma t)`` is flagged iff ``sigma <= ln(1 / ratio) / window``
        (:func:`acc.engine.metrics.judge_oscillation`).
    force_limit_N : float or None
        The machine's or tool's overload limit [N], > 0; None (the default) for none.  A run
        whose force exceeds it has ``overload = True``.
    overload_tolerance_pct : float
        A run whose force, averaged over a window of ``oscillation_window_s`` of cutting
        (after each segment's or event's first window; over a spindle revolution where the
        force is spindle-periodic), exceeds the reference by more than this [% of the
        reference], >= 0, has ``held_overload = True`` (and ``overload = True``, no
        productivity).
    excess_iae : bool
        Also compute ``excess_iae_N_s``, the IAE above the causal bound (about 10 ms per
        distinct plant, so off by default).
    """

    settling_band_pct: float = 2.0
    divergence_factor: float = 100.0
    oscillation_window_s: float = 2.0
    oscillation_threshold_pct: float = 10.0
    oscillation_decay_ratio: float = 0.5
    force_limit_N: float | None = None
    overload_tolerance_pct: float = 10.0
    excess_iae: bool = False

    def __post_init__(self) -> None:
        if not self.settling_band_pct > 0:
            raise ValueError("settling_band_pct must be > 0")
        if not self.divergence_factor > 1:
            raise ValueError("divergence_factor must be > 1")
        if not self.oscillation_window_s > 0:
            raise ValueError(f"oscillation_window_s must be > 0, got {self.oscillation_window_s}")
        if not self.oscillation_threshold_pct > 0:
            raise ValueError(
                f"oscillation_threshold_pct must be > 0, got {self.oscillation_threshold_pct}"
            )
        if self.force_limit_N is not None and not self.force_limit_N > 0:
            raise ValueError(f"force_limit_N must be > 0, got {self.force_limit_N}")
        if not 0 < self.oscillation_decay_ratio <= 1:
            raise ValueError(
                f"oscillation_decay_ratio must be in (0, 1], got {self.oscillation_decay_ratio}"
            )
        if not self.overload_tolerance_pct >= 0:
            raise ValueError(
                f"overload_tolerance_pct must be >= 0, got {self.overload_tolerance_pct}"
            )


@dataclass(frozen=True)
class Scenario:
    """One closed-loop run, fully specified."""

    simulation: SimulationParams = field(default_factory=SimulationParams)
    feed_drive: FeedDriveParams = field(default_factory=FeedDriveParams)
    force_process: ForceProcessTable = field(default_factory=ForceProcessTable)
    workpiece: Workpiece = field(default_factory=Workpiece)
    sensor: ForceSensorParams = field(default_factory=ForceSensorParams)
    nominal_plant: NominalPlant = field(default_factory=NominalPlant)
    controller: ControllerParams = field(default_factory=ControllerParams)
    metrics: MetricsParams = field(default_factory=MetricsParams)
    geometry: GeometricProcessParams = field(default_factory=GeometricProcessParams)
    cutting_coefficients: CuttingCoefficients = field(default_factory=CuttingCoefficients)
    current_sensing: CurrentSensingParams = field(default_factory=CurrentSensingParams)
    tool_breakage: BreakageMonitorParams = field(default_factory=BreakageMonitorParams)
    design: DesignSet = field(default_factory=DesignSet)
    disturbances: tuple[Disturbance, ...] = ()
    source: str = field(default="<defaults>", compare=False)

    def __post_init__(self) -> None:
        from acc.scenarios.checks import check_scenario

        check_scenario(self)  # what the simulation assumes (cross-section conditions)

    @property
    def delay_steps(self) -> int:
        """Feed-drive dead time in whole plant steps."""
        return dead_time_steps(
            self.feed_drive.dead_time_s,
            self.simulation.plant_step_s,
            self.simulation.dead_time_rounding,
        )

    def to_dict(self) -> dict[str, Any]:
        """All sections with every key resolved (defaults filled), TOML-friendly; the
        disturbances as the list ``disturbance`` of tables (omitted when there are none)."""
        out: dict[str, Any] = {name: section_values(getattr(self, name)) for name in SECTIONS}
        if self.disturbances:
            out[DISTURBANCE_LIST] = [section_values(d) for d in self.disturbances]
        return out

    def disturbance(self, name: str) -> Disturbance:
        """The disturbance called ``name`` (KeyError listing the names)."""
        for d in self.disturbances:
            if d.name == name:
                return d
        known = ", ".join(d.name for d in self.disturbances) or "none"
        raise KeyError(f"no disturbance named {name!r} (disturbances: {known})")

    def with_values(self, values: dict[str, Any], source: str | None = None) -> Scenario:
        """A copy with ``{"section.key": value}`` changed, validated as a file would be.

        ``"disturbance"`` replaces the whole disturbance list (a list of tables);
        ``"disturbance.<name>.<key>"`` changes one key of the disturbance called ``name``.

        Parameters
        ----------
        values : dict
        source : str or None
            Where the values come from, for errors (e.g. ``"--set"``); default: the
            scenario's own source.  The copy keeps the scenario's source.
        """
        blame = self.source if source is None else source
        data = self.to_dict()
        for dotted, value in values.items():
            section, _, key = str(dotted).partition(".")
            if section == DISTURBANCE_LIST:
                _set_disturbance(data, key, value, blame)
                continue
            if not key:
                raise ScenarioError.at(
                    blame, abbreviate(dotted), "expected 'section.key'"
                )
            data.setdefault(section, {})[key] = value
        try:
            return scenario_from_dict(data, source=self.source)
        except ScenarioError as exc:
            if source is None:
                raise
            raise exc.blame(source, instead_of=self.source) from None


#: The scenario's list of tables: ``[[disturbance]]`` entries
#: (:class:`plants.disturbance.Disturbance`).
DISTURBANCE_LIST = "disturbance"


def _set_disturbance(data: dict[str, Any], key: str, value: Any, source: str) -> None:
    """Apply ``disturbance`` (whole list) or ``disturbance.<name>.<key>`` to parsed data."""
    if not key:
        data[DISTURBANCE_LIST] = value
        return
    name, _, field_name = key.partition(".")
    if not field_name:
        raise ScenarioError(
            f"{source}: disturbance.{key}: expected disturbance.<name>.<key> or disturbance"
        )
    entries = data.get(DISTURBANCE_LIST, [])
    for entry in entries:
        if entry.get("name") == name:
            entry[field_name] = value
            return
    known = ", ".join(str(e.get("name")) for e in entries) or "none"
    raise ScenarioError(f"{source}: disturbance.{key}: no disturbance named {name!r} ({known})")


def _disturbances(raw: Any, source: str) -> tuple[Disturbance, ...]:
    """The ``[[disturbance]]`` list, validated; unnamed entries are called ``d<index>``."""
    if not isinstance(raw, list):
        raise ScenarioError(f"{source}: disturbance: expected a list of tables ([[disturbance]])")
    out = []
    for i, table in enumerate(raw):
        where = f"disturbance[{i}]"
        if isinstance(table, dict) and not table.get("name"):
            table = {**table, "name": f"d{i}"}
        entry = _section(Disturbance, table, where, source)
        out.append(entry)
    names = [d.name for d in out]
    for name in names:
        if names.count(name) > 1:
            raise ScenarioError(f"{source}: disturbance: the name {name!r} is used twice")
    return tuple(out)


SECTIONS: dict[str, type] = {
    "simulation": SimulationParams,
    "feed_drive": FeedDriveParams,
    "force_process": ForceProcessTable,
    "workpiece": Workpiece,
    "sensor": ForceSensorParams,
    "nominal_plant": NominalPlant,
    "controller": ControllerParams,
    "metrics": MetricsParams,
    "geometry": GeometricProcessParams,
    "cutting_coefficients": CuttingCoefficients,
    "current_sensing": CurrentSensingParams,
    "tool_breakage": BreakageMonitorParams,
    "design": DesignSet,
}


def field_types(cls: type) -> dict[str, Any]:
    """The keys of a section class and their types.

    A section is a frozen dataclass; one whose keys are not just its fields (the
    ``[controller]`` section, whose keys come from the registered kinds) provides a
    ``field_types()`` classmethod, and ``from_values``, ``replace_values`` and ``to_values``.
    """
    hook = getattr(cls, "field_types", None)
    if hook is not None:
        return dict(hook())
    return _dataclass_types(cls)


@functools.cache
def _dataclass_types(cls: type) -> dict[str, Any]:
    hints = typing.get_type_hints(cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls)}


def build_section(cls: type, values: dict[str, Any]) -> Any:
    """A section object from ``{key: value}`` (already converted), validated."""
    hook = getattr(cls, "from_values", None)
    return hook(values) if hook is not None else cls(**values)


def replace_section(obj: Any, values: dict[str, Any]) -> Any:
    """A section object with some keys changed, validated."""
    hook = getattr(obj, "replace_values", None)
    return hook(values) if hook is not None else dataclasses.replace(obj, **values)


def section_values(obj: Any) -> dict[str, Any]:
    """A section's keys and values, defaults filled, TOML-friendly (lists, no None)."""
    hook = getattr(obj, "to_values", None)
    values = hook() if hook is not None else dataclasses.asdict(obj)
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in values.items() if v is not None}


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", str(tp))


def _number_problem(value: float) -> str | None:
    """Why a number is not accepted (non-finite, or magnitude outside the limits), or None."""
    if not math.isfinite(value):
        return f"must be a finite number, got {value}"
    lo, hi = MAGNITUDE_RANGE
    if value != 0 and not lo <= abs(value) <= hi:
        return (
            f"magnitude of {value:.6g} is outside the accepted range {lo:g}..{hi:g} "
            "(limit; 0 is allowed)"
        )
    return None


def coerce_value(value: Any, tp: Any, where: str) -> Any:
    """Check and convert one TOML value to a field type (ScenarioError naming ``where``).

    Every number must be finite, and a non-zero one within
    :data:`acc.limits.MAGNITUDE_RANGE`; whole numbers fit in 64 bits; lists hold at most
    :data:`acc.limits.MAX_LIST_ITEMS` items.  Long values are abbreviated in the message.

    Parameters
    ----------
    value : Any
    tp : type
        The field's type (``float``, ``int``, ``bool``, ``str``, ``tuple[T, ...]``,
        ``T | None``).
    where : str
        ``"<source>: <section.key>"``, the start of the message.
    """
    source, sep, key = where.rpartition(": ")
    if not sep:
        source, key = where, None
    return _coerce(value, tp, source, key or "", key)


def _coerce(value: Any, tp: Any, source: str, at: str, key: str | None) -> Any:
    def fail(detail: str) -> ScenarioError:
        err = ScenarioError.at(source, at, detail)
        err.key = key
        return err

    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return _coerce(value, args[0], source, at, key)
    if origin is tuple:
        (item_tp, _) = typing.get_args(tp)
        if not isinstance(value, list | tuple):
            raise fail(f"expected a list of {_type_name(item_tp)}, got {abbreviate(value)}")
        if len(value) > MAX_LIST_ITEMS:
            raise fail(f"{len(value)} items; at most {MAX_LIST_ITEMS} (limit)")
        if item_tp is float:  # a float that passes as it is skips the item's path and checks
            lo, hi = MAGNITUDE_RANGE
            return tuple(
                v if type(v) is float and (v == 0 or lo <= abs(v) <= hi)  # NaN, inf fail
                else _coerce(v, float, source, f"{at}[{i}]", key)
                for i, v in enumerate(value)
            )
        return tuple(
            _coerce(v, item_tp, source, f"{at}[{i}]", key) for i, v in enumerate(value)
        )
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise fail(f"expected a number, got {abbreviate(value)}")
        if isinstance(value, int) and abs(value) > MAX_INTEGER:
            raise fail(f"{abbreviate(value)} is outside 64-bit integers")
        number = float(value)
        problem = _number_problem(number)
        if problem is not None:
            raise fail(problem)
        return number
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise fail(f"expected a whole number, got {abbreviate(value)}")
        if abs(value) > MAX_INTEGER:
            raise fail(f"{abbreviate(value)} is outside 64-bit integers (|n| <= 2**63-1)")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise fail(f"expected true or false, got {abbreviate(value)}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise fail(f"expected a string, got {abbreviate(value)}")
        return value
    raise TypeError(f"unsupported field type {tp!r} at {at}")  # pragma: no cover


def coerce_key(section: str, key: str, value: Any, tp: Any, source: str) -> Any:
    """:func:`coerce_value` for ``section.key`` of ``source``."""
    dotted = f"{section}.{key}"
    return _coerce(value, tp, source, dotted, dotted)


def _field_named(message: str, names: Any) -> str | None:
    """The field a validation message is about: the first field name it mentions."""
    best: tuple[int, int, str] | None = None
    for name in names:
        m = re.search(rf"(?<![A-Za-z0-9_]){re.escape(name)}(?![A-Za-z0-9_])", message)
        if m and (best is None or (m.start(), -len(name)) < best[:2]):
            best = (m.start(), -len(name), name)
    return None if best is None else best[2]


def section_error(source: str, section: str, cls: type, exc: Exception) -> ScenarioError:
    """A section's validation error (ValueError from ``__post_init__``) as a
    :class:`ScenarioError` naming ``section.key`` (the field the message mentions first)."""
    message = shorten(str(exc), 4 * MAX_SHOWN_CHARS)
    name = _field_named(message, field_types(cls))
    key = f"{section}.{name}" if name else f"[{section}]"
    return ScenarioError.at(source, key, message)


def _section(cls: type, table: Any, section: str, source: str) -> Any:
    if not isinstance(table, dict):
        raise ScenarioError.at(
            source, f"[{section}]", f"must be a table, got {abbreviate(table)}"
        )
    hints = field_types(cls)
    kwargs = {}
    for key, value in table.items():
        if key not in hints:
            raise ScenarioError.at(
                source,
                f"{section}.{shorten(key, 40)}",
                unknown_name("key", key, hints),
            )
        kwargs[key] = coerce_key(section, key, value, hints[key], source)
    try:
        return build_section(cls, kwargs)
    except ValueError as exc:
        raise section_error(source, section, cls, exc) from None


def scenario_from_dict(data: dict[str, Any], source: str = "<dict>") -> Scenario:
    """Build and validate a scenario from nested ``{section: {key: value}}``.

    Raises
    ------
    ScenarioError
        Unknown section or key, wrong type or impossible value.
    """
    if not isinstance(data, dict):
        raise ScenarioError.at(source, None, f"expected a table, got {abbreviate(data)}")
    for section in data:
        if section not in SECTIONS and section != DISTURBANCE_LIST:
            raise ScenarioError.at(
                source,
                f"[{shorten(section, 40)}]",
                unknown_name("section", section, [*SECTIONS, DISTURBANCE_LIST]),
            )
    parts = {
        name: _section(cls, data.get(name, {}), name, source) for name, cls in SECTIONS.items()
    }
    disturbances = _disturbances(data.get(DISTURBANCE_LIST, []), source)
    return Scenario(**parts, disturbances=disturbances, source=source)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file.

    Parameters
    ----------
    path : str or Path

    Raises
    ------
    ScenarioError
        Missing or unreadable file, not UTF-8, TOML syntax error, unknown key, wrong type,
        impossible value (:mod:`acc.inputs`).
    """
    p = Path(path)
    return scenario_from_dict(read_toml(p, "scenario"), source=str(p))


__all__ = [
    "MetricsParams",
    "SECTIONS",
    "Scenario",
    "ScenarioError",
    "SimulationParams",
    "build_section",
    "coerce_key",
    "coerce_value",
    "field_types",
    "load_scenario",
    "parse_assignment",
    "replace_section",
    "scenario_from_dict",
    "section_error",
    "section_values",
]
