"""The workbench's force loop as a userspace HAL component of LinuxCNC.

:class:`ForceLoopHook` runs inside the worker (:mod:`acc.linuxcnc.worker`), for every servo
sample, the elements the engine's loop (:mod:`acc.engine.force_loop`) runs for a plant step,
with the same compiled ``step``/``output`` laws built from the scenario by the same record
builders: the workpiece (the segment at the tool's position), the force process (the
simulated cut, driven by the joint's real position command) and the force sensor, or a HAL
pin that gives the force (a dynamometer or spindle-load signal), the controller every control
period and the metrics.

Clock.  The servo cycle that records sample ``c0 + k`` is the engine's plant step ``k``
(plant step = servo period).  In step ``k`` the tool is at the joint's position command of
the cycle before (``P[c0+k-1]``), the chip load advances with the joint's velocity of the
cycle, ``(P[c0+k] - P[c0+k-1]) / T``, exactly as the ``linuxcnc`` feed drive of the
engine moves it (:mod:`plants.linuxcnc_drive`).  The override the controller computes from
step ``k`` reaches ``motion.adaptive-feed`` in the cycle of step ``k + D`` (``D`` =
``loop_delay_cycles``, the schedule of :mod:`acc.linuxcnc.machine`; the component has ``D``
cycles to compute it, and a late one is counted).  Until step ``D`` the adaptive feed is 0.
The engine's prediction of the same run is therefore the scenario with the ``linuxcnc`` drive
and an axis dead time of ``D`` servo cycles (a delay commutes with the planner, which is
time-invariant and starts at rest in both).

Step 0 (``c0``) is ``start_margin_cycles`` after the first cycle in which the planner runs
the cut (``motion.motion-type`` = 2, a feed move; the adaptive feed holds it at rest).

Overload (the force above ``[metrics] force_limit_N``) or an alarm pin that is true pauses
the feed (``motion.feed-inhibit``) and ends the cut.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from acc.engine.element import jit, output, step
from acc.engine.metrics import event_marks, metrics_records, revolution_steps, safe_feed_mm_min
from acc.linuxcnc.worker import FeedCommand
from controllers.registry import controller_records
from controllers.robust_force_controller import DIAGNOSTIC_NAMES
from plants.force_process import force_process_records
from plants.force_sensor import force_sensor_records
from plants.workpiece import WorkpieceBatch

#: ``motion.motion-type`` of a feed move (LinuxCNC's motion_types.h: EMC_MOTION_TYPE_FEED).
MOTION_TYPE_FEED = 2
#: Signals the component records per step, in this order.
COMPONENT_SIGNALS = (
    "step", "force_N", "measured_force_N", "override", "segment", "position_mm",
    "feed_velocity_mm_min", "finished",
)


@jit(python_entry=True)
def servo_sample(
    slots: tuple, k: int, control: bool, position_mm: float, velocity_mm_min: float,
    last_velocity_mm_min: float, external_force_N: float, use_external: bool,
    diag: np.ndarray,
) -> tuple:
    """One plant step ``k`` of the force loop on one servo sample (module docstring).

    ``slots`` holds ``workpiece, force_process, sensor, controller, metrics`` records
    (params then state, shape (1,) each).  Returns ``(force_N, measured_N, override or NaN
    when ``control`` is false, segment, stop)``.
    """
    wp_p, wp_s, pp, ps, sp, ss, cp, cs, mp, ms = slots
    segment = output(wp_p[0], wp_s[0], position_mm)
    finished = segment == wp_p[0].segments
    if use_external:
        force = external_force_N
        measured = external_force_N
    else:
        force, feed_force, _ = output(pp[0], ps[0], segment, k, position_mm)
        measured, _ = step(sp[0], ss[0], force, feed_force, last_velocity_mm_min, np.nan,
                           np.nan)
    override = np.nan
    if control:
        override = step(cp[0], cs[0], measured, diag)
    stop = step(mp[0], ms[0], k, force, segment, finished, position_mm)
    if not use_external:
        step(pp[0], ps[0], segment, velocity_mm_min, velocity_mm_min)
    return force, measured, override, segment, stop


def loop_records(scenario: object) -> tuple:
    """The records of the workpiece, force process, sensor, controller and metrics slots of
    one run of ``scenario`` (a force-loop :class:`~acc.scenarios.force.Scenario` with the
    table force process and a dynamometer), built as :func:`acc.engine.simulate.simulate`
    builds them; the force process's chip load moves with a velocity held over each step.
    """
    s = scenario
    sim = s.simulation
    dt = sim.plant_step_s
    parts = WorkpieceBatch([s.workpiece])
    nseg = parts.segments
    gain, pole = s.force_process.segment_parameters(parts.radial_depth_mm[0],
                                                   parts.axial_depth_mm[0])
    gain, pole = np.atleast_2d(gain), np.atleast_2d(pole)
    bandwidth = np.array([s.feed_drive.bandwidth_rad_s])
    process = force_process_records(gain, pole, bandwidth, dt)
    reference = np.array([s.controller.reference_force_N])
    programmed = np.array([s.controller.programmed_feed_mm_min])
    seeds = np.array([sim.seed], dtype=np.uint64)
    sensor = force_sensor_records(
        np.array([s.sensor.noise_std_N]), np.array([s.sensor.lowpass_cutoff_hz]), dt, seeds,
        np.array([0]),
    )
    safe = np.array([safe_feed_mm_min(reference[0], gain[0, :nseg])])
    controller = controller_records(
        [s.controller], [s.nominal_plant], sim.control_period_s,
        safe / programmed, [s.design],
    )
    m = s.metrics
    metrics = metrics_records(
        reference, gain > 0, np.array([m.settling_band_pct]), np.array([m.divergence_factor]),
        dt, np.array([m.oscillation_window_s]),
        np.array([np.inf if m.force_limit_N is None else m.force_limit_N]),
        np.maximum(np.array([m.oscillation_threshold_pct]) / 100.0 * reference,
                   3.0 * np.array([s.sensor.noise_std_N])),
        sim.max_steps, np.array([revolution_steps(s)], dtype=np.int64),
        np.array([m.oscillation_decay_ratio]), np.array([m.overload_tolerance_pct]),
        [event_marks(s)],
    )
    return (*parts.records(), *process, *sensor, *controller, *metrics)


@dataclass
class ForceLoopHook:
    """The force loop on every servo sample (a :class:`acc.linuxcnc.worker.FeedHook`).

    Attributes
    ----------
    scenario : Scenario
        The force-loop scenario (plant step = servo period).
    feed_override : float
        LinuxCNC's feed override [-]: adaptive feed = override / feed_override.
    loop_delay_cycles : int
        ``D``: servo cycles from a control instant to the cycle its override acts in (>= 1).
    force_pin : str or None
        A recorded pin that gives the force [N] instead of the simulated cut.
    alarm_pin : str or None
        A recorded bit pin; true pauses the feed (a breakage alarm).
    start_margin_cycles : int
        Cycles from the first feed-move cycle to step 0.
    """

    scenario: object
    feed_override: float
    loop_delay_cycles: int = 10
    force_pin: str | None = None
    alarm_pin: str | None = None
    start_margin_cycles: int = 20
    _cols: dict[str, int] = field(default_factory=dict, repr=False)
    _slots: tuple = field(default=(), repr=False)
    _c0: int | None = field(default=None, repr=False)
    _last_pos: float = field(default=0.0, repr=False)
    _last_vel: float = field(default=0.0, repr=False)
    _rows: list = field(default_factory=list, repr=False)
    _done: bool = field(default=False, repr=False)
    _paused: str = field(default="", repr=False)
    _diag: np.ndarray = field(default_factory=lambda: np.full(len(DIAGNOSTIC_NAMES), np.nan),
                              repr=False)

    @property
    def output_pins(self) -> tuple[str, ...]:
        """Float pins of the ``acc`` component this hook writes every sample."""
        return ("force", "measured-force", "override")

    def begin(self, columns: tuple[str, ...], servo_period_s: float) -> float:
        """Build the records (compiled laws load here); the adaptive feed starts at 0."""
        self._cols = {name: i for i, name in enumerate(columns)}
        dt = self.scenario.simulation.plant_step_s
        if not math.isclose(dt, servo_period_s, rel_tol=1e-9):
            raise ValueError(f"plant_step_s = {dt} must equal the servo period {servo_period_s}")
        self._slots = loop_records(self.scenario)
        self._period = servo_period_s
        self._m = self.scenario.simulation.steps_per_control
        # compile (or load) before the machine runs
        probe = tuple(np.copy(a) for a in self._slots)
        servo_sample(probe, 0, True, 0.0, 0.0, 0.0, 0.0, self.force_pin is not None,
                     self._diag.copy())
        self._ticks = 0
        return 0.0

    def sample(self, number: int, values: np.ndarray, running: bool) -> FeedCommand | None:
        """Advance the loop by the step of this sample; schedule the override."""
        if self._c0 is None:
            if running and values[self._cols["motion.motion-type"]] == MOTION_TYPE_FEED:
                self._c0 = number + self.start_margin_cycles
            return None
        k = number - self._c0
        pos = float(values[self._cols["joint.0.motor-pos-cmd"]])
        if k < 0 or self._done:
            self._last_pos = pos
            return None
        velocity = (pos - self._last_pos) / self._period * 60.0
        external = float(values[self._cols[self.force_pin]]) if self.force_pin else 0.0
        control = k % self._m == 0
        force, measured, override, segment, stop = servo_sample(
            self._slots, k, control, self._last_pos, velocity, self._last_vel, external,
            self.force_pin is not None, self._diag,
        )
        self._rows.append((k, force, measured, override, segment, self._last_pos, velocity,
                           float(segment == self._slots[0][0]["segments"])))
        self._last_pos, self._last_vel = pos, velocity
        self.outputs = {"force": force, "measured-force": measured}
        limit = self.scenario.metrics.force_limit_N
        alarm = self.alarm_pin is not None and values[self._cols[self.alarm_pin]] > 0.5
        if (limit is not None and force > limit) or alarm:
            self._paused = "alarm" if alarm else "overload"
            self._done = True
            return FeedCommand(None, number, inhibit=True)
        if stop:
            self._done = True
        if not control:
            return None
        self.outputs["override"] = override
        feed = min(max(override / self.feed_override, 0.0), 1.0)
        return FeedCommand(feed, number + self.loop_delay_cycles)

    def arrays(self) -> dict[str, np.ndarray]:
        """The component's signals (:data:`COMPONENT_SIGNALS`), step 0's sample number, the
        metrics state and why the feed was paused."""
        rows = np.array(self._rows, dtype=float).reshape(len(self._rows),
                                                         len(COMPONENT_SIGNALS))
        out = {name: rows[:, i] for i, name in enumerate(COMPONENT_SIGNALS)}
        out["c0"] = np.array([-1 if self._c0 is None else self._c0])
        out["metrics_state"] = self._slots[-1].copy() if self._slots else np.zeros(0)
        out["metrics_params"] = self._slots[-2].copy() if self._slots else np.zeros(0)
        out["paused"] = np.array([self._paused])
        return out


__all__ = ["COMPONENT_SIGNALS", "ForceLoopHook", "loop_records", "servo_sample"]
