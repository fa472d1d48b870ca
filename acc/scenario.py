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

and a list of tables ``[[disturbance]]`` (:class:`plants.disturbance.Disturbance`), addressed
as ``disturbance.<name>.<key>`` by ``--set`` and campaigns.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import sys
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from acc.engine.current_sensing import CurrentSensingParams
from acc.errors import ScenarioError
from controllers.registry import ControllerParams, controller_kind
from plants.cutting_coefficients import CuttingCoefficients
from plants.disturbance import Disturbance
from plants.feed_drive import DeadTimeError, FeedDriveParams, dead_time_steps
from plants.force_process import ForceProcessTable, OutOfTableError
from plants.force_sensor import ForceSensorParams
from plants.geometric_process import GeometricProcessParams, check_regulable
from plants.nominal_plant import NominalPlant
from plants.workpiece import Workpiece

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


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
        if not self.plant_step_s > 0:
            raise ValueError(f"plant_step_s must be > 0, got {self.plant_step_s}")
        if not self.control_period_s > 0:
            raise ValueError(f"control_period_s must be > 0, got {self.control_period_s}")
        ratio = self.control_period_s / self.plant_step_s
        if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
            raise ValueError(
                f"control_period_s = {self.control_period_s} is not a whole multiple of "
                f"plant_step_s = {self.plant_step_s} ({ratio:.6g} steps)"
            )
        if not self.time_limit_s > 0:
            raise ValueError(f"time_limit_s must be > 0, got {self.time_limit_s}")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}")
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
    force_limit_N : float
        The machine's or tool's overload limit [N]; ``inf`` (the default) for none.  A run
        whose force exceeds it has ``overload = True``.
    """

    settling_band_pct: float = 2.0
    divergence_factor: float = 100.0
    oscillation_window_s: float = 2.0
    oscillation_threshold_pct: float = 5.0
    force_limit_N: float = math.inf

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
        if not self.force_limit_N > 0:
            raise ValueError(f"force_limit_N must be > 0, got {self.force_limit_N}")


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
    disturbances: tuple[Disturbance, ...] = ()
    source: str = field(default="<defaults>", compare=False)

    def __post_init__(self) -> None:
        try:
            self.delay_steps  # noqa: B018  (validates the dead time)
        except DeadTimeError as exc:
            raise ScenarioError(f"{self.source}: feed_drive.dead_time_s: {exc}") from None
        try:
            for depth in self.workpiece.radial_depth_mm:
                self.force_process.check_depth(depth)
            if self.force_process.out_of_table == "extrapolate":  # K2 > 0, p2 < 0 there too
                self.force_process.parameters(
                    [d for d in self.workpiece.radial_depth_mm if d > 0]
                )
        except OutOfTableError as exc:
            raise ScenarioError(f"{self.source}: workpiece.radial_depth_mm: {exc}") from None
        if controller_kind(self.controller.kind).delays_by_nominal_dead_time:
            try:  # the observer and estimator delay the command by whole control periods
                dead_time_steps(
                    self.nominal_plant.dead_time_s,
                    self.simulation.control_period_s,
                    self.simulation.dead_time_rounding,
                )
            except DeadTimeError as exc:
                raise ScenarioError(
                    f"{self.source}: nominal_plant.dead_time_s: {exc} (control periods of the "
                    f"{self.controller.kind!r} controller)"
                ) from None
        if self.geometry.enabled:
            self._check_geometry()

    def _check_geometry(self) -> None:
        """The geometric process must be able to cut this part and be regulable."""
        part = self.workpiece
        cutting = [
            i
            for i, (ae, ap) in enumerate(
                zip(part.radial_depth_mm, part.axial_depth_mm, strict=True)
            )
            if ae > 0 and ap > 0
        ]
        ae = np.array([part.radial_depth_mm[i] for i in cutting])
        ap = np.array([part.axial_depth_mm[i] for i in cutting])
        if ae.size and ae.max() > self.geometry.diameter_mm:
            raise ScenarioError(
                f"{self.source}: workpiece.radial_depth_mm: {ae.max():g} mm exceeds the tool "
                f"diameter geometry.diameter_mm = {self.geometry.diameter_mm:g} mm"
            )
        try:
            check_regulable(
                self.geometry,
                self.cutting_coefficients,
                ae,
                ap,
                self.controller.programmed_feed_mm_min,
            )
        except ValueError as exc:
            raise ScenarioError(f"{self.source}: geometry.component: {exc}") from None
        if self.current_sensing.enabled and self.geometry.component != "feed":
            raise ScenarioError(
                f"{self.source}: current_sensing.enabled: the feed-motor current measures the "
                f"feed force; set geometry.component = 'feed' (got {self.geometry.component!r})"
            )

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

    def with_values(self, values: dict[str, Any]) -> Scenario:
        """A copy with ``{"section.key": value}`` changed, validated as a file would be.

        ``"disturbance"`` replaces the whole disturbance list (a list of tables);
        ``"disturbance.<name>.<key>"`` changes one key of the disturbance called ``name``.
        """
        data = self.to_dict()
        for dotted, value in values.items():
            section, _, key = dotted.partition(".")
            if section == DISTURBANCE_LIST:
                _set_disturbance(data, key, value, self.source)
                continue
            if not key:
                raise ScenarioError(f"{self.source}: {dotted!r}: expected 'section.key'")
            data.setdefault(section, {})[key] = value
        return scenario_from_dict(data, source=self.source)


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


def coerce_value(value: Any, tp: Any, where: str) -> Any:
    """Check and convert one TOML value to a field type (ScenarioError naming ``where``)."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return coerce_value(value, args[0], where)
    if origin is tuple:
        (item_tp, _) = typing.get_args(tp)
        if not isinstance(value, list | tuple):
            raise ScenarioError(f"{where}: expected a list of {_type_name(item_tp)}, got {value!r}")
        return tuple(coerce_value(v, item_tp, f"{where}[{i}]") for i, v in enumerate(value))
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ScenarioError(f"{where}: expected a number, got {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ScenarioError(f"{where}: expected a whole number, got {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ScenarioError(f"{where}: expected true or false, got {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ScenarioError(f"{where}: expected a string, got {value!r}")
        return value
    raise TypeError(f"unsupported field type {tp!r} at {where}")  # pragma: no cover


def _section(cls: type, table: Any, section: str, source: str) -> Any:
    if not isinstance(table, dict):
        raise ScenarioError(f"{source}: [{section}] must be a table, got {table!r}")
    hints = field_types(cls)
    kwargs = {}
    for key, value in table.items():
        if key not in hints:
            raise ScenarioError(
                f"{source}: {section}.{key}: unknown key (known: {', '.join(hints)})"
            )
        kwargs[key] = coerce_value(value, hints[key], f"{source}: {section}.{key}")
    try:
        return build_section(cls, kwargs)
    except ValueError as exc:
        raise ScenarioError(f"{source}: [{section}] {exc}") from None


def scenario_from_dict(data: dict[str, Any], source: str = "<dict>") -> Scenario:
    """Build and validate a scenario from nested ``{section: {key: value}}``.

    Raises
    ------
    ScenarioError
        Unknown section or key, wrong type or impossible value.
    """
    for section in data:
        if section not in SECTIONS and section != DISTURBANCE_LIST:
            known = ", ".join([*SECTIONS, DISTURBANCE_LIST])
            raise ScenarioError(f"{source}: [{section}]: unknown section (known: {known})")
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
        Missing file, TOML syntax error, unknown key, wrong type, impossible value.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{p}: no such scenario file") from None
    except OSError as exc:
        raise ScenarioError(f"{p}: cannot read: {exc.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{p}: not valid TOML: {exc}") from None
    return scenario_from_dict(data, source=str(p))


def parse_assignment(text: str) -> tuple[str, Any]:
    """Parse a command-line ``section.key=value``; the value is read as TOML, else a string.

    Examples
    --------
    >>> parse_assignment("controller.reference_force_N=450")
    ('controller.reference_force_N', 450)
    >>> parse_assignment("workpiece.radial_depth_mm=[2, 4]")
    ('workpiece.radial_depth_mm', [2, 4])
    """
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or "." not in key:
        raise ScenarioError(f"--set {text!r}: expected section.key=value")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    return key, value


__all__ = [
    "MetricsParams",
    "SECTIONS",
    "Scenario",
    "ScenarioError",
    "SimulationParams",
    "build_section",
    "coerce_value",
    "field_types",
    "load_scenario",
    "parse_assignment",
    "replace_section",
    "scenario_from_dict",
    "section_values",
]
