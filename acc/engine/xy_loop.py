"""The two-axis (XY table) contouring loop, compiled: path, axis controllers, CEC, axes.

Clock as :mod:`acc.engine.axis_loop`: plant step ``dt``, step ``k`` at ``t_k = k dt``; the
controllers run once per period of ``m = T / dt`` steps, at ``k = j m + d_j`` (``d_j`` the
period's sampling delay in plant steps, ``0 <= d_j < m``: 0 without jitter, so
``k = 0, m, 2m, ...``), and their commands are held until the next control instant.  The
controllers keep their nominal period (a PC that runs late does not know it).  One plant
step ``k`` of a run:

1. the reference sample ``k`` (:data:`REFERENCE_ROWS`: position, velocity, tangent angle,
   instantaneous centre and radius) and the feed forces on the two axes ``F_x, F_y`` [N]
   (positive opposes positive motion; the axis slot's convention);
2. ``axis`` (output) of each axis: what its sensors show at ``k``;
3. at a control instant: ``u_x = C_x(k, x_r, v_xr, 0, sensors_x)`` and ``u_y`` likewise
   (the controller slot of :mod:`acc.engine.axis_loop`), then the cross-coupled controller
   (:mod:`controllers.contouring.cross_coupled`) on the measured axis errors
   ``E = R - P_meas`` adds ``U_x, U_y``; each sum is limited to ``+-command_limit_V``;
4. ``axis`` (step) of each axis with its command and force held (exact ZOH);
5. the contour error of the *carriage* positions: exact for circles (``Eq. 17``, the
   reference's own centre and radius) and straight parts (the linear form is exact there),
   and, beside it, the estimates Eq. (11) and Eq. (16) of the same carriage positions (the
   estimator accuracy of spec E1-1), all in Peng's sign (+ with the tool to the right of
   the motion; :mod:`controllers.contouring.contour_error`).  On other paths (corners,
   blends) ``contour_error_mm`` is the error to the local circle of the reference; use the
   distance to the path on the traces instead.

6. the verdict (:mod:`acc.engine.axis_verdicts`): a non-finite state, an axis following
   error beyond the run's bound or a current beyond its bound ends the run here (the
   traces end at the step before); a step counts as saturated on an axis when its
   controller's output is at its limit, the command limit clips its command or the current
   limit does.

With the CEC disabled the two axes do not interact: each axis equals its run in
:mod:`acc.engine.axis_loop` bit for bit (tested).
"""

from __future__ import annotations

import math

import numpy as np

from acc.engine.axis_verdicts import CURRENT_BOUND, ERROR_BOUND, NON_FINITE
from acc.engine.element import jit, output, step
from acc.engine.loop_metrics import nan_max
from controllers.contouring.contour_error import curvature_corrected_estimate_at, linear_estimate_at
from controllers.contouring.cross_coupled import contour_error_lacerda_at

#: Rows of the reference array ``(runs, rows, n)``, in order.
REFERENCE_ROWS = (
    "x_mm",
    "y_mm",
    "velocity_x_mm_s",
    "velocity_y_mm_s",
    "tangent_angle_rad",
    "centre_x_mm",
    "centre_y_mm",
    "radius_mm",
)
#: Signals every run records, in trace order.
TRACE_NAMES = (
    "x_ref_mm",
    "y_ref_mm",
    "x_mm",
    "y_mm",
    "x_meas_mm",
    "y_meas_mm",
    "velocity_x_mm_s",
    "velocity_y_mm_s",
    "current_x_A",
    "current_y_A",
    "command_x_V",
    "command_y_V",
    "load_x_N",
    "load_y_N",
    "contour_error_mm",
    "linear_estimate_mm",
    "curvature_estimate_mm",
    "cec_error_mm",
)
#: Per-run metrics, in order.
METRIC_NAMES = (
    "iae_contour_mm_s",
    "max_abs_contour_error_mm",
    "rms_contour_error_mm",
    "iae_x_mm_s",
    "iae_y_mm_s",
    "max_abs_linear_estimate_error_mm",
    "max_abs_curvature_estimate_error_mm",
    "iae_linear_estimate_error_mm_s",
    "iae_curvature_estimate_error_mm_s",
    "max_abs_command_V",
    "max_abs_current_A",
)


@jit
def _limit(u: float, lim: float) -> float:
    if lim > 0.0:
        if u > lim:
            return lim
        if u < -lim:
            return -lim
    return u


@jit
def run_one(
    r: int,
    n_steps: int,
    steps_per_control: int,
    record_every: int,
    plant_step_s: float,
    command_limit_V: float,
    curvature_angle: int,
    control_delay_steps: np.ndarray,
    reference: np.ndarray,
    loads: np.ndarray,
    axis_x_p: np.ndarray,
    axis_x_s: np.ndarray,
    axis_y_p: np.ndarray,
    axis_y_s: np.ndarray,
    ctrl_x_p: np.ndarray,
    ctrl_x_s: np.ndarray,
    ctrl_y_p: np.ndarray,
    ctrl_y_s: np.ndarray,
    cec_p: np.ndarray,
    cec_s: np.ndarray,
    bounds: np.ndarray,
    controller_limits: np.ndarray,
    traces: np.ndarray,
    metrics: np.ndarray,
    verdict: np.ndarray,
    failure_value: np.ndarray,
) -> None:
    """Simulate run ``r`` for ``n_steps`` plant steps (module docstring).

    ``control_delay_steps[r, j]`` is the sampling delay of control period ``j`` [plant
    steps]; ``reference[r, i, k]`` is row ``i`` of :data:`REFERENCE_ROWS` at step ``k``;
    ``loads[r, j, k]`` the feed force on axis ``j`` (0: x, 1: y) [N]; ``traces[r, i, j]``
    receives signal ``i`` of :data:`TRACE_NAMES` at sample ``j`` (every ``record_every``
    steps; 0: none); ``metrics[r, i]`` metric ``i`` of :data:`METRIC_NAMES`.
    ``bounds[r]`` is ``(error bound [mm], current bound [A])``, ``controller_limits[r, j]``
    axis ``j``'s controller output limit (0: none); ``verdict[r]`` receives ``(failure
    code, its plant step, x steps at a limit, the failing axis (0: x, 1: y), y steps at a
    limit)`` and
    ``failure_value[r]`` the value that broke a bound.
    """
    axp = axis_x_p[r]
    axs = axis_x_s[r]
    ayp = axis_y_p[r]
    ays = axis_y_s[r]
    cxp = ctrl_x_p[r]
    cxs = ctrl_x_s[r]
    cyp = ctrl_y_p[r]
    cys = ctrl_y_s[r]
    cp = cec_p[r]
    cs = cec_s[r]
    error_bound = bounds[r, 0]
    current_bound = bounds[r, 1]
    lim_x = controller_limits[r, 0]
    lim_y = controller_limits[r, 1]
    saturated_x = 0
    saturated_y = 0
    at_limit_x = False
    at_limit_y = False
    ux = 0.0
    uy = 0.0
    eps = 0.0
    phase = 0
    period = 0
    rec_count = 0
    j = 0
    iae = 0.0
    sq = 0.0
    max_e = 0.0
    iae_x = 0.0
    iae_y = 0.0
    max_lin = 0.0
    max_cur = 0.0
    iae_lin = 0.0
    iae_cur = 0.0
    max_u = 0.0
    max_i = 0.0
    for k in range(n_steps):
        xr = reference[r, 0, k]
        yr = reference[r, 1, k]
        vxr = reference[r, 2, k]
        vyr = reference[r, 3, k]
        alpha = reference[r, 4, k]
        ccx = reference[r, 5, k]
        ccy = reference[r, 6, k]
        rad = reference[r, 7, k]
        fx = loads[r, 0, k]
        fy = loads[r, 1, k]
        xm, vxm, axm = output(axp, axs, fx)
        ym, vym, aym = output(ayp, ays, fy)
        if phase == control_delay_steps[r, period]:
            ux = step(cxp, cxs, k, xr, vxr, 0.0, xm, vxm, axm)
            uy = step(cyp, cys, k, yr, vyr, 0.0, ym, vym, aym)
            at_limit_x = lim_x > 0.0 and abs(ux) >= lim_x
            at_limit_y = lim_y > 0.0 and abs(uy) >= lim_y
            cx_, cy_, eps = step(cp, cs, xr - xm, yr - ym, alpha, xr, yr, ccx, ccy, rad)
            sx = ux + cx_
            sy = uy + cy_
            ux = _limit(sx, command_limit_V)
            uy = _limit(sy, command_limit_V)
            at_limit_x = at_limit_x or ux != sx
            at_limit_y = at_limit_y or uy != sy
        phase += 1
        if phase == steps_per_control:
            phase = 0
            period += 1
        x, vx, _, ix, appx = step(axp, axs, ux, fx)
        y, vy, _, iy, appy = step(ayp, ays, uy, fy)
        ex = xr - x
        ey = yr - y
        code = 0
        value = 0.0
        which = 0
        for axis_i in range(2):
            ej = abs(ex) if axis_i == 0 else abs(ey)
            vj = abs(vx) if axis_i == 0 else abs(vy)
            if not (ej <= error_bound and vj < math.inf):
                code = NON_FINITE if not (ej < math.inf and vj < math.inf) else ERROR_BOUND
                value = ej
                which = axis_i
                break
        if code == 0:
            for axis_i in range(2):
                ij = abs(ix) if axis_i == 0 else abs(iy)
                if ij > current_bound:
                    code = CURRENT_BOUND
                    value = ij
                    which = axis_i
                    break
        if code != 0:
            verdict[r, 0] = code
            verdict[r, 1] = k
            verdict[r, 3] = which
            failure_value[r] = value
            break
        if at_limit_x or appx != ux:
            saturated_x += 1
        if at_limit_y or appy != uy:
            saturated_y += 1
        e = -contour_error_lacerda_at(2, curvature_angle, ex, ey, alpha, xr, yr, ccx, ccy, rad)
        e_lin = linear_estimate_at(ex, ey, alpha)
        e_cur = curvature_corrected_estimate_at(ex, ey, alpha, xr, yr, ccx, ccy, rad,
                                                curvature_angle)
        ae = abs(e)
        iae += ae
        sq += e * e
        max_e = nan_max(max_e, ae)
        iae_x += abs(ex)
        iae_y += abs(ey)
        d = abs(e_lin - e)
        iae_lin += d
        max_lin = nan_max(max_lin, d)
        d = abs(e_cur - e)
        iae_cur += d
        max_cur = nan_max(max_cur, d)
        max_u = nan_max(max_u, max(abs(appx), abs(appy)))
        a = max(abs(ix), abs(iy))
        if a > max_i:
            max_i = a
        if record_every > 0:
            if rec_count == 0:
                rec_count = record_every
                traces[r, 0, j] = xr
                traces[r, 1, j] = yr
                traces[r, 2, j] = x
                traces[r, 3, j] = y
                traces[r, 4, j] = xm
                traces[r, 5, j] = ym
                traces[r, 6, j] = vx
                traces[r, 7, j] = vy
                traces[r, 8, j] = ix
                traces[r, 9, j] = iy
                traces[r, 10, j] = appx
                traces[r, 11, j] = appy
                traces[r, 12, j] = fx
                traces[r, 13, j] = fy
                traces[r, 14, j] = e
                traces[r, 15, j] = e_lin
                traces[r, 16, j] = e_cur
                traces[r, 17, j] = eps
                j += 1
            rec_count -= 1
    metrics[r, 0] = iae * plant_step_s
    metrics[r, 1] = max_e
    metrics[r, 2] = math.sqrt(sq / max(n_steps, 1))
    metrics[r, 3] = iae_x * plant_step_s
    metrics[r, 4] = iae_y * plant_step_s
    metrics[r, 5] = max_lin
    metrics[r, 6] = max_cur
    metrics[r, 7] = iae_lin * plant_step_s
    metrics[r, 8] = iae_cur * plant_step_s
    metrics[r, 9] = max_u
    metrics[r, 10] = max_i
    verdict[r, 2] = saturated_x
    verdict[r, 4] = saturated_y


@jit(python_entry=True)
def run_runs(runs: np.ndarray, *args: object) -> None:
    """:func:`run_one` for each run index in ``runs`` (one thread's share of a batch)."""
    for i in range(runs.shape[0]):
        run_one(runs[i], *args)


__all__ = ["METRIC_NAMES", "REFERENCE_ROWS", "TRACE_NAMES", "run_one", "run_runs"]
