"""LinuxCNC's trajectory planner as the feed drive: feed override x ``motion.adaptive-feed``,
its clamps, the planner's rate limit and cycle delays, and an optional axis drive behind it
(``feed_drive.kind = "linuxcnc"``).

The workbench's controller writes its override into LinuxCNC's feed-scaling input.  What
LinuxCNC does with it, per servo cycle ``n`` of period ``T`` (``[EMCMOT] SERVO_PERIOD``), as
written in LinuxCNC 2.9.0~pre1 (git f1270d6ed7, the Debian 12 package ``linuxcnc-uspace``):

1. **Feed scaling** (``src/emc/motion/control.c``, ``process_inputs``): the net feed scale is
   ``feed_scale x adaptive_feed`` with ``adaptive_feed`` clipped to ``[-1, 1]`` (a negative
   value runs the path backwards; the workbench never asks for that and clips to
   ``[0, 1]``).  The override ``u / F`` of the workbench [-] is written as
   ``adaptive_feed = u / (F x feed_override)``: for an override range 0.1-2, feed override
   2 and ``[DISPLAY] MAX_FEED_OVERRIDE`` = 2.
2. **Requested velocity** (``src/emc/tp/tp.c``, ``tpGetFeedScale``, ``tpGetRealTargetVel``,
   ``tpGetMaxTargetVel``; ``src/emc/tp/tc.c``, ``tcGetMaxTargetVel``):
   ``v* = min(F/60 x net_scale, F/60 x MAX_FEED_OVERRIDE)`` [mm/s] (the segment's own
   ``maxvel``, the axis's ``MAX_VELOCITY``, is assumed above it).
3. **Rate limit** (``tp.c``, ``tpCalculateTrapezoidalAccel``, ``tcUpdateDistFromAccel``;
   ``tc.c``, ``tcGetOverallMaxAccel``): in the middle of a long straight segment,
   ``acc = clip((v* - V) / T, -A, A)``, ``V <- V + acc T`` and the planner's position
   ``X <- X + (V_old + V) T / 2`` (trapezoidal).  ``A`` is the segment's acceleration
   (``[AXIS_X] MAX_ACCELERATION`` for a move along X), halved when the segment ends in a
   parabolic blend (``G64``: ``TC_TERM_COND_PARABOLIC``), whole under exact stop (``G61``).
   The velocity follows a new adaptive-feed value in the servo cycle that reads it.
4. **Joint interpolation** (``src/emc/motion/control.c``, ``get_pos_cmds``, coordinated
   mode; ``src/emc/kinematics/cubic.c``, ``cubicAddPoint``, ``cubicInterpolate``): with
   ``TRAJ_PERIOD`` = ``SERVO_PERIOD`` each cycle adds ``X_n`` to the cubic interpolator and
   reads its first way point, so the joint's position command is
   ``P_n = (X_{n-3} + 4 X_{n-2} + X_{n-1}) / 6``: the planner's position smoothed and one
   cycle later (it does not depend on ``X_n``).
5. **Axis drive** (optional, a real axis): the joint velocity ``(P_n - P_{n-1}) / T`` through
   a dead time ``axis_dead_time_s`` (whole plant steps) and a first-order lag of time
   constant ``axis_time_constant_s`` (exact for the velocity held over each plant step, as
   :mod:`plants.feed_drive` does for Eq. 6).  Without them the tool is at the joint's position
   command (a simulated axis, ``pos-fb = pos-cmd``).

The end of a segment (deceleration to its end point, blends between segments) is not
modelled: the element is the planner in the middle of one long straight move.  Collinear
moves under G64 are joined tangentially (``tp.c``, ``tpSetupTangent``:
``TC_TERM_COND_TANGENT``), so all but the last ramp at the full acceleration: model them with
``blending = "G61"`` (docs/linuxcnc_drive.md gives the recorded agreement).

Clock.  Plant step ``dt`` and servo period ``T``: one is a whole multiple of the other.
With ``dt = c T`` each plant step runs ``c`` servo cycles with the command held; with
``T = m dt`` a servo cycle runs at every ``m``-th plant step (``k = 0, m, 2m, ...``) and the
joint moves at its cycle's constant velocity over the ``m`` steps.  The command ``u[k]`` of
plant step ``k`` is the adaptive-feed value the cycles of that step read (written before
``motion-controller`` in the servo thread); the tool's position at ``t_{k+1}`` is the joint's
position command of the step's last cycle.

Slot contract (:mod:`acc.engine.force_loop`): ``step(p, s, command_mm_min, load_force_N)``
returns the velocity at the start of the step [mm/min], the velocity the chip load's exact
update holds over the step [mm/min] and the travel [mm].  Without an axis lag the tool
moves at a constant velocity over the step and both velocities are that velocity (the chip
load's update is then exact whatever bandwidth it was built with); with a lag, they are the
lag's velocity at the start of the step and its delayed input, as for Eq. (6), and the
force process must be built with the bandwidth ``1 / axis_time_constant_s``
(:func:`chip_load_bandwidth_rad_s`).  ``output(p, s)`` is the axis's velocity at the start
of the step (without a lag: over the last servo cycle), with NaN current and motor speed.

Small-signal model (:func:`small_signal_delay_s`).  While the requested velocity changes by
less than ``A T`` per servo cycle the rate limit is inactive and steps 1-4 are linear: the
joint velocity is ``z^-1 (1 + z^-1)/2 (1 + 4 z^-1 + z^-2)/6`` times ``v*``, a linear-phase
filter whose delay is exactly 2.5 servo cycles and whose gain is
``cos(w T / 2) (2 + cos(w T)) / 3`` (1 at DC).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import delay_size, init_states, jit, per_run, record, register_element

#: Planner termination conditions: G64 (parabolic blend, half the acceleration), G61 (stop).
BLENDING_MODES = ("G64", "G61")
#: Delay of the linear part of the planner and joint interpolator [servo cycles].
SMALL_SIGNAL_DELAY_CYCLES = 2.5
#: Relative tolerance [-] for whole multiples of the servo period and plant step.
_WHOLE_RTOL = 1e-9


@dataclass(frozen=True)
class LinuxCNCDrive:
    """The ``linuxcnc`` feed drive's parameters (the ``[feed_drive]`` keys of that kind).

    Attributes
    ----------
    servo_period_s : float
        ``[EMCMOT] SERVO_PERIOD`` [s] (also ``TRAJ_PERIOD``), > 0.
    max_acceleration_mm_s2 : float
        The segment's acceleration limit ``A`` [mm/s^2] (``[AXIS_X] MAX_ACCELERATION`` for a
        move along X), > 0.
    blending : {"G64", "G61"}
        Path mode: ``G64`` ramps at ``A/2``, ``G61`` at ``A``.
    feed_override : float
        LinuxCNC's feed override [-], > 0 and <= ``max_feed_override``.
    max_feed_override : float
        ``[DISPLAY] MAX_FEED_OVERRIDE`` [-], > 0.
    axis_time_constant_s : float
        Lag of the axis drive [s], >= 0 (0: none).
    axis_dead_time_s : float
        Dead time of the axis drive [s], >= 0, whole plant steps.
    """

    servo_period_s: float = 0.001
    max_acceleration_mm_s2: float = 508.0
    blending: str = "G64"
    feed_override: float = 2.0
    max_feed_override: float = 2.0
    axis_time_constant_s: float = 0.0
    axis_dead_time_s: float = 0.0

    @property
    def ramp_acceleration_mm_s2(self) -> float:
        """The acceleration the velocity ramps at [mm/s^2]: ``A/2`` under G64, ``A`` under G61."""
        return self.max_acceleration_mm_s2 * (0.5 if self.blending == "G64" else 1.0)

    def rate_limit_mm_min(self) -> float:
        """Largest change of the requested feed per servo cycle that is followed at once,
        ``A_ramp T`` [mm/min] (larger changes ramp)."""
        return self.ramp_acceleration_mm_s2 * self.servo_period_s * 60.0


def check_drive(drive: LinuxCNCDrive) -> tuple[str, str] | None:
    """The first single-key problem of the drive's parameters as ``(key, message)``, or None."""
    for key in ("servo_period_s", "max_acceleration_mm_s2", "feed_override",
                "max_feed_override"):
        value = getattr(drive, key)
        if not (math.isfinite(value) and value > 0):
            return key, f"must be > 0, got {value}"
    for key in ("axis_time_constant_s", "axis_dead_time_s"):
        value = getattr(drive, key)
        if not (math.isfinite(value) and value >= 0):
            return key, f"must be >= 0, got {value}"
    if drive.blending not in BLENDING_MODES:
        return "blending", f"must be one of {', '.join(BLENDING_MODES)}, got {drive.blending!r}"
    if drive.feed_override > drive.max_feed_override:
        return "feed_override", (
            f"{drive.feed_override:g} is above max_feed_override = {drive.max_feed_override:g} "
            "(LinuxCNC caps the speed at F x MAX_FEED_OVERRIDE)")
    return None


def servo_ratio(servo_period_s: float, plant_step_s: float) -> tuple[int, int] | None:
    """``(cycles per plant step, plant steps per servo cycle)``, one of them 1, or None when
    neither period is a whole multiple of the other."""
    for ratio, swap in ((plant_step_s / servo_period_s, False),
                        (servo_period_s / plant_step_s, True)):
        n = round(ratio)
        if n >= 1 and abs(ratio - n) <= _WHOLE_RTOL * ratio:
            return (1, int(n)) if swap else (int(n), 1)
    return None


def axis_delay_steps(drive: LinuxCNCDrive, plant_step_s: float) -> int | None:
    """``axis_dead_time_s`` in whole plant steps, or None when it is not whole."""
    ratio = drive.axis_dead_time_s / plant_step_s
    n = round(ratio)
    return int(n) if abs(ratio - n) <= _WHOLE_RTOL * max(1.0, ratio) else None


def chip_load_bandwidth_rad_s(drive: LinuxCNCDrive, fallback_rad_s: float) -> float:
    """The bandwidth the force process's exact chip-load update must be built with: the axis
    lag's ``1/tau``, or (without a lag, where it does not matter) ``fallback_rad_s``."""
    tau = drive.axis_time_constant_s
    return 1.0 / tau if tau > 0 else fallback_rad_s


def small_signal_delay_s(drive: LinuxCNCDrive) -> float:
    """Delay of the small-signal model [s]: 2.5 servo cycles plus the axis dead time."""
    return SMALL_SIGNAL_DELAY_CYCLES * drive.servo_period_s + drive.axis_dead_time_s


def small_signal_gain(drive: LinuxCNCDrive, omega_rad_s: ArrayLike) -> NDArray[np.float64]:
    """Gain of the planner's linear filter beside its delay, ``cos(wT/2)(2 + cos wT)/3`` [-].

    Parameters
    ----------
    drive : LinuxCNCDrive
    omega_rad_s : array_like, shape (n,)

    Returns
    -------
    ndarray, shape (n,)
    """
    wt = np.asarray(omega_rad_s, dtype=float) * drive.servo_period_s
    return np.cos(wt / 2.0) * (2.0 + np.cos(wt)) / 3.0


#: Bandwidth that stands for "no axis lag" in the small-signal model [rad/s]: its gain and
#: phase differ from none by less than 0.2 degrees below 300 rad/s.
NO_LAG_BANDWIDTH_RAD_S = 1e5


def small_signal_drive(drive: LinuxCNCDrive) -> tuple[float, float]:
    """Eq. (6)'s ``(a, L)`` of the small-signal model: the axis lag's ``1/tau`` (without
    one, :data:`NO_LAG_BANDWIDTH_RAD_S`) and :func:`small_signal_delay_s` [rad/s, s]."""
    tau = drive.axis_time_constant_s
    return (1.0 / tau if tau > 0 else NO_LAG_BANDWIDTH_RAD_S), small_signal_delay_s(drive)


def small_signal_note(drive: LinuxCNCDrive, control_period_s: float) -> str:
    """One line stating the small-signal model ``acc analyze`` uses, where it holds and how
    far its pure delay is from the planner's filter up to the control Nyquist frequency."""
    a, delay = small_signal_drive(drive)
    w = np.pi / control_period_s
    gain_error = 100.0 * float(1.0 - small_signal_gain(drive, [w])[0])
    lag = (f"the axis lag tau = {drive.axis_time_constant_s:g} s" if drive.axis_time_constant_s
           > 0 else f"no axis lag (a = {a:.0e} rad/s)")
    return (
        f"feed_drive.kind = 'linuxcnc' analysed by its small-signal model: a dead time "
        f"L = {delay:.6g} s ({SMALL_SIGNAL_DELAY_CYCLES:g} servo cycles of "
        f"{drive.servo_period_s:g} s + axis {drive.axis_dead_time_s:g} s) and {lag}; exact "
        f"while the commanded feed changes by less than {drive.rate_limit_mm_min():.4g} "
        f"mm/min per servo cycle ({drive.blending} rate limit "
        f"{drive.ramp_acceleration_mm_s2:g} mm/s^2), larger steps ramp and are slower than "
        f"this model; the planner's filter gain is {gain_error:.2g} % below the delay's at "
        f"the control Nyquist frequency {w:.4g} rad/s")


def _dtypes(ring: int = 8) -> tuple[np.dtype, np.dtype]:
    params = record(
        "feed_drive.linuxcnc",
        [
            ("plant_step_s", "f8"),
            ("servo_period_s", "f8"),
            ("cycles_per_step", "i8"),
            ("steps_per_cycle", "i8"),
            ("programmed_feed_mm_min", "f8"),
            ("feed_override", "f8"),
            ("max_feed_override", "f8"),
            ("acceleration_mm_s2", "f8"),  # the ramp's: A/2 (G64) or A (G61)
            ("has_lag", "b1"),
            ("phi", "f8"),  # exp(-dt / tau)
            ("lag_integral_s", "f8"),  # integral of exp(-t / tau) over a step
            ("delay_steps", "i8"),
            ("ring_mask", "i8"),
        ],
    )
    state = record(
        "feed_drive.linuxcnc",
        [
            ("adaptive_feed", "f8"),  # the last value the planner read, clipped [-]
            ("planner_velocity_mm_s", "f8"),  # V (motion.current-vel)
            ("planner_position_mm", "f8"),  # X_n (the planner's position, axis pos-cmd)
            ("points_mm", "f8", (3,)),  # X_{n-3}, X_{n-2}, X_{n-1} before the next cycle
            ("joint_position_mm", "f8"),  # P_n (joint pos-cmd)
            ("cycle_velocity_mm_min", "f8"),  # joint velocity of the current servo cycle
            ("phase", "i8"),  # plant steps into the servo cycle
            ("velocity_mm_min", "f8"),  # the axis's velocity at the start of the step
            ("head", "i8"),
            ("history_mm_min", "f8", (ring,)),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At rest at position 0, every past command 0."""
    s.adaptive_feed = 0.0
    s.planner_velocity_mm_s = 0.0
    s.planner_position_mm = 0.0
    for i in range(3):
        s.points_mm[i] = 0.0
    s.joint_position_mm = 0.0
    s.cycle_velocity_mm_min = 0.0
    s.phase = 0
    s.velocity_mm_min = 0.0
    s.head = 0
    for i in range(s.history_mm_min.shape[0]):
        s.history_mm_min[i] = 0.0


@jit
def servo_cycle(p, s, command_mm_min: float) -> float:  # noqa: ANN001
    """One servo cycle (module docstring, steps 1-4): the joint's new position command
    ``P_n`` is read from the points before the planner moves; returns ``P_n - P_{n-1}`` [mm]."""
    x0, x1, x2 = s.points_mm[0], s.points_mm[1], s.points_mm[2]
    joint = (x0 + 4.0 * x1 + x2) / 6.0  # cubic.c wayPoint
    moved = joint - s.joint_position_mm
    s.joint_position_mm = joint
    feed = p.programmed_feed_mm_min
    af = command_mm_min / (feed * p.feed_override)
    if af > 1.0:
        af = 1.0
    elif not af > 0.0:  # negative (and NaN) commands: no motion
        af = 0.0
    s.adaptive_feed = af
    reqvel = feed / 60.0
    target = min(reqvel * (p.feed_override * af), reqvel * p.max_feed_override)
    t = p.servo_period_s
    v = s.planner_velocity_mm_s
    acc = (target - v) / t
    if acc > p.acceleration_mm_s2:
        acc = p.acceleration_mm_s2
    elif acc < -p.acceleration_mm_s2:
        acc = -p.acceleration_mm_s2
    v_next = v + acc * t
    if v_next < 0.0:
        v_next = 0.0
    else:
        s.planner_position_mm += (v_next + v) * 0.5 * t
    s.planner_velocity_mm_s = v_next
    s.points_mm[0] = x1
    s.points_mm[1] = x2
    s.points_mm[2] = s.planner_position_mm
    return moved


@jit
def step(p, s, command_mm_min: float, load_force_N: float = 0.0) -> tuple[float, float, float]:  # noqa: ANN001
    """One plant step with the command ``u[k]`` [mm/min] (module docstring; the planner has
    no load input: ``load_force_N`` [N] is the slot's contract and is not used).

    Returns the velocity at the start of the step [mm/min], the velocity held over the step
    (the delayed joint velocity entering the lag) [mm/min] and the travel [mm].
    """
    dt = p.plant_step_s
    if p.cycles_per_step > 1 or p.steps_per_cycle == 1:
        moved = 0.0
        for _ in range(p.cycles_per_step):
            moved += servo_cycle(p, s, command_mm_min)
        joint_v = moved / dt * 60.0
    else:
        if s.phase == 0:
            s.cycle_velocity_mm_min = servo_cycle(p, s, command_mm_min) / p.servo_period_s * 60.0
        joint_v = s.cycle_velocity_mm_min
        s.phase += 1
        if s.phase == p.steps_per_cycle:
            s.phase = 0
    s.history_mm_min[s.head] = joint_v
    delayed = s.history_mm_min[(s.head - p.delay_steps) & p.ring_mask]
    s.head = (s.head + 1) & p.ring_mask
    if p.has_lag:
        v = s.velocity_mm_min
        s.velocity_mm_min = p.phi * v + (1.0 - p.phi) * delayed
        travel = (delayed * dt + (v - delayed) * p.lag_integral_s) / 60.0
        return v, delayed, travel
    s.velocity_mm_min = delayed
    return delayed, delayed, delayed * dt / 60.0


@jit
def output(p, s) -> tuple[float, float, float]:  # noqa: ANN001
    """The axis's velocity at the start of the step [mm/min] (without a lag: over the last
    plant step); no motor model, so NaN current [A] and motor speed [rad/s]."""
    return s.velocity_mm_min, np.nan, np.nan


LINUXCNC_DRIVE = register_element(
    "feed_drive.linuxcnc",
    _dtypes,
    init,
    step,
    "LinuxCNC's trajectory planner: adaptive feed, rate limit, cycle delays, axis lag",
    output,
)


def linuxcnc_drive_records(
    drive: LinuxCNCDrive,
    programmed_feed_mm_min: ArrayLike,
    plant_step_s: float,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of LinuxCNC feed drives (one design).

    Parameters
    ----------
    drive : LinuxCNCDrive
    programmed_feed_mm_min : array_like, shape (runs,) or scalar
        The G-code feed ``F`` of each run [mm/min], > 0.
    plant_step_s : float
        ``dt`` [s]; the servo period is a whole multiple of it or it of the servo period.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)

    Raises
    ------
    ValueError
        A bad parameter (:func:`check_drive`), periods that are not whole multiples, an axis
        dead time that is not whole plant steps.
    """
    problem = check_drive(drive)
    if problem is not None:
        raise ValueError(f"{problem[0]} {problem[1]}")
    ratio = servo_ratio(drive.servo_period_s, plant_step_s)
    if ratio is None:
        raise ValueError(
            f"servo_period_s = {drive.servo_period_s:g} s and plant_step_s = {plant_step_s:g} s: "
            "one must be a whole multiple of the other")
    n = axis_delay_steps(drive, plant_step_s)
    if n is None:
        raise ValueError(f"axis_dead_time_s = {drive.axis_dead_time_s:g} s is not a whole "
                         f"number of plant steps of {plant_step_s:g} s")
    runs, (feed,) = per_run(programmed_feed_mm_min)
    if np.any(~(feed > 0)):
        raise ValueError("programmed_feed_mm_min must be > 0")
    params, state = LINUXCNC_DRIVE.records(runs, ring=delay_size(n + 1))
    tau = drive.axis_time_constant_s
    params["plant_step_s"] = plant_step_s
    params["servo_period_s"] = drive.servo_period_s
    params["cycles_per_step"], params["steps_per_cycle"] = ratio
    params["programmed_feed_mm_min"] = feed
    params["feed_override"] = drive.feed_override
    params["max_feed_override"] = drive.max_feed_override
    params["acceleration_mm_s2"] = drive.ramp_acceleration_mm_s2
    params["has_lag"] = tau > 0
    params["phi"] = math.exp(-plant_step_s / tau) if tau > 0 else 0.0
    params["lag_integral_s"] = -math.expm1(-plant_step_s / tau) * tau if tau > 0 else 0.0
    params["delay_steps"] = n
    params["ring_mask"] = state.dtype["history_mm_min"].shape[0] - 1
    return params, init_states(params, state)


__all__ = [
    "BLENDING_MODES",
    "LINUXCNC_DRIVE",
    "SMALL_SIGNAL_DELAY_CYCLES",
    "NO_LAG_BANDWIDTH_RAD_S",
    "LinuxCNCDrive",
    "axis_delay_steps",
    "check_drive",
    "chip_load_bandwidth_rad_s",
    "linuxcnc_drive_records",
    "servo_cycle",
    "servo_ratio",
    "small_signal_delay_s",
    "small_signal_drive",
    "small_signal_gain",
    "small_signal_note",
]
