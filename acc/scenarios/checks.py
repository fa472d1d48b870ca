"""What a simulation assumes of a scenario, checked when the scenario is built.

:func:`check_scenario` runs from :class:`acc.scenarios.force.Scenario`'s ``__post_init__``: every
condition that involves more than one key, or a design step, is checked before any run, so a
scenario that can be built is simulated without an exception.  Each failure is a
:class:`~acc.errors.ScenarioError` naming the file and the key to change.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from acc.engine.current_sensing import CurrentSensingParams
from acc.errors import ScenarioError
from acc.limits import MAX_AIR_CUT_STEPS, MAX_DELAY_STEPS
from controllers.registry import controller_kind
from plants.cutting_coefficients import CuttingCoefficients
from plants.feed_drive import DeadTimeError, dead_time_steps
from plants.force_process import OutOfTableError
from plants.geometric_process import GeometricProcessParams, check_regulable

if TYPE_CHECKING:
    from acc.scenarios.force import Scenario

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
    if scenario.feed_drive.kind == "servo_axis" and abs(sim.plant_step_s - 0.001) > 1e-12:
        raise ScenarioError.at(
            src,
            "feed_drive.kind",
            f"the servo axis's lead-lag position loop runs at Peng's 1 ms: it needs "
            f"simulation.plant_step_s = 0.001, got {sim.plant_step_s:g}",
        )
    if scenario.feed_drive.kind == "linuxcnc":
        _check_linuxcnc_drive(scenario)
    _check_sensor_kind(scenario)
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
    _check_resonator(scenario)
    _check_design(scenario)
    if scenario.geometry.enabled:
        _check_geometry(scenario)
    else:
        _check_conventional(scenario)
    if scenario.current_sensing.enabled:
        _check_current_sensing(scenario)
    if scenario.tool_breakage.enabled:
        _check_tool_breakage(scenario)


def _check_linuxcnc_drive(scenario: Scenario) -> None:
    """The LinuxCNC drive's servo period and the plant step are whole multiples of one
    another, and its axis dead time is whole plant steps (:mod:`plants.linuxcnc_drive`)."""
    from plants.linuxcnc_drive import axis_delay_steps, servo_ratio

    drive, dt = scenario.feed_drive.linuxcnc, scenario.simulation.plant_step_s
    if servo_ratio(drive.servo_period_s, dt) is None:
        raise ScenarioError.at(
            scenario.source, "feed_drive.servo_period_s",
            f"{drive.servo_period_s:g} s and simulation.plant_step_s = {dt:g} s: one must be "
            "a whole multiple of the other (the planner runs whole servo cycles)")
    n = axis_delay_steps(drive, dt)
    if n is None or n > MAX_DELAY_STEPS:
        raise ScenarioError.at(
            scenario.source, "feed_drive.axis_dead_time_s",
            f"{drive.axis_dead_time_s:g} s is not a whole number of plant steps of {dt:g} s"
            if n is None else f"{drive.axis_dead_time_s:g} s is {n} plant steps (limit "
            f"{MAX_DELAY_STEPS:.0e} steps of delay line)")


def _check_resonator(scenario: Scenario) -> None:
    """The resonant term's frequency is below the Nyquist frequency of the control period
    (:mod:`controllers.resonator`: ``W = 2 pi f0 T_c < pi``, else its poles alias)."""
    from controllers.resonator import ResonantOptions

    opts = scenario.controller.group(ResonantOptions)
    period = scenario.simulation.control_period_s
    if opts.enabled and not 2.0 * math.pi * opts.resonant_frequency_hz * period < math.pi:
        raise ScenarioError.at(
            scenario.source, "controller.resonant_frequency_hz",
            f"{opts.resonant_frequency_hz:g} Hz is not below the Nyquist frequency "
            f"{0.5 / period:g} Hz of the control period (simulation.control_period_s = "
            f"{period:g} s)",
        )


def _check_tool_breakage(scenario: Scenario) -> None:
    """The in-loop breakage monitor cuts with the tooth-passing geometric force, its faults
    fit the cutter, and the current it watches exists."""
    src = scenario.source
    tb = scenario.tool_breakage
    geo = scenario.geometry
    if not (geo.enabled and geo.tooth_passing):
        raise ScenarioError.at(
            src, "tool_breakage.enabled",
            "cutter faults and breakage act on the tooth-passing force: set geometry.enabled "
            "= true and geometry.tooth_passing = true",
        )
    if tb.runout_um and len(tb.runout_um) != geo.teeth:
        raise ScenarioError.at(
            src, "tool_breakage.runout_um",
            f"one value per tooth (geometry.teeth = {geo.teeth}), got {len(tb.runout_um)}",
        )
    for key, teeth in (("missing_teeth", tb.missing_teeth), ("broken_tooth", (tb.broken_tooth,))):
        bad = [t for t in teeth if t >= geo.teeth or t < (-1 if key == "broken_tooth" else 0)]
        if bad:
            raise ScenarioError.at(
                src, f"tool_breakage.{key}",
                f"tooth {bad[0]} is not a tooth of the cutter (0..{geo.teeth - 1})",
            )
    if len(set(tb.missing_teeth) | ({tb.broken_tooth} - {-1})) >= geo.teeth:
        raise ScenarioError.at(
            src, "tool_breakage.missing_teeth", "at least one tooth must stay on the cutter"
        )
    if tb.signal == "current" and scenario.sensor.kind == "dynamometer":
        raise ScenarioError.at(
            src, "tool_breakage.signal",
            "the monitor watches the servo axis's measured current: set sensor.kind = "
            "'peng_inverse_model' or 'peng_steady_state' (or tool_breakage.signal = "
            "'measured_force')",
        )
    if tb.current_signal == "resultant_xy" and tb.signal != "current":
        raise ScenarioError.at(
            src, "tool_breakage.current_signal",
            "the resultant current needs tool_breakage.signal = 'current'",
        )


def _check_sensor_kind(scenario: Scenario) -> None:
    """Peng's estimators read the servo axis's current: they need the servo feed drive,
    exclude Kim & Chung's current sensing and, with the geometric model, regulate the feed
    force the screw carries."""
    src = scenario.source
    kind = scenario.sensor.kind
    if kind == "dynamometer":
        if scenario.sensor.current_noise_std_A > 0:
            raise ScenarioError.at(
                src, "sensor.current_noise_std_A",
                "the dynamometer measures no current; set sensor.kind = 'peng_inverse_model' "
                "or 'peng_steady_state' (or current_sensing.current_noise_std_A)",
            )
        return
    if scenario.feed_drive.kind != "servo_axis":
        raise ScenarioError.at(
            src, "sensor.kind",
            f"{kind!r} estimates the force from the servo axis's current: it needs "
            f"feed_drive.kind = 'servo_axis' (got {scenario.feed_drive.kind!r})",
        )
    if scenario.current_sensing.enabled:
        raise ScenarioError.at(
            src, "sensor.kind",
            f"{kind!r} and current_sensing.enabled = true are two force estimates from "
            "currents; choose one",
        )
    if scenario.geometry.enabled and scenario.geometry.component != "feed":
        raise ScenarioError.at(
            src, "sensor.kind",
            f"{kind!r} measures the feed force; set geometry.component = 'feed' (got "
            f"{scenario.geometry.component!r})",
        )


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
    from acc.engine.metrics import safe_feed_mm_min

    part = scenario.workpiece
    largest = scenario.force_process.largest_static_gain_N_per_mm_min(part.radial_depth_mm)
    reference = scenario.controller.reference_force_N
    _check_safe_feed(  # (the division itself where a gain cuts: 3 us a run less)
        scenario,
        lambda: reference / largest if largest > 0 else safe_feed_mm_min(reference, (largest,)),
    )


def _check_safe_feed(scenario: Scenario, safe_feed: Any) -> None:
    """The safe constant feed ``safe_feed()`` [mm/min] is finite and > 0, and the time to
    machine the part at it can be computed."""
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
    why = _travel_time_problem(
        scenario.workpiece.length_mm,
        feed,
        scenario.feed_drive.bandwidth_rad_s,
        scenario.delay_steps * scenario.simulation.plant_step_s,
    )
    if why is not None:
        raise ScenarioError.at(
            src,
            "feed_drive.bandwidth_rad_s",
            f"the machining time at the safe constant feed cannot be computed ({why})",
        )


@functools.lru_cache(maxsize=4096)
def _travel_time_problem(
    length_mm: float, feed_mm_min: float, bandwidth_rad_s: float, dead_time_s: float
) -> str | None:
    """Why :func:`acc.engine.metrics.constant_feed_time_s` fails here, or None."""
    from acc.engine.metrics import constant_feed_time_s

    try:
        t = constant_feed_time_s(length_mm, feed_mm_min, bandwidth_rad_s, dead_time_s)
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        return str(exc)
    return None if math.isfinite(t) else f"{t} s"


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
    _check_safe_feed(scenario, lambda: _geometric_safe_feed(scenario))


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
    if total > MAX_AIR_CUT_STEPS:
        raise ScenarioError.at(
            src,
            "current_sensing.identification_time_s",
            f"the air cuts take {total:.3g} plant steps (limit {MAX_AIR_CUT_STEPS:.0e})",
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


__all__ = ["MIN_IDENTIFICATION_STEPS", "check_scenario"]
