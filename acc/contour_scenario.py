"""Contouring scenarios: a TOML file whose ``[simulation] model = "xy_contour"`` runs two of
Peng's servo axes along an interpolated path (spec §5.5).

Sections (every key optional; defaults in the dataclasses)::

    [simulation]            model = "xy_contour", plant_step_s (0.001; also the control
                            period and the interpolator's clock)
    [path]                  :class:`controllers.contouring.interpolator.PathParams` keys
    [servo_axis]            :class:`plants.axis.servo_axis.ServoAxisParams` keys, both axes
    [servo_axis.x], [servo_axis.y]
                            per-axis overrides of [servo_axis] (e.g. Peng's mismatched
                            ``viscous_friction_Nm_s_rad = 0.3`` on y)
    [position_controller]   kind: "lead_lag" or "pid" (both axes)
    [lead_lag]              :class:`controllers.axis.lead_lag.LeadLagParams` keys
    [pid]                   :class:`controllers.axis.pid.AxisPIDParams` keys
    [integrator_switching]  Peng's switched integral action around the corner: the integrator
                            of the lead-lag is off from ``off_before_vertex_mm`` of path before
                            the vertex until ``on_after_vertex_mm`` after it
    [contour_controller]    kind: "none" or "cec" (Lacerda & Belo's cross-coupled controller,
                            run in the coupled XY loop), then
                            :class:`controllers.contouring.cross_coupled.CrossCoupledParams`
                            keys

Files go through the project's loader (:mod:`acc.inputs`) and key checks
(:func:`acc.scenario.coerce_key`): an unknown section or key, a wrong type or an impossible
value is a one-line error naming ``section.key``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from acc.errors import ScenarioError
from acc.limits import MAX_PLANT_STEPS, abbreviate, shorten
from controllers.axis.lead_lag import LeadLagParams
from controllers.axis.pid import AxisPIDParams
from controllers.contouring.cross_coupled import CrossCoupledParams
from controllers.contouring.interpolator import PathParams
from plants.axis.servo_axis import ServoAxisParams

#: Position-controller kinds and their parameter sections.
CONTROLLER_KINDS = {"lead_lag": "lead_lag", "pid": "pid"}


@dataclass(frozen=True)
class ContourSimulationParams:
    """``[simulation]`` of a contouring scenario.

    Attributes
    ----------
    model : {"xy_contour"}
    plant_step_s : float
        ``dt`` [s], > 0: the plant step, the control period and the interpolator's clock.
    """

    model: str = "xy_contour"
    plant_step_s: float = 0.001

    def __post_init__(self) -> None:
        if self.model != "xy_contour":
            raise ValueError(f"model must be 'xy_contour' here, got {self.model!r}")
        if not (math.isfinite(self.plant_step_s) and self.plant_step_s > 0):
            raise ValueError(f"plant_step_s must be > 0, got {self.plant_step_s!r}")


@dataclass(frozen=True)
class ContourControllerKind:
    """``[position_controller]``: the axes' position controller."""

    kind: str = "lead_lag"

    def __post_init__(self) -> None:
        if self.kind not in CONTROLLER_KINDS:
            raise ValueError(
                f"kind must be one of {', '.join(CONTROLLER_KINDS)}, got {self.kind!r}"
            )


@dataclass(frozen=True)
class IntegratorSwitching:
    """``[integrator_switching]``: Peng's integrator off around the corner (Sec. 4.4.2).

    Attributes
    ----------
    enabled : bool
        Apply the switching (a corner path and a lead-lag integrator needed).
    off_before_vertex_mm, on_after_vertex_mm : float
        Path distances from the vertex [mm], >= 0 (P_1 is not given in the thesis).
    when_off : {"frozen", "reset"}
    """

    enabled: bool = False
    off_before_vertex_mm: float = 1.0
    on_after_vertex_mm: float = 3.0
    when_off: str = "frozen"

    def __post_init__(self) -> None:
        for name in ("off_before_vertex_mm", "on_after_vertex_mm"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if self.when_off not in ("frozen", "reset"):
            raise ValueError(f"when_off must be 'frozen' or 'reset', got {self.when_off!r}")


@dataclass(frozen=True)
class ContourControllerSection(CrossCoupledParams):
    """``[contour_controller]``: ``kind = "none" | "cec"`` plus the CEC's parameters."""

    kind: str = "none"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.kind not in ("none", "cec"):
            raise ValueError(f"kind must be 'none' or 'cec', got {self.kind!r}")

    @property
    def params(self) -> CrossCoupledParams:
        """The :class:`CrossCoupledParams` part."""
        names = [f.name for f in dataclasses.fields(CrossCoupledParams)]
        return CrossCoupledParams(**{n: getattr(self, n) for n in names})


#: Section name -> its class, in file order.
CONTOUR_SECTIONS: dict[str, type] = {
    "simulation": ContourSimulationParams,
    "path": PathParams,
    "servo_axis": ServoAxisParams,
    "position_controller": ContourControllerKind,
    "lead_lag": LeadLagParams,
    "pid": AxisPIDParams,
    "integrator_switching": IntegratorSwitching,
    "contour_controller": ContourControllerSection,
}


@dataclass(frozen=True)
class ContourScenario:
    """A validated contouring scenario (one object per section; the two axes resolved)."""

    simulation: ContourSimulationParams
    path: PathParams
    axis_x: ServoAxisParams
    axis_y: ServoAxisParams
    position_controller: ContourControllerKind
    lead_lag: LeadLagParams
    pid: AxisPIDParams
    integrator_switching: IntegratorSwitching
    contour_controller: ContourControllerSection
    source: str = "<dict>"

    @property
    def controller_params(self) -> LeadLagParams | AxisPIDParams:
        """The selected position controller's parameters."""
        return getattr(self, CONTROLLER_KINDS[self.position_controller.kind])

    def reference(self) -> Any:
        """The interpolated path (:class:`~controllers.contouring.interpolator.PathReference`)."""
        from controllers.contouring.interpolator import interpolate

        return interpolate(self.path, self.simulation.plant_step_s)

    def simulate(self) -> tuple[Any, Any, dict[str, Any]]:
        """``(reference, positions (n, 2), signals {name: (n,)})`` of the run.

        Independent axes run in :func:`acc.engine.contour_simulate.simulate_contouring`; with
        ``contour_controller.kind = "cec"`` the coupled loop
        :func:`acc.engine.xy_simulate.simulate_xy` runs instead.
        """
        import numpy as np

        ref = self.reference()
        ctrl = self.controller_params
        sw = self.integrator_switching
        if sw.enabled:
            from acc.engine.contour_simulate import switched_integrator

            ctrl = switched_integrator(ctrl, ref, sw.off_before_vertex_mm,
                                       sw.on_after_vertex_mm, sw.when_off)
        if self.contour_controller.kind == "cec":
            from acc.engine.xy_simulate import XYReference, simulate_xy

            dt = self.simulation.plant_step_s
            res = simulate_xy(self.axis_x, self.axis_y, ctrl, ctrl, XYReference.from_path(ref),
                              cec=self.contour_controller.params, plant_step_s=dt,
                              control_period_s=dt, command_limit_V=0.0)
            pos = np.stack([res.signals["x_mm"][0], res.signals["y_mm"][0]], axis=1)
            signals = {k: v[0] for k, v in res.signals.items()}
            signals["contour_error_mm"] = ref.exact_contour_error(pos)
            return ref, pos, signals
        from acc.engine.contour_simulate import simulate_contouring

        res = simulate_contouring(ref, self.axis_x, self.axis_y, ctrl)
        return ref, res.position_mm(0), {k: v[0] for k, v in res.signals.items()}


def is_contour_data(data: Any) -> bool:
    """True when a parsed file selects the contouring lab (``model = "xy_contour"``)."""
    sim = data.get("simulation") if isinstance(data, dict) else None
    return isinstance(sim, dict) and sim.get("model") == "xy_contour"


def contour_scenario_from_dict(data: dict[str, Any], source: str = "<dict>") -> ContourScenario:
    """Build and validate a contouring scenario from ``{section: {key: value}}``.

    Raises
    ------
    ScenarioError
        Unknown section or key, wrong type, non-finite number or impossible value, named in
        one line.
    """
    from acc.scenario import _section

    if not isinstance(data, dict):
        raise ScenarioError.at(source, None, f"expected a table, got {abbreviate(data)}")
    for section in data:
        if section not in CONTOUR_SECTIONS:
            raise ScenarioError.at(
                source, f"[{shorten(section, 40)}]",
                f"unknown section of a contouring scenario (known: {', '.join(CONTOUR_SECTIONS)})",
            )
    servo = data.get("servo_axis", {})
    if not isinstance(servo, dict):
        raise ScenarioError.at(source, "[servo_axis]", f"must be a table, got {abbreviate(servo)}")
    common = {k: v for k, v in servo.items() if k not in ("x", "y")}
    axes = {}
    for name in ("x", "y"):
        own = servo.get(name, {})
        if not isinstance(own, dict):
            raise ScenarioError.at(source, f"[servo_axis.{name}]",
                                   f"must be a table, got {abbreviate(own)}")
        axes[name] = _section(ServoAxisParams, {**common, **own}, f"servo_axis.{name}", source)
    parts = {name: _section(cls, data.get(name, {}), name, source)
             for name, cls in CONTOUR_SECTIONS.items() if name != "servo_axis"}
    scenario = ContourScenario(axis_x=axes["x"], axis_y=axes["y"], source=source, **parts)
    _check_combination(scenario, source)
    return scenario


def _check_combination(sc: ContourScenario, source: str) -> None:
    """Cross-section conditions, checked before any run (the path is interpolated once)."""
    try:
        ref = sc.reference()
    except ValueError as exc:
        msg = str(exc)
        key = next((f"path.{f.name}" for f in dataclasses.fields(PathParams)
                    if msg.startswith(f.name)), "[path]")
        raise ScenarioError.at(source, key, shorten(msg, 200)) from None
    if ref.samples > MAX_PLANT_STEPS:
        raise ScenarioError.at(source, "[path]", f"{ref.samples} samples; at most "
                               f"{MAX_PLANT_STEPS:g} (limit)")
    sw = sc.integrator_switching
    if sw.enabled:
        if not math.isfinite(ref.vertex_time_s):
            raise ScenarioError.at(source, "integrator_switching.enabled",
                                   "needs a corner path (square or diamond)")
        if sc.position_controller.kind != "lead_lag" or sc.lead_lag.integrator_form == "none":
            raise ScenarioError.at(source, "integrator_switching.enabled",
                                   "needs the lead_lag controller with an integrator_form")


def load_contour_scenario(path: str | Path) -> ContourScenario:
    """Read and validate a contouring scenario file (:mod:`acc.inputs` reads it)."""
    from acc.inputs import read_toml

    return contour_scenario_from_dict(read_toml(path, "scenario"), str(path))


def with_values(scenario: ContourScenario, values: dict[str, Any], data: dict[str, Any],
                source: str = "--set") -> ContourScenario:
    """``data`` (the file's tables) with ``{"section.key": value}`` changed, validated again."""
    merged = {k: dict(v) if isinstance(v, dict) else v for k, v in data.items()}
    for dotted, value in values.items():
        section, _, key = dotted.rpartition(".")
        if not section:
            raise ScenarioError.at(source, shorten(dotted, 60), "expected section.key")
        if section.startswith("servo_axis."):
            table = merged.setdefault("servo_axis", {})
            table.setdefault(section.split(".", 1)[1], {})[key] = value
        else:
            merged.setdefault(section, {})[key] = value
    return contour_scenario_from_dict(merged, source)


__all__ = [
    "CONTOUR_SECTIONS",
    "ContourScenario",
    "contour_scenario_from_dict",
    "is_contour_data",
    "load_contour_scenario",
    "with_values",
]
