"""Axis scenarios: a TOML file whose ``[simulation] model = "axis"`` selects the feed-axis lab.

Sections (every key optional; defaults in the dataclasses)::

    [simulation]           model = "axis", plant_step_s (0.001), control_period_s (0.001),
                           duration_s (1.0), seed (0)
    [axis]                 kind: "servo" (Peng's DC servo) or "oscillating" (Briquez)
    [servo_axis]           :class:`plants.axis.servo_axis.ServoAxisParams` keys
    [oscillating_axis]     :class:`plants.axis.oscillating_axis.OscillatingAxisParams` keys
    [position_controller]  kind: "lead_lag", "pid" or "state_control"
    [lead_lag]             :class:`controllers.axis.lead_lag.LeadLagParams` keys
    [pid]                  :class:`controllers.axis.pid.AxisPIDParams` keys (LinuxCNC pins)
    [state_control]        :class:`controllers.axis.state_control.StateControlParams` keys
    [trajectory]           :class:`controllers.axis.trajectory.TrajectoryParams` keys
    [cutting_load]         :class:`plants.axis.cutting_load.CuttingLoadParams` keys

Files go through the project's one loader (:mod:`acc.inputs`) and its key checks
(:func:`acc.scenarios.force.coerce_key`): an unknown section or key, a wrong type, a non-finite
number or an impossible value is a one-line error naming ``section.key``.  A section of the
kind not selected is still validated (a typo there is not silently ignored).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from acc.engine.axis_verdicts import DIVERGENCE_FACTOR
from acc.errors import ScenarioError
from acc.limits import (
    MAX_DELAY_STEPS,
    MAX_PLANT_STEPS,
    MAX_TRACE_BYTES,
    format_bytes,
    shorten,
)
from acc.scenarios.sections import check_sections, selects_model
from controllers.axis.lead_lag import LeadLagParams
from controllers.axis.pid import AxisPIDParams
from controllers.axis.state_control import StateControlParams
from controllers.axis.trajectory import TrajectoryParams
from plants.axis.cutting_load import CuttingLoadParams
from plants.axis.oscillating_axis import OscillatingAxisParams
from plants.axis.servo_axis import ServoAxisParams

#: Signals an axis run traces (:data:`acc.engine.axis_simulate.AXIS_SIGNALS`).
TRACED_SIGNALS = 10
#: Axis kinds and their parameter sections.
AXIS_KINDS = {"servo": "servo_axis", "oscillating": "oscillating_axis"}
#: Position-controller kinds and their parameter sections.
CONTROLLER_KINDS = {"lead_lag": "lead_lag", "pid": "pid", "state_control": "state_control"}


@dataclass(frozen=True)
class AxisSimulationParams:
    """``[simulation]`` of an axis scenario.

    Attributes
    ----------
    model : {"axis"}
    plant_step_s : float
        ``dt`` [s], > 0.
    control_period_s : float
        Position-controller period [s], a whole multiple of ``dt``.
    duration_s : float
        Simulated time [s], a whole number of plant steps.
    seed : int
        Root seed (accelerometer noise).
    divergence_factor : float
        ``D``: a following error beyond ``D`` path sizes, or a current beyond ``D`` times the
        drive's peak, fails the run (:mod:`acc.engine.axis_verdicts`; 100), > 1.
    """

    model: str = "axis"
    plant_step_s: float = 0.001
    control_period_s: float = 0.001
    duration_s: float = 1.0
    seed: int = 0
    divergence_factor: float = DIVERGENCE_FACTOR

    def __post_init__(self) -> None:
        if self.model != "axis":
            raise ValueError(f"model must be 'axis' here, got {self.model!r}")
        if not self.plant_step_s > 0:
            raise ValueError(f"plant_step_s must be > 0, got {self.plant_step_s!r}")
        from acc.engine.piecewise import whole_steps

        ratio = self.control_period_s / self.plant_step_s
        if not (self.control_period_s > 0 and abs(ratio - round(ratio)) < 1e-9 and ratio >= 1):
            raise ValueError(
                f"control_period_s must be a whole multiple (>= 1) of plant_step_s "
                f"{self.plant_step_s:g} s, got {self.control_period_s!r}"
            )
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"duration_s must be a finite number > 0, got {self.duration_s!r}")
        steps = self.duration_s / self.plant_step_s
        if steps <= MAX_PLANT_STEPS:  # the engine's own test of whole steps
            if whole_steps(self.duration_s, self.plant_step_s, "duration_s") < 1:
                raise ValueError(f"duration_s must be at least one plant step "
                                 f"({self.plant_step_s:g} s), got {self.duration_s!r}")
        if self.control_period_s > self.duration_s:
            raise ValueError(f"control_period_s must not exceed duration_s "
                             f"({self.duration_s:g} s): the controller would act once, got "
                             f"{self.control_period_s!r}")
        if steps > MAX_PLANT_STEPS:
            raise ValueError(
                f"duration_s / plant_step_s = {steps:.3g} steps; at most {MAX_PLANT_STEPS:g} "
                "(limit)"
            )
        trace_bytes = 2 * TRACED_SIGNALS * 8 * steps  # the traces and their copy
        if trace_bytes > MAX_TRACE_BYTES:
            raise ValueError(
                f"duration_s: the traces of {steps:.3g} steps need "
                f"{format_bytes(trace_bytes)}; at most {format_bytes(MAX_TRACE_BYTES)} (limit)"
            )
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed!r}")
        if not (math.isfinite(self.divergence_factor) and self.divergence_factor > 1):
            raise ValueError(f"divergence_factor must be a finite number > 1, got "
                             f"{self.divergence_factor!r}")


@dataclass(frozen=True)
class AxisKind:
    """``[axis]``: which axis model runs (``"servo"`` or ``"oscillating"``)."""

    kind: str = "servo"

    def __post_init__(self) -> None:
        if self.kind not in AXIS_KINDS:
            raise ValueError(f"kind must be one of {', '.join(AXIS_KINDS)}, got {self.kind!r}")


@dataclass(frozen=True)
class ControllerKind:
    """``[position_controller]``: which position controller runs."""

    kind: str = "lead_lag"

    def __post_init__(self) -> None:
        if self.kind not in CONTROLLER_KINDS:
            raise ValueError(
                f"kind must be one of {', '.join(CONTROLLER_KINDS)}, got {self.kind!r}"
            )


#: Section name -> its class, in file order.
AXIS_SECTIONS: dict[str, type] = {
    "simulation": AxisSimulationParams,
    "axis": AxisKind,
    "servo_axis": ServoAxisParams,
    "oscillating_axis": OscillatingAxisParams,
    "position_controller": ControllerKind,
    "lead_lag": LeadLagParams,
    "pid": AxisPIDParams,
    "state_control": StateControlParams,
    "trajectory": TrajectoryParams,
    "cutting_load": CuttingLoadParams,
}


@dataclass(frozen=True)
class AxisScenario:
    """A validated axis scenario: one object per section (:data:`AXIS_SECTIONS`)."""

    simulation: AxisSimulationParams
    axis: AxisKind
    servo_axis: ServoAxisParams
    oscillating_axis: OscillatingAxisParams
    position_controller: ControllerKind
    lead_lag: LeadLagParams
    pid: AxisPIDParams
    state_control: StateControlParams
    trajectory: TrajectoryParams
    cutting_load: CuttingLoadParams
    source: str = "<dict>"

    @property
    def axis_params(self) -> ServoAxisParams | OscillatingAxisParams:
        """The parameters of the selected axis kind."""
        return getattr(self, AXIS_KINDS[self.axis.kind])

    @property
    def controller_params(self) -> LeadLagParams | AxisPIDParams | StateControlParams:
        """The parameters of the selected position controller."""
        return getattr(self, CONTROLLER_KINDS[self.position_controller.kind])

    def with_values(self, values: dict[str, Any], source: str = "--set") -> AxisScenario:
        """A copy with ``{"section.key": value}`` changed, validated like the file.

        The copy keeps the scenario's source; an error names ``source`` (the scenario alone
        was valid, so the values caused it)."""
        data = self.to_dict()
        for dotted, value in values.items():
            section, _, key = dotted.partition(".")
            if not key:
                raise ScenarioError.at(source, shorten(dotted, 60), "expected section.key")
            data.setdefault(section, {})[key] = value
        try:
            return axis_scenario_from_dict(data, self.source)
        except ScenarioError as exc:
            raise exc.blame(source, instead_of=self.source) from None

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Nested ``{section: {key: value}}`` (every key, defaults filled)."""
        out = {}
        for name in AXIS_SECTIONS:
            values = dataclasses.asdict(getattr(self, name))
            out[name] = {k: v for k, v in values.items() if not _is_inf(v)}
        return out

    def simulate(self, record_every_steps: int | None = 1) -> Any:
        """Run it in the compiled axis loop (:func:`acc.engine.axis_simulate.simulate_axis`)."""
        from acc.engine.axis_simulate import simulate_axis

        sim = self.simulation
        load = self.cutting_load if self.cutting_load.kind != "none" else None
        return simulate_axis(
            self.axis_params,
            self.controller_params,
            self.trajectory,
            duration_s=sim.duration_s,
            plant_step_s=sim.plant_step_s,
            control_period_s=sim.control_period_s,
            load=load,
            seed=sim.seed,
            record_every_steps=record_every_steps,
            divergence_factor=sim.divergence_factor,
        )

    def summary_row(self, result: Any) -> dict[str, Any]:
        """The run's metrics, one CSV row: the kinds, every metric of run 0 of ``result``
        (what :meth:`simulate` returns; NaN for a failed run), ``failed`` and
        ``failure_reason`` (:mod:`acc.engine.axis_verdicts`)."""
        row: dict[str, Any] = {
            "axis": self.axis.kind,
            "position_controller": self.position_controller.kind,
            "trajectory": self.trajectory.kind,
            "cutting_load": self.cutting_load.kind,
        }
        row.update({k: bool(v[0]) if v.dtype == bool else float(v[0])
                    for k, v in result.metrics.items()})
        row["failure_reason"] = result.failure_reasons[0]
        return row


def _is_inf(value: Any) -> bool:
    return isinstance(value, float) and math.isinf(value)


def is_axis_data(data: Any) -> bool:
    """True when a parsed file selects the axis lab (``[simulation] model = "axis"``)."""
    return selects_model(data, "axis")


def axis_scenario_from_dict(data: dict[str, Any], source: str = "<dict>") -> AxisScenario:
    """Build and validate an axis scenario from ``{section: {key: value}}``.

    Raises
    ------
    ScenarioError
        Unknown section or key, wrong type, non-finite number or impossible value, named in
        one line.
    """
    from acc.scenarios.force import _section

    check_sections(data, AXIS_SECTIONS, "an axis scenario", source)
    parts = {
        name: _section(cls, data.get(name, {}), name, source)
        for name, cls in AXIS_SECTIONS.items()
    }
    scenario = AxisScenario(**parts, source=source)
    _check_combination(scenario, source)
    return scenario


def _check_combination(sc: AxisScenario, source: str) -> None:
    """Cross-section conditions the simulation assumes, checked before any run."""
    ax, ctrl = sc.axis.kind, sc.position_controller.kind
    if ctrl == "lead_lag" and ax != "servo":
        raise ScenarioError.at(
            source, "position_controller.kind",
            "lead_lag drives Peng's servo axis (a voltage command); use pid or state_control "
            "on the oscillating axis",
        )
    if sc.cutting_load.kind == "torque_step" and ax != "servo":
        raise ScenarioError.at(
            source, "cutting_load.kind", "a torque_step needs the servo axis (a motor torque)"
        )
    dt = sc.simulation.plant_step_s
    k_t = getattr(sc.axis_params, "force_to_torque_m", None)
    for section, build in (("trajectory", lambda: sc.trajectory.breakpoints(dt)),
                           ("cutting_load", lambda: sc.cutting_load.breakpoints(dt, k_t))):
        try:  # what the engine builds from them (whole plant steps, the same test)
            build()
        except ValueError as exc:
            raise ScenarioError.at(source, _key_in(section, AXIS_SECTIONS[section], str(exc)),
                                   shorten(str(exc), 200)) from None
    _check_controller(sc, source)


def _key_in(section: str, cls: type, message: str) -> str:
    """``section.<the field the message names first>``, or ``[section]``."""
    from acc.scenarios.force import _field_named, field_types

    name = _field_named(message, field_types(cls))
    return f"{section}.{name}" if name else f"[{section}]"


def _check_controller(sc: AxisScenario, source: str) -> None:
    """The position controller's records can be built (what the engine does first): the
    lead-lag's delay line fits :data:`acc.limits.MAX_DELAY_STEPS`, the restricted state
    control's acceleration observer can be designed at the control period."""
    period = sc.simulation.control_period_s
    kind = sc.position_controller.kind
    if kind == "lead_lag":
        delay = sc.lead_lag.computational_delay_samples
        if delay > MAX_DELAY_STEPS:
            raise ScenarioError.at(source, "lead_lag.computational_delay_samples",
                                   f"{delay} control periods of delay line; at most "
                                   f"{MAX_DELAY_STEPS:.0e} (limit)")
    elif kind == "state_control":
        import numpy as np

        from controllers.axis.state_control import state_control_records

        try:
            with np.errstate(all="ignore"):
                state_control_records([sc.state_control], period, seed=0,
                                      initial_position_mm=np.zeros(1))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            key = _key_in("state_control", StateControlParams, str(exc))
            if key == "[state_control]":  # the observer's model decays within a period
                key = ("simulation.control_period_s" if period > sc.simulation.plant_step_s
                       else "state_control.observer_frequency_Hz")
            raise ScenarioError.at(
                source, key, f"the restricted state control cannot be built at "
                f"control_period_s = {period:g} s: {shorten(str(exc), 160)}") from None


def load_axis_scenario(path: str | Path) -> AxisScenario:
    """Read and validate an axis scenario file (:mod:`acc.inputs` reads it)."""
    from acc.inputs import read_toml

    return axis_scenario_from_dict(read_toml(path, "scenario"), str(path))


__all__ = [
    "AXIS_KINDS",
    "AXIS_SECTIONS",
    "CONTROLLER_KINDS",
    "AxisScenario",
    "AxisSimulationParams",
    "axis_scenario_from_dict",
    "is_axis_data",
    "load_axis_scenario",
]
