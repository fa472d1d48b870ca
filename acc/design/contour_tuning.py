"""Gains of the XY table's PIDs as Lacerda & Belo tune them (spec A1-3, A1-4).

* :func:`ziegler_nichols_pid` (A1-4, the experiment, L280): the ultimate gain ``K_u`` of
  the P-only loop and its period ``T_u`` from the sampled linear loop (the smallest ``K_p``
  at which the spectral radius of the closed loop reaches 1, by bisection; ``T_u`` from the
  angle of the critical eigenvalue), then the classic table ``K_p = 0.6 K_u``,
  ``T_i = T_u/2``, ``T_d = td_scale T_u/8`` (the paper then "increased the derivative time").
* :func:`tune_axis_pid` (A1-3, MATLAB FMINS in the paper): Nelder-Mead
  (``scipy.optimize.minimize``) over ``log(K_p, K_i, K_d)`` (so the gains stay > 0) from the
  ZN gains, minimising the IAE of the carriage error tracking ``A sin(2 pi f t)`` with the
  unlimited controller output, plus a penalty ``w (max|u| - 10 V)`` when the output leaves
  +-10 V (the paper's constraint).
* :func:`tune_cec_pid`: Nelder-Mead over the CEC's gains with the axis gains fixed,
  minimising the IAE of the exact contour error (Eq. 17) on the test circle; the axis
  commands are limited to +-10 V inside the loop, so the constraint holds by construction.

Deterministic: a fixed initial simplex (each gain x/ e^0.5 around the start) and fixed
iteration caps.  Defaults [ASSUMED] where the paper is silent (sinusoid amplitude and
frequency: the circle's radius and ``v / (2 pi r)``; penalty weight).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import expm
from scipy.optimize import minimize

from acc.engine.axis_simulate import simulate_axis
from acc.engine.xy_simulate import XYReference, simulate_xy
from controllers.axis.pid import AxisPIDParams
from controllers.contouring.cross_coupled import CrossCoupledParams
from plants.axis.elastic_axis import ElasticAxisParams


@dataclass(frozen=True)
class TuningResult:
    """A tuned PID.

    Attributes
    ----------
    kp, ki, kd : float
        Gains [V/mm, V/(mm s), V s/mm].
    cost : float
        Objective at the gains (IAE [mm s] plus any penalty).
    start_cost : float
        Objective at the start gains.
    evaluations : int
        Objective evaluations.
    """

    kp: float
    ki: float
    kd: float
    cost: float
    start_cost: float
    evaluations: int


def _sampled_loop(axis: ElasticAxisParams, period_s: float) -> tuple[np.ndarray, np.ndarray,
                                                                     np.ndarray]:
    """Linear axis from the command [V] to the motor-side position [mm], ZOH at the period."""
    A, B = axis.continuous_matrices()
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = A
    M[:n, n] = B[:, 0] * axis.amplifier_gain_V_V
    E = expm(M * period_s)
    C = np.zeros(n)
    C[0] = axis.mm_per_rad
    return E[:n, :n], E[:n, n], C


def closed_loop_spectral_radius(axis: ElasticAxisParams, kp: float, ki: float, kd: float,
                               period_s: float = 1e-3) -> float:
    """Spectral radius of the sampled linear loop with LinuxCNC's PID (< 1: stable).

    State ``[x (5), errorI, previous feedback]``; with ``r = 0``, ``e = -C x``:
    ``errorI += e T``, ``u = K_p e + K_i errorI + K_d (e - e_prev)/T`` (the integral is
    updated before the output, as ``calc_pid``); friction, limits and quantisation left out.
    """
    phi, gamma, c = _sampled_loop(axis, period_s)
    n = phi.shape[0]
    T = period_s
    # u = g_x x + g_i I + g_p y_prev, with I the integral *before* this period's update
    g_x = -kp * c - ki * T * c - kd / T * c
    g_i, g_p = ki, kd / T
    M = np.zeros((n + 2, n + 2))
    M[:n, :n] = phi + np.outer(gamma, g_x)
    M[:n, n] = gamma * g_i
    M[:n, n + 1] = gamma * g_p
    M[n, :n] = -T * c
    M[n, n] = 1.0
    M[n + 1, :n] = c
    return float(np.max(np.abs(np.linalg.eigvals(M))))


def ultimate_gain(axis: ElasticAxisParams, period_s: float = 1e-3) -> tuple[float, float]:
    """``(K_u [V/mm], T_u [s])`` of the P-only sampled loop ``u(k) = -K_p x_meas(k)``
    (friction, limits and quantisation left out)."""
    phi, gamma, c = _sampled_loop(axis, period_s)

    def radius(kp: float) -> tuple[float, complex]:
        w = np.linalg.eigvals(phi - kp * np.outer(gamma, c))
        i = int(np.argmax(np.abs(w)))
        return float(abs(w[i])), complex(w[i])

    lo, hi = 1e-6, 1.0
    while radius(hi)[0] < 1.0:
        hi *= 2.0
        if hi > 1e6:
            raise ValueError("the P-only loop stays stable: no ultimate gain")
    for _ in range(80):
        mid = math.sqrt(lo * hi)
        if radius(mid)[0] < 1.0:
            lo = mid
        else:
            hi = mid
    w = radius(hi)[1]
    angle = abs(math.atan2(w.imag, w.real))
    return hi, (2 * math.pi * period_s / angle) if angle > 0 else math.inf


#: Ziegler-Nichols ultimate-gain rules: (K_p / K_u, T_i / T_u, T_d / T_u).
ZN_RULES = {"classic": (0.6, 0.5, 0.125), "no_overshoot": (0.2, 0.5, 1.0 / 3.0)}


def ziegler_nichols_pid(axis: ElasticAxisParams, period_s: float = 1e-3,
                        td_scale: float = 1.0, rule: str = "classic"
                        ) -> tuple[float, float, float]:
    """ZN PID ``(K_p, K_i, K_d)`` from :func:`ultimate_gain`.

    ``rule``: ``"classic"`` (``0.6 K_u, T_u/2, T_u/8``; A1-4) or ``"no_overshoot"``
    (``0.2 K_u, T_u/2, T_u/3``).  ``td_scale`` multiplies the derivative time (the paper's
    "increase in the derivative time").  On the [ASSUMED] table the classic gains oscillate
    in the nonlinear loop (current limit, friction), as the paper's rig "oscillated a
    little"; the Nelder-Mead tuning starts from ``"no_overshoot"``.
    """
    if rule not in ZN_RULES:
        raise ValueError(f"rule must be one of {', '.join(ZN_RULES)}, got {rule!r}")
    a, b, c = ZN_RULES[rule]
    ku, tu = ultimate_gain(axis, period_s)
    kp = a * ku
    ti, td = b * tu, td_scale * c * tu
    return kp, kp / ti, kp * td


def _nelder_mead(cost, start: tuple[float, ...], max_evaluations: int) -> tuple:  # noqa: ANN001
    z0 = np.log(np.asarray(start, float))
    simplex = np.vstack([z0] + [z0 + 0.5 * np.eye(len(z0))[i] for i in range(len(z0))])
    count = [0]

    def f(z: np.ndarray) -> float:
        count[0] += 1
        v = cost(np.exp(z))
        return v if math.isfinite(v) else 1e30

    start_cost = f(z0)
    res = minimize(f, z0, method="Nelder-Mead",
                   options={"initial_simplex": simplex, "maxfev": max_evaluations,
                            "xatol": 1e-3, "fatol": 1e-12})
    best = res.x if res.fun <= start_cost else z0
    return np.exp(best), min(float(res.fun), start_cost), start_cost, count[0]


def tune_axis_pid(
    axis: ElasticAxisParams,
    amplitude_mm: float,
    frequency_Hz: float,
    *,
    start: tuple[float, float, float] | None = None,
    periods: float = 1.0,
    plant_step_s: float = 1e-4,
    control_period_s: float = 1e-3,
    limit_V: float = 10.0,
    penalty_mm_s_per_V: float = 1.0,
    max_spectral_radius: float = 0.9999,
    max_evaluations: int = 150,
) -> TuningResult:
    """Nelder-Mead PID of one axis on a sinusoid (A1-3).

    Parameters
    ----------
    axis : ElasticAxisParams
    amplitude_mm, frequency_Hz : float
        ``x_ref = A sin(2 pi f t)`` [mm, Hz].
    start : (kp, ki, kd), optional
        Start gains (default: :func:`ziegler_nichols_pid`, ``"no_overshoot"``).
    periods : float
        Simulated sinusoid periods.
    plant_step_s, control_period_s : float
        [s].
    limit_V : float
        The output constraint [V].
    penalty_mm_s_per_V : float
        Penalty per volt of excess output [mm s/V].
    max_spectral_radius : float
        Gains whose linear sampled loop (:func:`closed_loop_spectral_radius`) exceeds this
        are rejected [ASSUMED 0.9999]: a short sinusoid does not show a slow divergence (the
        lightly damped two-inertia mode is the one a derivative gain destabilises).  An
        unstable start has its derivative gain halved until it is stable.
    max_evaluations : int
        Cap on objective evaluations.

    Returns
    -------
    TuningResult
    """
    if start is None:
        start = ziegler_nichols_pid(axis, control_period_s, rule="no_overshoot")
    for _ in range(20):
        if closed_loop_spectral_radius(axis, *start, control_period_s) <= max_spectral_radius:
            break
        start = (start[0], start[1], start[2] / 2)
    duration = round(periods / frequency_Hz / control_period_s) * control_period_s
    n = round(duration / plant_step_s)
    t = np.arange(n) * plant_step_s
    ref = amplitude_mm * np.sin(2 * math.pi * frequency_Hz * t)

    def cost(g: np.ndarray) -> float:
        if closed_loop_spectral_radius(axis, *g, control_period_s) > max_spectral_radius:
            return math.inf
        pid = AxisPIDParams(p_gain_per_mm=g[0], i_gain_per_mm_s=g[1], d_gain_s_per_mm=g[2])
        r = simulate_axis(axis, pid, reference_samples_mm=ref, duration_s=n * plant_step_s,
                          plant_step_s=plant_step_s, control_period_s=control_period_s,
                          record_every_steps=None, threads=1)
        iae = float(r.metrics["iae_mm_s"][0])
        excess = max(0.0, float(r.metrics["max_abs_command"][0]) - limit_V)
        return iae + penalty_mm_s_per_V * excess

    g, c, c0, evals = _nelder_mead(cost, start, max_evaluations)
    return TuningResult(float(g[0]), float(g[1]), float(g[2]), c, c0, evals)


def tune_cec_pid(
    axis_x: ElasticAxisParams,
    axis_y: ElasticAxisParams,
    pid_x: AxisPIDParams,
    pid_y: AxisPIDParams,
    reference: XYReference,
    cec: CrossCoupledParams,
    *,
    load_x_N: np.ndarray | None = None,
    load_y_N: np.ndarray | None = None,
    start: tuple[float, float, float] = (1.0, 10.0, 0.001),
    plant_step_s: float = 1e-4,
    control_period_s: float = 1e-3,
    max_evaluations: int = 150,
) -> TuningResult:
    """Nelder-Mead gains of the CEC's PID on the test circle, axis gains fixed (A1-3).

    ``cec`` gives the model and options; its gains are replaced.  The objective is the
    IAE of the exact contour error [mm s] (the loop limits each command to +-10 V).
    """

    def cost(g: np.ndarray) -> float:
        c = replace(cec, kp_V_per_mm=float(g[0]), ki_V_per_mm_s=float(g[1]),
                    kd_V_s_per_mm=float(g[2]))
        r = simulate_xy(axis_x, axis_y, pid_x, pid_y, reference, cec=c, load_x_N=load_x_N,
                        load_y_N=load_y_N, plant_step_s=plant_step_s,
                        control_period_s=control_period_s, record_every_steps=None, threads=1)
        return float(r.metrics["iae_contour_mm_s"][0])

    g, c, c0, evals = _nelder_mead(cost, start, max_evaluations)
    return TuningResult(float(g[0]), float(g[1]), float(g[2]), c, c0, evals)


__all__ = ["ZN_RULES", "TuningResult", "closed_loop_spectral_radius", "tune_axis_pid",
           "tune_cec_pid", "ultimate_gain",
           "ziegler_nichols_pid"]
