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
=================  =====================================================================
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

import numpy as np

from acc.engine.current_sensing import CurrentSensingParams
from acc.errors import ScenarioError
from acc.inputs import parse_assignment, read_toml
from acc.limits import (
    MAGNITUDE_RANGE,
    MAX_DELAY_STEPS,
    MAX_INTEGER,
    MAX_LIST_ITEMS,
    MAX_PLANT_STEPS,
    MAX_SHOWN_CHARS,
    abbreviate,
    shorten,
)
from controllers.registry import ControllerParams, controller_kind
from plants.cutting_coefficients import CuttingCoefficients
from plants.feed_drive import DeadTimeError, FeedDriveParams, dead_time_steps
from plants.force_process import ForceProcessTable, OutOfTableError
from plants.force_sensor import ForceSensorParams
from plants.geometric_process import GeometricProcessParams, check_regulable
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
    """

    settling_band_pct: float = 2.0
    divergence_factor: float = 100.0

    def __post_init__(self) -> None:
        if not self.settling_band_pct > 0:
            raise ValueError("settling_band_pct must be > 0")
        if not self.divergence_factor > 1:
            raise ValueError("divergence_factor must be > 1")


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
    source: str = field(default="<defaults>", compare=False)

    def __post_init__(self) -> None:
        check_scenario(self)

    @property
    def delay_steps(self) -> int:
        """Feed-drive dead time in whole plant steps."""
        return dead_time_steps(
            self.feed_drive.dead_time_s,
            self.simulation.plant_step_s,
            self.simulation.dead_time_rounding,
        )

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """All sections with every key resolved (defaults filled), TOML-friendly."""
        return {name: section_values(getattr(self, name)) for name in SECTIONS}

    def with_values(self, values: dict[str, Any], source: str | None = None) -> Scenario:
        """A copy with ``{"section.key": value}`` changed, validated as a file would be.

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
                f"unknown key (known: {', '.join(hints)})",
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
        if section not in SECTIONS:
            raise ScenarioError.at(
                source,
                f"[{shorten(section, 40)}]",
                f"unknown section (known: {', '.join(SECTIONS)})",
            )
    parts = {
        name: _section(cls, data.get(name, {}), name, source) for name, cls in SECTIONS.items()
    }
    return Scenario(**parts, source=source)


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


# --- cross-section checks: what the simulation assumes ---------------------------------
def check_scenario(scenario: Scenario) -> None:
    """Every condition a run of ``scenario`` relies on, checked before any run.

    A scenario that passes is simulated without an exception: dead times are whole steps
    and fit :data:`acc.limits.MAX_DELAY_STEPS`; every cut depth is in the process table;
    the PI design, the safe constant feed and its machining time can be computed; the
    geometric model can cut the part and is regulable; the current-sensing speed loop and
    air-cut identification work at this plant step.

    Raises
    ------
    ScenarioError
        Naming the file and the key to change.
    """
    src = scenario.source
    sim = scenario.simulation
    try:
        delay = scenario.delay_steps
    except DeadTimeError as exc:
        raise ScenarioError.at(src, "feed_drive.dead_time_s", str(exc)) from None
    if delay > MAX_DELAY_STEPS:
        raise ScenarioError.at(
            src,
            "feed_drive.dead_time_s",
            f"{scenario.feed_drive.dead_time_s} s is {delay} plant steps (limit "
            f"{MAX_DELAY_STEPS:.0e} steps of delay line)",
        )
    part = scenario.workpiece
    try:
        for depth in part.radial_depth_mm:
            scenario.force_process.check_depth(depth)
        if scenario.force_process.out_of_table == "extrapolate":  # K2 > 0, p2 < 0 there too
            scenario.force_process.parameters([d for d in part.radial_depth_mm if d > 0])
    except OutOfTableError as exc:
        raise ScenarioError.at(src, "workpiece.radial_depth_mm", str(exc)) from None
    if controller_kind(scenario.controller.kind).delays_by_nominal_dead_time:
        try:  # the observer and estimator delay the command by whole control periods
            periods = dead_time_steps(
                scenario.nominal_plant.dead_time_s,
                sim.control_period_s,
                sim.dead_time_rounding,
            )
        except DeadTimeError as exc:
            raise ScenarioError.at(
                src,
                "nominal_plant.dead_time_s",
                f"{exc} (control periods of the {scenario.controller.kind!r} controller)",
            ) from None
        if periods > MAX_DELAY_STEPS:
            raise ScenarioError.at(
                src,
                "nominal_plant.dead_time_s",
                f"{scenario.nominal_plant.dead_time_s} s is {periods} control periods "
                f"(limit {MAX_DELAY_STEPS:.0e})",
            )
    _check_design(scenario)
    if scenario.geometry.enabled:
        _check_geometry(scenario)
    else:
        _check_conventional(scenario)
    if scenario.current_sensing.enabled:
        _check_current_sensing(scenario)


def _check_design(scenario: Scenario) -> None:
    """The PI design on the nominal plant succeeds and gives finite gains."""
    from controllers.registry import resolved_gains

    try:
        gains = resolved_gains(
            scenario.controller, scenario.nominal_plant, scenario.simulation.control_period_s
        )
        ok = math.isfinite(gains.kp_per_N) and math.isfinite(gains.ki_per_N_s)
        why = f"gains kp = {gains.kp_per_N:.3g}, ki = {gains.ki_per_N_s:.3g}"
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        ok, why = False, str(exc)
    if not ok:
        raise ScenarioError.at(
            scenario.source,
            "controller.design_phase_margin_deg",
            f"the PI design on the nominal plant (nominal_plant.*, programmed feed, control "
            f"period) fails: {why}; give controller.kp_per_N and ki_per_N_s",
        )


def _check_conventional(scenario: Scenario) -> None:
    """The safe constant feed of the table process and its machining time are finite."""
    from acc.engine.metrics import constant_feed_time_s, safe_feed_mm_min

    part = scenario.workpiece
    gains = scenario.force_process.static_gain_N_per_mm_min(part.radial_depth_mm)
    _check_safe_feed(
        scenario,
        lambda: safe_feed_mm_min(scenario.controller.reference_force_N, gains),
        constant_feed_time_s,
    )


def _check_safe_feed(scenario: Scenario, safe_feed: Any, travel_time: Any) -> None:
    src = scenario.source
    try:
        feed = float(safe_feed())
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        raise ScenarioError.at(
            src, "controller.reference_force_N", f"no safe constant feed: {exc}"
        ) from None
    if not (math.isfinite(feed) and feed > 0):
        raise ScenarioError.at(
            src,
            "controller.reference_force_N",
            f"{scenario.controller.reference_force_N:g} N gives no safe constant feed "
            f"(got {feed:.3g} mm/min): the force at zero feed already reaches it, or the "
            "process gains are out of proportion",
        )
    try:
        t = travel_time(
            scenario.workpiece.length_mm,
            feed,
            scenario.feed_drive.bandwidth_rad_s,
            scenario.delay_steps * scenario.simulation.plant_step_s,
        )
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        t, reason = math.nan, str(exc)
    else:
        reason = f"{t:.3g} s"
    if not math.isfinite(t):
        raise ScenarioError.at(
            src,
            "feed_drive.bandwidth_rad_s",
            f"the machining time at the safe constant feed cannot be computed ({reason})",
        )


def _check_geometry(scenario: Scenario) -> None:
    """The geometric process must be able to cut this part and be regulable."""
    src = scenario.source
    part = scenario.workpiece
    cutting = [
        i
        for i, (ae, ap) in enumerate(zip(part.radial_depth_mm, part.axial_depth_mm, strict=True))
        if ae > 0 and ap > 0
    ]
    if not cutting:
        raise ScenarioError.at(
            src,
            "workpiece.axial_depth_mm",
            "no segment cuts with the geometric model (it needs a segment with radial and "
            "axial depth both > 0)",
        )
    ae = np.array([part.radial_depth_mm[i] for i in cutting])
    ap = np.array([part.axial_depth_mm[i] for i in cutting])
    if ae.max() > scenario.geometry.diameter_mm:
        raise ScenarioError.at(
            src,
            "workpiece.radial_depth_mm",
            f"{ae.max():g} mm exceeds the tool diameter geometry.diameter_mm = "
            f"{scenario.geometry.diameter_mm:g} mm",
        )
    try:
        with np.errstate(all="ignore"):
            check_regulable(
                scenario.geometry,
                scenario.cutting_coefficients,
                ae,
                ap,
                scenario.controller.programmed_feed_mm_min,
            )
    except ValueError as exc:
        raise ScenarioError.at(src, "geometry.component", str(exc)) from None
    if scenario.current_sensing.enabled and scenario.geometry.component != "feed":
        raise ScenarioError.at(
            src,
            "current_sensing.enabled",
            "the feed-motor current measures the feed force; set geometry.component = "
            f"'feed' (got {scenario.geometry.component!r})",
        )
    _check_safe_feed(scenario, lambda: _geometric_safe_feed(scenario), _travel_time())


def _travel_time() -> Any:
    from acc.engine.metrics import constant_feed_time_s

    return constant_feed_time_s


def _geometric_safe_feed(scenario: Scenario) -> float:
    part = scenario.workpiece
    key = (
        scenario.geometry,
        scenario.cutting_coefficients,
        part.radial_depth_mm,
        part.axial_depth_mm,
        scenario.controller.reference_force_N,
    )
    return _geometric_safe_feed_cached(*key)


@functools.lru_cache(maxsize=1024)
def _geometric_safe_feed_cached(
    geometry: GeometricProcessParams,
    coefficients: CuttingCoefficients,
    radial: tuple[float, ...],
    axial: tuple[float, ...],
    reference_force_N: float,
) -> float:
    from plants.geometric_process import GeometricForceOutput

    rows = np.zeros((1, len(radial) + 1)), np.zeros((1, len(radial) + 1))
    rows[0][0, :-1] = radial
    rows[1][0, :-1] = axial
    with np.errstate(all="ignore"):
        out = GeometricForceOutput(geometry, coefficients, rows[0], rows[1], 1.0)
        return out.safe_feed_mm_min(reference_force_N, 0)


def _check_current_sensing(scenario: Scenario) -> None:
    """The speed loop is stable at this step and the air cuts identify the drive."""
    from plants.motor_drive import check_speed_loop

    src = scenario.source
    cs = scenario.current_sensing
    dt = scenario.simulation.plant_step_s
    try:
        check_speed_loop(cs.speed_loop_bandwidth_rad_s, dt)
    except ValueError as exc:
        raise ScenarioError.at(
            src,
            "current_sensing.speed_loop_bandwidth_rad_s",
            f"{exc} (the discrete speed loop's limit; at plant_step_s = {dt} s the bandwidth "
            f"can be at most {0.5 / dt:.6g} rad/s)",
        ) from None
    n = round(cs.identification_time_s / dt)
    if n < MIN_IDENTIFICATION_STEPS:
        raise ScenarioError.at(
            src,
            "current_sensing.identification_time_s",
            f"{cs.identification_time_s} s is {n} plant steps per air cut; the identification "
            f"needs at least {MIN_IDENTIFICATION_STEPS}",
        )
    total = n * len(cs.identification_feeds_mm_min)
    if total > MAX_PLANT_STEPS:
        raise ScenarioError.at(
            src,
            "current_sensing.identification_time_s",
            f"the air cuts take {total:.3g} plant steps (limit {MAX_PLANT_STEPS:.0e})",
        )
    why = _identification_problem(cs, dt)
    if why is not None:
        raise ScenarioError.at(
            src, "current_sensing.identification_feeds_mm_min", f"air-cut identification: {why}"
        )


#: Fewest plant steps of one identification air cut.
MIN_IDENTIFICATION_STEPS = 10


@functools.lru_cache(maxsize=256)
def _identification_problem(params: CurrentSensingParams, plant_step_s: float) -> str | None:
    """Why the (noise-free) air-cut identification fails, or None; the noise of a run only
    changes the measured currents, not the regressors."""
    from acc.engine.current_sensing import identify_feed_drives
    from plants.motor_drive import BallScrew, ServoMotor

    try:
        with np.errstate(all="ignore"):
            (drive,) = identify_feed_drives(
                dataclasses.replace(params, current_noise_std_A=0.0),
                ServoMotor(),
                BallScrew(),
                plant_step_s,
                [0],
                [0],
            )
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return str(exc)
    values = (
        drive.effective_inertia_kg_m2,
        drive.viscous_friction_Nm_s_rad,
        drive.coulomb_friction_Nm,
    )
    if not all(math.isfinite(v) for v in values):
        return f"the identified drive is not finite ({values})"
    return None


__all__ = [
    "MetricsParams",
    "SECTIONS",
    "Scenario",
    "ScenarioError",
    "SimulationParams",
    "build_section",
    "check_scenario",
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
