"""The closed cutting-force loop, compiled: one run at a time, every element written once.

Clock.  Plant step ``dt``; step ``k`` is at ``t_k = k dt`` (an integer clock, never an
accumulated float).  The controller runs every ``m = T_c / dt`` steps, at ``k = 0, m, 2m,
...``, and its override is held until the next control instant (zero-order hold).

One plant step ``k`` of a run, slot by slot (each slot is filled by a compiled element,
:mod:`acc.engine.element`; the element is chosen by the scenario and known at compile time):

1. ``workpiece``: the segment (depths) the tool meets at its position ``p_k``;
2. ``force_process`` (output): the force ``f_k`` from the chip-load state ``x_k`` (table
   gain or the geometric model) and the feed-direction force that loads the screw;
   ``disturbances``: a force multiplier (hardness, axial depth) and additive force, the
   additive feed at the drive's input, the measurement's gain and bias;
3. ``sensor``: the force the controller sees ``y_k`` (noise, low-pass; or estimated from
   the feed-motor current, Kim & Chung's model or Peng's estimators on the servo axis's
   current and speed ``I_a[k], W[k]``, which the feed drive shows at the start of the
   step) and, where there is one, the measured current;
   ``monitor``: the tool-breakage detector on the measured current (or force), every step
   (:mod:`controllers.monitoring.breakage_monitor`; without ``[tool_breakage]`` the slot
   holds ``monitor.off``, whose empty step compiles away);
4. at a control instant, ``controller``: ``override = C(y_k)``, ``u = override x F_prog``;
5. ``metrics``: IAE, ISE, peaks, settling, finish, failure of step ``k``; the trace sample;
   the run stops here once the part is finished or the run has failed;
6. ``feed_drive``: the command goes through the dead time and the lag (exact), giving the
   velocity ``v_k``, the delayed command and the exact travel (or through Peng's servo
   axis, loaded by the feed force: :mod:`controllers.axis.servo_feed_drive`);
   ``force_process`` (step): the chip load advances to ``k + 1``, exact given the drive's
   lag; the position by the travel.

The depth is constant over a plant step (the only approximation); for a constant depth the
loop is the exact sampled-data system (tested against python-control).
"""

from __future__ import annotations

import numpy as np

from acc.engine.element import jit, output, step
from controllers.robust_force_controller import DIAGNOSTIC_NAMES

#: Signals every run records (then the controller diagnostics), in trace order.
TRACE_NAMES = (
    "force_N",
    "measured_force_N",
    "reference_force_N",
    "override",
    "commanded_feed_mm_min",
    "feed_velocity_mm_min",
    "position_mm",
    "feed_current_A",
    "disturbance_force_N",
    "disturbance_feed_mm_min",
    "breakage_monitor_signal",
    *DIAGNOSTIC_NAMES,
)
N_DIAGNOSTICS = len(DIAGNOSTIC_NAMES)
_FIRST_DIAGNOSTIC = len(TRACE_NAMES) - N_DIAGNOSTICS

#: A run's scratch record: the buffer its controller writes its diagnostics into.  A field of
#: a record, not an array of its own: numba passes a record's array field to a call without
#: a reference count, where an allocated array's count is changed twice a call by x86
#: ``lock`` instructions, which wait for every earlier store (the control period's last
#: results) before any later load runs (2-3 % of a plant step, ``bench_paired.py``).
SCRATCH = np.dtype([("diagnostics", "f8", (N_DIAGNOSTICS,))], align=True)


def scratch_records(runs: int) -> np.ndarray:
    """The scratch records of a batch, shape (runs,) (:data:`SCRATCH`)."""
    return np.zeros(runs, dtype=SCRATCH)


@jit(python_entry=True)
def run_runs(
    runs: np.ndarray,
    n_steps: int,
    steps_per_control: int,
    record_every: int,
    programmed_feed_mm_min: np.ndarray,
    reference_force_N: np.ndarray,
    slots: tuple,
    traces: np.ndarray,
    trace_segment: np.ndarray,
    scratch: np.ndarray,
) -> None:
    """Simulate each run ``r`` of ``runs`` (one thread's share of a batch) for up to
    ``n_steps`` plant steps (module docstring); the runs' states are advanced in place.

    ``slots`` holds the records arrays of the slots, shape (runs,) each, in the order
    ``workpiece, force_process, disturbances, sensor, controller, feed_drive, metrics,
    monitor`` (params then state of each).  ``traces[r, i, j]`` receives signal ``i`` of
    :data:`TRACE_NAMES` at sample ``j`` (every ``record_every`` steps; 0: none) and
    ``trace_segment[r, j]`` the segment.  ``scratch``: the runs' :data:`SCRATCH` records.

    One function, not a loop calling a per-run function: numba would optimise and emit the
    whole plant step twice, once in each (about 0.4 s of a cold compile).
    """
    wp_pa, wp_sa, ppa, psa, xpa, xsa, spa, ssa, cpa, csa, dpa, dsa, mpa, msa, bpa, bsa = slots
    for i in range(runs.shape[0]):
        r = runs[i]
        wp_p, wp_s, pp, ps, xp, xs = wp_pa[r], wp_sa[r], ppa[r], psa[r], xpa[r], xsa[r]
        sp, ss, bp, bs = spa[r], ssa[r], bpa[r], bsa[r]
        cp, cs, dp, ds, mp, ms = cpa[r], csa[r], dpa[r], dsa[r], mpa[r], msa[r]
        prog = programmed_feed_mm_min[r]
        ref = reference_force_N[r]
        diag = scratch[r].diagnostics
        diag[:] = np.nan
        position = 0.0
        override = 0.0
        command = 0.0
        ctrl_count = 0  # steps to the next control instant
        rec_count = 0  # steps to the next trace sample
        j = 0
        segments = wp_p.segments
        for k in range(n_steps):
            segment = output(wp_p, wp_s, position)
            finished = segment == segments
            force, feed_force, cross_force = output(pp, ps, segment, k, position)
            mult, d_force, d_feed, m_gain, m_bias = step(
                xp, xs, k, position, wp_p.axial_depth_mm[segment]
            )
            force = force * mult + d_force
            feed_force = feed_force * mult + d_force
            cross_force = cross_force * mult
            velocity, drive_current, drive_speed = output(dp, ds)
            measured, current = step(
                sp, ss, force, feed_force, velocity, drive_current, drive_speed
            )
            measured = m_gain * measured + m_bias
            watched, _ = step(bp, bs, k, position, force, measured, current, cross_force)
            if ctrl_count == 0:
                override = step(cp, cs, measured, diag)
                command = override * prog
                ctrl_count = steps_per_control
            ctrl_count -= 1
            stop = step(mp, ms, k, force, segment, finished, position)
            if record_every > 0:
                if rec_count == 0:
                    rec_count = record_every
                    traces[r, 0, j] = force
                    traces[r, 1, j] = measured
                    traces[r, 2, j] = ref
                    traces[r, 3, j] = override
                    traces[r, 4, j] = command
                    traces[r, 5, j] = velocity
                    traces[r, 6, j] = position
                    traces[r, 7, j] = current
                    traces[r, 8, j] = d_force
                    traces[r, 9, j] = d_feed
                    traces[r, 10, j] = watched
                    for i in range(N_DIAGNOSTICS):
                        traces[r, _FIRST_DIAGNOSTIC + i, j] = diag[i]
                    trace_segment[r, j] = segment
                    j += 1
                rec_count -= 1
            if stop:
                break
            v, delayed, travel = step(dp, ds, command + d_feed, feed_force)
            step(pp, ps, segment, v, delayed)
            position += travel


__all__ = ["N_DIAGNOSTICS", "SCRATCH", "TRACE_NAMES", "run_runs", "scratch_records"]
