"""Peng's servo axis as the force loop's feed drive: NC override delay, interpolator, the
1 ms lead-lag position loop and the DC servo (``feed_drive.kind = "servo_axis"``).

Kim & Chung model the feed drive as the first-order block of Eq. (6) with a dead time.  This
element replaces the block by the axis beneath it (seed 000, Ch. 2), per plant step ``k``:

1. the override command ``u[k] = override x F_prog`` [mm/min] enters the NC's override delay
   (``feed_drive.dead_time_s``, Kim & Chung's 0.1 s kept explicit, whole plant steps);
2. the interpolator integrates the delayed feed into the position reference,
   ``x_r[k+1] = x_r[k] + u[k-N] dt / 60``;
3. the position loop (:func:`controllers.axis.lead_lag.lead_lag_law`, Peng's
   ``D(z) = 2.5 (z - 0.8825)/z`` with ``K_d`` = 10/128 V/count by default) acts on
   ``x_r[k] - x[k]`` at every plant step (the thesis's 1 ms);
4. the servo axis (:mod:`plants.axis.servo_axis`, exact ZOH) advances under the command and
   the cutting load: the feed force reflects to the motor as ``T_c = k F`` (3.34).

Contract of the feed-drive slot: ``step(p, s, command_mm_min, load_force_N)`` returns the
table velocity at the start of the step [mm/min], the velocity the chip load sees over the
step and the travel [mm].  The chip load's exact update assumes Eq. (6)'s lag; here the
velocity is held over the plant step instead (both returned velocities are ``v[k]``), an
O(dt) approximation of the chip-load integral (1 ms steps).  ``output(p, s)`` is ``v[k]``
with the armature current ``I_a[k]`` [A] and motor speed ``W[k]`` [rad/s], which the
servo-current force sensors read (:mod:`acc.engine.servo_current_sensing`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import delay_size, init_states, jit, per_run, record, register_element
from controllers.axis import lead_lag
from controllers.axis.lead_lag import LeadLagParams, lead_lag_law, lead_lag_records
from plants.axis import servo_axis
from plants.axis.servo_axis import ServoAxisParams, servo_axis_records


def _dtypes(ring: int = 8, loop_ring: int = 8) -> tuple[np.dtype, np.dtype]:
    axis_p, axis_s = servo_axis.SERVO.dtypes()
    loop_p, loop_s = lead_lag.LEAD_LAG.dtypes(ring=loop_ring)
    params = record(
        "feed_drive.servo_axis",
        [
            ("plant_step_s", "f8"),
            ("delay_steps", "i8"),
            ("ring_mask", "i8"),
            ("axis", axis_p),
            ("position_loop", loop_p),
        ],
    )
    state = record(
        "feed_drive.servo_axis",
        [
            ("head", "i8"),
            ("step", "i8"),
            ("reference_mm", "f8"),
            ("history_mm_min", "f8", (ring,)),
            ("axis", axis_s),
            ("position_loop", loop_s),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At rest: table, reference and every past command at 0."""
    s.head = 0
    s.step = 0
    s.reference_mm = 0.0
    for i in range(s.history_mm_min.shape[0]):
        s.history_mm_min[i] = 0.0
    servo_axis.init(p.axis, s.axis)
    lead_lag.init(p.position_loop, s.position_loop)


@jit
def output(p, s) -> tuple[float, float, float]:  # noqa: ANN001
    """Table velocity [mm/min], armature current [A] and motor speed [rad/s] at the start
    of the step (what the drive's current and tacho show)."""
    w = s.axis.speed_rad_s
    return w * p.axis.mm_per_rad * 60.0, s.axis.current_A, w


@jit
def step(p, s, command_mm_min: float, load_force_N: float) -> tuple[float, float, float]:  # noqa: ANN001
    """One plant step (module docstring): velocity at its start [mm/min] (twice) and the
    travel [mm]."""
    s.history_mm_min[s.head] = command_mm_min
    delayed = s.history_mm_min[(s.head - p.delay_steps) & p.ring_mask]
    s.head = (s.head + 1) & p.ring_mask
    v = s.axis.speed_rad_s * p.axis.mm_per_rad * 60.0
    x0 = s.axis.position_mm
    x_meas, _, _ = servo_axis.output(p.axis, s.axis, load_force_N)
    command_V = lead_lag_law(p.position_loop, s.position_loop, s.step, s.reference_mm - x_meas)
    servo_axis.step(p.axis, s.axis, command_V, load_force_N)
    s.reference_mm += delayed * p.plant_step_s / 60.0
    s.step += 1
    return v, v, s.axis.position_mm - x0


SERVO_FEED_DRIVE = register_element(
    "feed_drive.servo_axis",
    _dtypes,
    init,
    step,
    "Peng's servo axis under the lead-lag position loop, behind the NC's override delay",
    output,
)


def servo_feed_drive_records(
    delay_steps: ArrayLike,
    plant_step_s: float,
    axis: ServoAxisParams | None = None,
    position_loop: LeadLagParams | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of servo-axis feed drives.

    Parameters
    ----------
    delay_steps : array_like of int, shape (runs,) or scalar
        The NC's override delay of each run in whole plant steps, >= 0.
    plant_step_s : float
        ``dt`` [s]: also the position loop's period.
    axis : ServoAxisParams, optional
        Peng's Appendix A by default.
    position_loop : LeadLagParams, optional
        Peng's D(z) by default.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs, (n,) = per_run(delay_steps, dtype=None)
    if not np.issubdtype(n.dtype, np.integer) or np.any(n < 0):
        raise ValueError("delay_steps must be whole numbers of plant steps, >= 0")
    axis = ServoAxisParams() if axis is None else axis
    position_loop = LeadLagParams() if position_loop is None else position_loop
    ap, _ = servo_axis_records(axis, plant_step_s, runs=runs)
    lp, ls = lead_lag_records(position_loop, axis.counts_per_mm, plant_step_s, runs=runs)
    params, state = SERVO_FEED_DRIVE.records(
        runs, ring=delay_size(int(n.max()) + 1), loop_ring=ls.dtype["history_V"].shape[0]
    )
    params["plant_step_s"] = plant_step_s
    params["delay_steps"] = n
    params["ring_mask"] = state.dtype["history_mm_min"].shape[0] - 1
    params["axis"] = ap
    params["position_loop"] = lp
    return params, init_states(params, state)


__all__ = ["SERVO_FEED_DRIVE", "servo_feed_drive_records"]
