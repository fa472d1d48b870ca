"""The single-axis position loop, compiled: reference, controller, axis, cutting load.

Clock.  Plant step ``dt``; step ``k`` is at ``t_k = k dt``.  The position controller runs
every ``m = T / dt`` steps, at ``k = 0, m, 2m, ...``, and its command is held until the next
control instant (zero-order hold, as the D/A converter holds ``V_c``).

One plant step ``k`` of a run, slot by slot (each slot filled by a compiled element of
:mod:`acc.engine.element`, chosen when the records are built):

1. ``load`` (:mod:`acc.engine.piecewise`): the feed force on the table ``F_k`` [N];
2. ``reference`` (:mod:`acc.engine.piecewise`): ``x_r``, ``v_r``, ``a_r`` at ``k``;
3. ``axis`` (output): what the sensors show at ``k`` (position [mm], speed [mm/s],
   acceleration [mm/s^2]);
4. at a control instant, ``controller``: ``u = C(k, x_r, v_r, a_r, sensors)`` (V for a servo
   axis, mm/s for a speed-commanded one);
5. ``axis`` (step): position, velocity, acceleration and current at ``k``, then the state
   advances to ``k + 1`` with ``u`` and ``F_k`` held (exact ZOH of the linear part);
6. the verdict (:mod:`acc.engine.axis_verdicts`): a non-finite state, a following error
   ``e_k = x_r - x`` beyond the run's bound or a current beyond its bound ends the run here
   (its traces end at the step before); else the metrics of ``e_k`` and the trace sample.

For Peng's linear axis with the lead-lag controller and ``m = 1`` this is exactly
``x(k+1) = G x(k) + Gamma u(k)`` of his Eq. (2.31) (tested).

Contracts of the slots (the element kinds that fill them):

* axis (``axis.servo``, ``axis.oscillating``): ``output(p, s, load_N) -> (x_meas, v_meas,
  a_meas)``; ``step(p, s, command, load_N) -> (x, v, a, current, applied_command)``;
* controller (``position_controller.*``): ``step(p, s, k, x_r, v_r, a_r, x_meas, v_meas,
  a_meas) -> command``;
* reference and load (``signal.piecewise``): ``step(p, s, k) -> (value, slope, curvature)``.
"""

from __future__ import annotations

import math

import numpy as np

from acc.engine.axis_verdicts import CURRENT_BOUND, ERROR_BOUND, NON_FINITE
from acc.engine.element import jit, output, step
from acc.engine.loop_metrics import nan_max

#: Signals every run records, in trace order.
TRACE_NAMES = (
    "x_ref_mm",
    "x_mm",
    "x_meas_mm",
    "following_error_mm",
    "velocity_mm_s",
    "acceleration_mm_s2",
    "current_A",
    "command",
    "load_force_N",
)
#: Per-run metrics, in order.
METRIC_NAMES = (
    "iae_mm_s",
    "rms_following_error_mm",
    "max_abs_following_error_mm",
    "final_following_error_mm",
    "max_abs_current_A",
    "max_abs_command",
)


@jit
def run_one(
    r: int,
    n_steps: int,
    steps_per_control: int,
    record_every: int,
    plant_step_s: float,
    reference_p: np.ndarray,
    reference_s: np.ndarray,
    load_p: np.ndarray,
    load_s: np.ndarray,
    axis_p: np.ndarray,
    axis_s: np.ndarray,
    controller_p: np.ndarray,
    controller_s: np.ndarray,
    bounds: np.ndarray,
    command_limit: np.ndarray,
    traces: np.ndarray,
    metrics: np.ndarray,
    verdict: np.ndarray,
    failure_value: np.ndarray,
) -> None:
    """Simulate run ``r`` for ``n_steps`` plant steps (module docstring).

    ``bounds[r]`` is ``(error bound [mm], current bound [A])`` and ``command_limit[r]`` the
    controller's output limit (0: none) that counts a step as saturated.
    ``traces[r, i, j]`` receives signal ``i`` of :data:`TRACE_NAMES` at sample ``j`` (every
    ``record_every`` steps; 0: none); ``metrics[r, i]`` metric ``i`` of
    :data:`METRIC_NAMES`; ``verdict[r]`` ``(failure code, its plant step, steps at a
    limit)`` and ``failure_value[r]`` the value that broke a bound.
    """
    rp = reference_p[r]
    rs = reference_s[r]
    lp = load_p[r]
    ls = load_s[r]
    ap = axis_p[r]
    as_ = axis_s[r]
    cp = controller_p[r]
    cs = controller_s[r]
    error_bound = bounds[r, 0]
    current_bound = bounds[r, 1]
    limit = command_limit[r]
    saturated = 0
    command = 0.0
    ctrl_count = 0
    rec_count = 0
    j = 0
    iae = 0.0
    sq = 0.0
    max_e = 0.0
    max_i = 0.0
    max_u = 0.0
    e = 0.0
    for k in range(n_steps):
        load, _, _ = step(lp, ls, k)
        x_ref, v_ref, a_ref = step(rp, rs, k)
        x_meas, v_meas, a_meas = output(ap, as_, load)
        if ctrl_count == 0:
            command = step(cp, cs, k, x_ref, v_ref, a_ref, x_meas, v_meas, a_meas)
            ctrl_count = steps_per_control
        ctrl_count -= 1
        x, v, a, current, applied = step(ap, as_, command, load)
        e = x_ref - x
        ae = abs(e)
        code = 0
        value = ae
        if not (ae <= error_bound and abs(v) < math.inf):
            code = NON_FINITE if not (ae < math.inf and abs(v) < math.inf) else ERROR_BOUND
        elif abs(current) > current_bound:
            code = CURRENT_BOUND
            value = abs(current)
        if code != 0:
            verdict[r, 0] = code
            verdict[r, 1] = k
            failure_value[r] = value
            break
        if applied != command or (limit > 0.0 and abs(command) >= limit):
            saturated += 1
        iae += ae
        sq += e * e
        max_e = nan_max(max_e, ae)
        if abs(current) > max_i:
            max_i = abs(current)
        max_u = nan_max(max_u, abs(applied))
        if record_every > 0:
            if rec_count == 0:
                rec_count = record_every
                traces[r, 0, j] = x_ref
                traces[r, 1, j] = x
                traces[r, 2, j] = x_meas
                traces[r, 3, j] = e
                traces[r, 4, j] = v
                traces[r, 5, j] = a
                traces[r, 6, j] = current
                traces[r, 7, j] = applied
                traces[r, 8, j] = load
                j += 1
            rec_count -= 1
    metrics[r, 0] = iae * plant_step_s
    metrics[r, 1] = math.sqrt(sq / max(n_steps, 1))
    metrics[r, 2] = max_e
    metrics[r, 3] = e
    metrics[r, 4] = max_i
    metrics[r, 5] = max_u
    verdict[r, 2] = saturated


@jit(python_entry=True)
def run_runs(runs: np.ndarray, *args: object) -> None:
    """:func:`run_one` for each run index in ``runs`` (one thread's share of a batch);
    ``args`` are :func:`run_one`'s after the run index."""
    for i in range(runs.shape[0]):
        run_one(runs[i], *args)


__all__ = ["METRIC_NAMES", "TRACE_NAMES", "run_one", "run_runs"]
