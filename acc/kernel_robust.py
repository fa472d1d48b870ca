"""Compiled step of the robust adaptive force controller (adaptive PI, DOB), for :mod:`acc.kernel`.

One control period of :class:`controllers.robust_force_controller.RobustForceController` for
one run, operation for operation (kinds ``adaptive_pi``, ``dob_pi``, ``dob_adaptive_pi``
with the ``"rls"`` estimator): gain estimator update with its guards (in-cut, excitation,
reset and skip, covariance trace bound, projection), adaptive PI gains, disturbance
observer estimate on the nominal or the estimated model, PI law with clamping
anti-windup, then the command into the estimator's and the observer's delay lines.

Layout.  A run's parameters are a flat float array ``p`` and its state a flat float array
``s``; :func:`pack_robust` builds both for a batch from the NumPy controller, so the
derived values (ZOH numerators, observer filter matrices, bounds) come from the same code.
Integers (delays, ring sizes, filter orders, flags) are stored as floats and read back with
``int()``.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from controllers.gain_estimator import EXCITATION_WEIGHT, SKIP_AFTER_RESET
from controllers.robust_force_controller import RobustForceController

# --- parameter layout ------------------------------------------------------------------
P_REF, P_KP, P_KI, P_LO, P_HI, P_FEED = 0, 1, 2, 3, 4, 5
P_A, P_K2N, P_P2N, P_TC, P_CLAMP = 6, 7, 8, 9, 10
P_HAS_EST, P_HAS_OBS, P_OBS_EST = 11, 12, 13
P_PHI_A, P_FMIN_FRAC, P_EXC_THR, P_RESET_FRAC, P_LAMBDA, P_VAR = 14, 15, 16, 17, 18, 19
P_TRACE_MAX, P_PHI2_LO, P_PHI2_HI, P_G_LO, P_G_HI = 20, 21, 22, 23, 24
P_EST_DELAY, P_EST_SIZE = 25, 26
P_THETA0 = 27  # 3 values
P_P0 = 30  # 9 values, row-major
P_OBS_DELAY, P_OBS_SIZE, P_LIMIT, P_NB, P_NI = 39, 40, 41, 42, 43
P_OBS = 44  # bank_A (nb*nb), bank_B (nb), bank_C (3*nb), bank_D (3), in_A (ni*ni), in_B, in_C

# --- state layout ------------------------------------------------------------------------
S_INTEGRAL = 0
S_THETA = 1  # 3
S_COV = 4  # 9
S_F1, S_F2, S_EXC, S_SKIP, S_EST_HEAD = 13, 14, 15, 16, 17
S_EST_HIST = 18  # est_size values, then the observer: xb (nb), xi (ni), head, history


@numba.njit(cache=True, nogil=True)
def _clip(x: float, lo: float, hi: float) -> float:
    """``numpy.clip`` for one value (NaN stays NaN)."""
    if x < lo:
        return lo
    if x > hi:
        return hi
    return x


@numba.njit(cache=True, nogil=True)
def _wrap(i: int, size: int) -> int:
    """``i % size`` for ``-2 size < i < 2 size`` (ring-buffer slots), without a division."""
    if i < 0:
        i += size
        if i < 0:
            i += size
    elif i >= size:
        i -= size
    return i


@numba.njit(cache=True, nogil=True)
def _row_dot(p: NDArray, at: int, s: NDArray, st: int, n: int) -> float:
    """``sum_j p[at + j] s[st + j]``, summed in order (as ``einsum`` does for short rows)."""
    acc = 0.0
    for j in range(n):
        acc += p[at + j] * s[st + j]
    return acc


@numba.njit(cache=True, nogil=True)
def _sym(s: NDArray, i: int, j: int, kv: tuple, phv: tuple, lam: float) -> float:
    """Entry ``(i, j)`` of ``0.5 (Q + Q^T)``, ``Q = (P - K Ph^T) / lam`` (RLS covariance)."""
    qij = (s[S_COV + 3 * i + j] - kv[i] * phv[j]) / lam
    qji = (s[S_COV + 3 * j + i] - kv[j] * phv[i]) / lam
    return 0.5 * (qij + qji)


@numba.njit(cache=True, nogil=True)
def robust_step(p: NDArray, s: NDArray, y: float, diag: NDArray) -> float:
    """One control period; ``s`` is updated in place; returns the override [-].

    ``diag`` receives the controller's diagnostics in the order of
    :data:`controllers.robust_force_controller.DIAGNOSTIC_NAMES`.
    """
    r = p[P_REF]
    F = p[P_FEED]
    tc = p[P_TC]
    k2m = p[P_K2N]
    p2m = p[P_P2N]
    kp = p[P_KP]
    ki = p[P_KI]
    k2_est = p[P_K2N]
    p2_est = p[P_P2N]
    updated = 0.0
    has_est = p[P_HAS_EST] > 0.5
    has_obs = p[P_HAS_OBS] > 0.5
    est_size = int(p[P_EST_SIZE])
    obs_at = S_EST_HIST + est_size
    nb = int(p[P_NB])
    ni = int(p[P_NI])
    if has_est:
        # --- ProcessGainEstimator.update ------------------------------------------------
        phi_a = p[P_PHI_A]
        f1 = s[S_F1]
        f2 = s[S_F2]
        head = int(s[S_EST_HEAD])
        d = int(p[P_EST_DELAY])
        u1 = s[S_EST_HIST + _wrap(head - 1 - d, est_size)]
        u2 = s[S_EST_HIST + _wrap(head - 2 - d, est_size)]
        yy = (y - phi_a * f1) / r
        h0 = (f1 - phi_a * f2) / r
        h1 = u1 / F
        h2 = u2 / F
        w = EXCITATION_WEIGHT
        du = (u1 - u2) / F
        excitation = (1 - w) * s[S_EXC] + w * (du * du)
        fmin = p[P_FMIN_FRAC] * r
        in_cut = (y > fmin) and (f1 > fmin) and (f2 > fmin)
        t0 = s[S_THETA]
        t1 = s[S_THETA + 1]
        t2 = s[S_THETA + 2]
        err = yy - (h0 * t0 + h1 * t1 + h2 * t2)
        reset = in_cut and (abs(err) > p[P_RESET_FRAC])
        old_skip = s[S_SKIP]
        if reset:
            s[S_SKIP] = SKIP_AFTER_RESET
        else:
            s[S_SKIP] = max(old_skip - 1.0, 0.0)
        gate = in_cut and (excitation > p[P_EXC_THR]) and (not reset) and (old_skip == 0.0)
        if reset:
            for i in range(9):
                s[S_COV + i] = p[P_P0 + i]
        if gate:
            updated = 1.0
            # _rls: one step with forgetting (no heap arrays in the hot path)
            lam = p[P_LAMBDA]
            c = S_COV
            ph0 = s[c] * h0 + s[c + 1] * h1 + s[c + 2] * h2
            ph1 = s[c + 3] * h0 + s[c + 4] * h1 + s[c + 5] * h2
            ph2 = s[c + 6] * h0 + s[c + 7] * h1 + s[c + 8] * h2
            denom = lam * p[P_VAR] + (h0 * ph0 + h1 * ph1 + h2 * ph2)
            k0 = ph0 / denom
            k1 = ph1 / denom
            k2g = ph2 / denom
            e2 = yy - (h0 * t0 + h1 * t1 + h2 * t2)
            th0 = t0 + k0 * e2
            th1 = t1 + k1 * e2
            th2 = t2 + k2g * e2
            kv = (k0, k1, k2g)
            phv = (ph0, ph1, ph2)
            q00 = _sym(s, 0, 0, kv, phv, lam)
            q01 = _sym(s, 0, 1, kv, phv, lam)
            q02 = _sym(s, 0, 2, kv, phv, lam)
            q11 = _sym(s, 1, 1, kv, phv, lam)
            q12 = _sym(s, 1, 2, kv, phv, lam)
            q22 = _sym(s, 2, 2, kv, phv, lam)
            tr = q00 + q11 + q22
            scale = min(1.0, p[P_TRACE_MAX] / tr)
            s[c] = q00 * scale
            s[c + 1] = q01 * scale
            s[c + 2] = q02 * scale
            s[c + 3] = q01 * scale
            s[c + 4] = q11 * scale
            s[c + 5] = q12 * scale
            s[c + 6] = q02 * scale
            s[c + 7] = q12 * scale
            s[c + 8] = q22 * scale
            # _project
            th0 = _clip(th0, p[P_PHI2_LO], p[P_PHI2_HI])
            bsum = th1 + th2
            to_gain = (r / F) / ((1.0 - phi_a) * (1.0 - th0))
            g = bsum * to_gain
            g_clip = _clip(g, p[P_G_LO], p[P_G_HI])
            if not (g == g_clip):
                nom_sum = p[P_THETA0 + 1] + p[P_THETA0 + 2]
                den = bsum if bsum > 0 else 1.0
                sh1 = th1 / den if (bsum > 0 and th1 >= 0) else p[P_THETA0 + 1] / nom_sum
                sh2 = th2 / den if (bsum > 0 and th2 >= 0) else p[P_THETA0 + 2] / nom_sum
                target = g_clip / to_gain
                th1 = sh1 * target
                th2 = sh2 * target
            s[S_THETA] = th0
            s[S_THETA + 1] = th1
            s[S_THETA + 2] = th2
        s[S_F2] = f1
        s[S_F1] = y
        s[S_EXC] = excitation
        # estimates (ProcessGainEstimator._physical) and adaptive_pi_gains
        phi2 = s[S_THETA]
        p2h = math.log(phi2) / tc
        gh = (s[S_THETA + 1] + s[S_THETA + 2]) * (r / F) / ((1.0 - phi_a) * (1.0 - phi2))
        k2h = gh * (-p2h)
        k2_est = k2h
        p2_est = p2h
        ratio = p[P_K2N] / k2h
        kp = p[P_KP] * ratio
        ki = p[P_KI] * ratio * p2h / p[P_P2N]
        if p[P_OBS_EST] > 0.5:
            k2m = k2h
            p2m = p2h
    dist = 0.0
    if has_obs:
        # --- DisturbanceObserver.estimate ----------------------------------------------
        o_a = P_OBS
        o_b = o_a + nb * nb
        o_c = o_b + nb
        o_d = o_c + 3 * nb
        xb = obs_at
        xi = obs_at + nb
        m0 = _row_dot(p, o_c, s, xb, nb) + p[o_d] * y
        m1 = _row_dot(p, o_c + nb, s, xb, nb) + p[o_d + 1] * y
        m2 = _row_dot(p, o_c + 2 * nb, s, xb, nb) + p[o_d + 2] * y
        a = p[P_A]
        implied = (m0 + (a - p2m) * m1 - a * p2m * m2) / (a * k2m)
        i_c = o_d + 3 + ni * ni + ni
        dq = _row_dot(p, i_c, s, xi, ni)
        lim = p[P_LIMIT]
        dist = _clip(implied - dq, -lim, lim)
    # --- pi_law ---------------------------------------------------------------------------
    e = r - y
    integral = s[S_INTEGRAL]
    w_out = kp * e + integral + (-dist / F)
    lo = p[P_LO]
    hi = p[P_HI]
    override = _clip(w_out, lo, hi)
    di = ki * tc * e
    if p[P_CLAMP] > 0.5 and (((w_out > hi) and (e > 0)) or ((w_out < lo) and (e < 0))):
        di = 0.0
    s[S_INTEGRAL] = integral + di
    command = override * F
    diag[0] = kp
    diag[1] = ki
    diag[2] = k2_est
    diag[3] = p2_est
    diag[4] = k2_est / (-p2_est)
    diag[5] = updated
    diag[6] = dist
    if has_est:
        head = int(s[S_EST_HEAD])
        s[S_EST_HIST + head] = command
        s[S_EST_HEAD] = _wrap(head + 1, est_size)
    if has_obs:
        # --- DisturbanceObserver.advance -----------------------------------------------
        o_a = P_OBS
        o_b = o_a + nb * nb
        o_c = o_b + nb
        o_d = o_c + 3 * nb
        i_a = o_d + 3
        i_b = i_a + ni * ni
        xb = obs_at
        xi = obs_at + nb
        head_at = xi + ni
        hist = head_at + 1
        obs_size = int(p[P_OBS_SIZE])
        head = int(s[head_at])
        s[hist + head] = command
        delayed = s[hist + _wrap(head - int(p[P_OBS_DELAY]), obs_size)]
        scratch = hist + obs_size  # nb + ni slots for the new filter states
        for i in range(nb):
            s[scratch + i] = _row_dot(p, o_a + nb * i, s, xb, nb) + p[o_b + i] * y
        for i in range(ni):
            s[scratch + nb + i] = _row_dot(p, i_a + ni * i, s, xi, ni) + p[i_b + i] * delayed
        for i in range(nb):
            s[xb + i] = s[scratch + i]
        for i in range(ni):
            s[xi + i] = s[scratch + nb + i]
        s[head_at] = _wrap(head + 1, obs_size)
    return override


def unsupported_robust(ctrl: RobustForceController) -> str | None:
    """Why the compiled step cannot run a robust controller (None if it can)."""
    if ctrl.estimator is not None and ctrl.estimator.params.method != "rls":
        return f"estimator {ctrl.estimator.params.method!r} (compiled: 'rls')"
    if ctrl.observer is not None and ctrl.observer.bank_C.shape[1] != 3:
        return "an observer bank without 3 outputs"
    return None


def pack_robust(ctrl: RobustForceController) -> tuple[NDArray, NDArray]:
    """Parameters ``(runs, P)`` and initial state ``(runs, S)`` of a batch (module layout)."""
    runs = ctrl.runs
    est, obs = ctrl.estimator, ctrl.observer
    nb = 0 if obs is None else obs.bank_A.shape[1]
    ni = 0 if obs is None else obs.in_A.shape[1]
    n_obs = nb * nb + nb + 3 * nb + 3 + ni * ni + ni + ni
    p = np.zeros((runs, P_OBS + n_obs))
    p[:, P_REF] = ctrl.reference_force_N
    p[:, P_KP] = ctrl.kp_per_N
    p[:, P_KI] = ctrl.ki_per_N_s
    p[:, P_LO] = ctrl.override_min
    p[:, P_HI] = ctrl.override_max
    p[:, P_FEED] = ctrl.programmed_feed_mm_min
    p[:, P_A] = ctrl.bandwidth_rad_s
    p[:, P_K2N] = ctrl.k2_N_min_per_mm_s
    p[:, P_P2N] = ctrl.p2_rad_s
    p[:, P_TC] = ctrl.control_period_s
    p[:, P_CLAMP] = 1.0 if ctrl.anti_windup == "clamping" else 0.0
    p[:, P_HAS_EST] = est is not None
    p[:, P_HAS_OBS] = obs is not None
    p[:, P_OBS_EST] = ctrl.observer_model == "estimated"
    p[:, P_NB] = nb
    p[:, P_NI] = ni
    est_size = 0
    st0 = ctrl.init()
    if est is not None:
        prm = est.params
        est_size = est._size
        p[:, P_PHI_A] = est.phi_a
        p[:, P_FMIN_FRAC] = prm.min_force_fraction
        p[:, P_EXC_THR] = prm.excitation_threshold
        p[:, P_RESET_FRAC] = prm.reset_error_fraction
        p[:, P_LAMBDA] = prm.forgetting
        p[:, P_VAR] = prm.measurement_std_fraction**2
        p[:, P_TRACE_MAX] = est.trace_max
        p[:, P_PHI2_LO], p[:, P_PHI2_HI] = est.phi2_bounds
        p[:, P_G_LO], p[:, P_G_HI] = est.gain_bounds
        p[:, P_EST_DELAY] = est.delay_periods
        p[:, P_EST_SIZE] = est_size
        p[:, P_THETA0 : P_THETA0 + 3] = est.theta0
        p[:, P_P0 : P_P0 + 9] = est.P0.reshape(runs, 9)
    obs_size = 0
    if obs is not None:
        obs_size = obs._size
        p[:, P_OBS_DELAY] = obs.delay_periods
        p[:, P_OBS_SIZE] = obs_size
        p[:, P_LIMIT] = obs.limit_mm_min
        p[:, P_OBS:] = np.column_stack(
            [
                obs.bank_A.reshape(runs, -1),
                obs.bank_B.reshape(runs, -1),
                obs.bank_C.reshape(runs, -1),
                obs.bank_D.reshape(runs, -1),
                obs.in_A.reshape(runs, -1),
                obs.in_B.reshape(runs, -1),
                obs.in_C.reshape(runs, -1),
            ]
        )
    scratch = nb + ni if obs is not None else 0
    s = np.zeros((runs, S_EST_HIST + est_size + nb + ni + 1 + obs_size + scratch))
    s[:, S_INTEGRAL] = st0.integral
    if est is not None:
        e0 = st0.estimator
        s[:, S_THETA : S_THETA + 3] = e0.theta
        s[:, S_COV : S_COV + 9] = e0.covariance.reshape(runs, 9)
        s[:, S_F1] = e0.force_N[:, 0]
        s[:, S_F2] = e0.force_N[:, 1]
        s[:, S_EXC] = e0.excitation
        s[:, S_SKIP] = e0.skip
        s[:, S_EST_HEAD] = e0.head
        s[:, S_EST_HIST : S_EST_HIST + est_size] = e0.history_mm_min
    if obs is not None:
        o0 = st0.observer
        at = S_EST_HIST + est_size
        s[:, at : at + nb] = o0.force_bank
        s[:, at + nb : at + nb + ni] = o0.input_filter
        s[:, at + nb + ni] = o0.head
        s[:, at + nb + ni + 1 : at + nb + ni + 1 + obs_size] = o0.history_mm_min
    return p, s


__all__ = ["pack_robust", "robust_step", "unsupported_robust"]
