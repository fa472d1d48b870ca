"""Online estimation of the force-process gain ``K2`` and pole ``p2`` (Eq. 7) in closed loop.

Model.  Between the command ``u`` [mm/min] (held over each control period ``T_c``) and the
sampled force ``f`` [N] the plant of Eq. (8) is, exactly,

.. math:: f[k] - \\phi_a f[k-1] = \\phi_2 (f[k-1] - \\phi_a f[k-2])
          + b_1 u[k-1-N] + b_2 u[k-2-N]

with ``phi_a = exp(-a T_c)`` (the feed drive, known from the nominal model),
``phi_2 = exp(p2 T_c)``, ``N = L / T_c`` whole periods of dead time, and ``b1, b2`` the
zero-order-hold numerator of ``a K2 / ((s + a)(s - p2))``.  Removing the known drive pole
leaves a regression linear in ``theta = (phi_2, b1, b2)``; scaled by the reference force
``r`` and the programmed feed ``F``:

``y[k] = (f[k] - phi_a f[k-1]) / r``,
``h[k] = ((f[k-1] - phi_a f[k-2]) / r, u[k-1-N] / F, u[k-2-N] / F)``,  ``y = h . theta``.

The physical estimates follow as ``p2 = ln(phi_2) / T_c``, static gain
``G = (b1 + b2) (r / F) / ((1 - phi_a)(1 - phi_2))`` and ``K2 = -p2 G``.

Estimators.  ``"rls"``: recursive least squares with exponential forgetting ``lambda``.
``"kalman"``: ``theta`` as a random walk with covariance ``(1 - lambda) P0`` per period,
measured through ``h`` with variance ``sigma^2`` (the equations of filterpy's
``predict``/``update``, Joseph form, compiled; tested equal to filterpy).

Guards (every one keeps the estimate where it is rather than guessing):

* start from the nominal model (Eq. 9), covariance ``P0``;
* update only in the cut: ``f[k], f[k-1], f[k-2] > min_force_fraction r`` (an air cut has
  no information about ``K2`` and would drive ``b`` to zero);
* update only with excitation: an exponentially weighted mean of
  ``((u[k-1-N] - u[k-2-N]) / F)^2`` (the input the regression sees) above a threshold.  A
  feed held at a clamp, or a settled loop, carries no new information; a settled loop with
  sensor noise carries mostly noise, which biases an equation-error estimate, so the
  threshold sits above the noise the PI passes to the command;
* a prediction error above ``reset_error_fraction`` (an abrupt change: a depth step) resets
  the covariance to ``P0`` and skips the two samples whose regressor straddles the step;
* the covariance trace is bounded by ``COVARIANCE_TRACE_FACTOR tr(P0)``;
* the estimate is projected so that ``|p2|`` and ``G`` stay within a factor
  ``parameter_ratio_max`` of the nominal values.

The bias of the regression comes only from what the model leaves out: sensor noise (an
equation-error estimate is biased by noise on ``f[k-1]``), a sensor low-pass, and dead-time
mismatch.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, per_run, record, register_element, ring_size

ESTIMATOR_KINDS = ("rls", "kalman")

#: Bound on the covariance trace, in multiples of the initial trace [-].
COVARIANCE_TRACE_FACTOR = 10.0
#: Prior standard deviation of ``phi_2`` [-] (about 2 rad/s of pole at T_c = 0.01 s).
PHI2_PRIOR_STD = 0.02
#: Prior standard deviation of ``b1, b2``, as a fraction of their nominal values [-].
B_PRIOR_FRACTION = 0.5
#: Weight of the newest sample in the excitation measure [-] (about a 10-period window).
EXCITATION_WEIGHT = 0.1
#: Samples skipped after a covariance reset: the regressor straddles the change.
SKIP_AFTER_RESET = 2


@dataclass(frozen=True)
class EstimatorOptions:
    """Settings of the process-gain estimator: the ``estimator_*`` keys of ``[controller]``
    (the adaptive kinds' option group).

    Attributes
    ----------
    estimator : {"rls", "kalman"}
        Recursive least squares with forgetting, or a random-walk Kalman filter.
    estimator_forgetting : float
        RLS forgetting factor ``lambda`` per control period, in (0, 1]; the Kalman filter's
        random walk is ``(1 - lambda) P0`` per period.
    estimator_measurement_std_fraction : float
        Measurement standard deviation of ``y`` [fraction of the reference], > 0.
    estimator_min_force_fraction : float
        No update unless the last three forces exceed this fraction of the reference [-].
    estimator_excitation_threshold : float
        No update unless the excitation measure exceeds this [-], >= 0.
    estimator_reset_error_fraction : float
        Prediction error that resets the covariance [fraction of the reference], > 0.
    estimator_parameter_ratio_max : float
        ``|p2|`` and the static gain are kept within this factor of nominal [-], > 1.
    """

    estimator: str = "rls"
    estimator_forgetting: float = 0.98
    estimator_measurement_std_fraction: float = 0.002
    estimator_min_force_fraction: float = 0.1
    estimator_excitation_threshold: float = 1e-3
    estimator_reset_error_fraction: float = 0.05
    estimator_parameter_ratio_max: float = 5.0

    def __post_init__(self) -> None:
        if self.estimator not in ESTIMATOR_KINDS:
            raise ValueError(f"estimator must be one of {ESTIMATOR_KINDS}, got {self.estimator!r}")
        if not 0 < self.estimator_forgetting <= 1:
            raise ValueError(
                f"estimator_forgetting must be in (0, 1], got {self.estimator_forgetting}"
            )
        if not self.estimator_measurement_std_fraction > 0:
            raise ValueError("estimator_measurement_std_fraction must be > 0")
        if not self.estimator_min_force_fraction >= 0:
            raise ValueError("estimator_min_force_fraction must be >= 0")
        if not self.estimator_excitation_threshold >= 0:
            raise ValueError("estimator_excitation_threshold must be >= 0")
        if not self.estimator_reset_error_fraction > 0:
            raise ValueError("estimator_reset_error_fraction must be > 0")
        if not self.estimator_parameter_ratio_max > 1:
            raise ValueError("estimator_parameter_ratio_max must be > 1")


@functools.lru_cache(maxsize=4096)
def zoh_numerator(
    bandwidth_rad_s: float, k2_N_min_per_mm_s: float, p2_rad_s: float, control_period_s: float
) -> tuple[float, float]:
    """``b1, b2`` of the zero-order-hold discretisation of ``a K2 / ((s + a)(s - p2))``.

    ``scipy.signal.cont2discrete`` of the transfer function (what python-control's ``c2d``
    calls), normalised to a monic denominator.
    """
    from scipy.signal import cont2discrete

    a = bandwidth_rad_s
    num, den, _ = cont2discrete(
        ([a * k2_N_min_per_mm_s], np.polymul([1.0, a], [1.0, -p2_rad_s])),
        control_period_s,
        method="zoh",
    )
    num = np.atleast_1d(np.squeeze(num))
    den = np.atleast_1d(np.squeeze(den))
    num = num / den[0]
    num = np.r_[np.zeros(max(0, 2 - len(num))), num][-2:]
    return float(num[0]), float(num[1])


METHOD_CODES = {"rls": 0, "kalman": 1}


def _dtypes(ring: int = 16) -> tuple[np.dtype, np.dtype]:
    params = record(
        "estimator.process_gain",
        [
            ("method", "i8"),  # METHOD_CODES
            ("phi_a", "f8"),  # exp(-a Tc), the known drive pole
            ("reference_force_N", "f8"),
            ("programmed_feed_mm_min", "f8"),
            ("control_period_s", "f8"),
            ("min_force_fraction", "f8"),
            ("excitation_threshold", "f8"),
            ("reset_error_fraction", "f8"),
            ("forgetting", "f8"),
            ("variance", "f8"),  # measurement_std_fraction ** 2
            ("trace_max", "f8"),
            ("phi2_min", "f8"),
            ("phi2_max", "f8"),
            ("static_gain_min_N_per_mm_min", "f8"),
            ("static_gain_max_N_per_mm_min", "f8"),
            ("delay_periods", "i8"),
            ("ring_mask", "i8"),
            ("theta0", "f8", (3,)),
            ("covariance0", "f8", (3, 3)),
        ],
    )
    state = record(
        "estimator.process_gain",
        [
            ("theta", "f8", (3,)),
            ("covariance", "f8", (3, 3)),
            ("force1_N", "f8"),  # f[k-1]
            ("force2_N", "f8"),  # f[k-2]
            ("excitation", "f8"),
            ("skip", "i8"),
            ("updated", "i8"),
            ("head", "i8"),
            ("history_mm_min", "f8", (ring,)),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """Nominal estimate, covariance ``P0``, at rest."""
    for i in range(3):
        s.theta[i] = p.theta0[i]
        for j in range(3):
            s.covariance[i, j] = p.covariance0[i, j]
    s.force1_N = 0.0
    s.force2_N = 0.0
    s.excitation = 0.0
    s.skip = 0
    s.updated = 0
    s.head = 0
    for i in range(s.history_mm_min.shape[0]):
        s.history_mm_min[i] = 0.0


@jit
def _clip(x: float, lo: float, hi: float) -> float:
    """``numpy.clip`` of one value (NaN stays NaN)."""
    if x < lo:
        return lo
    if x > hi:
        return hi
    return x


@jit
def _sym(P: np.ndarray, i: int, j: int, kv: tuple, phv: tuple, lam: float) -> float:
    """Entry ``(i, j)`` of ``(Q + Q^T) / 2`` with ``Q = (P - K (P h)^T) / lambda``."""
    qij = (P[i, j] - kv[i] * phv[j]) / lam
    qji = (P[j, i] - kv[j] * phv[i]) / lam
    return 0.5 * (qij + qji)


@jit
def _rls(p, s, h0: float, h1: float, h2: float, y: float) -> tuple:  # noqa: ANN001
    """One RLS step with forgetting; the covariance is written (symmetrised) to ``s``.

    With ``variance = 1`` this is the textbook RLS; the scaling makes ``P0`` a prior
    covariance comparable with the Kalman variant.
    """
    lam = p.forgetting
    P = s.covariance
    ph0 = P[0, 0] * h0 + P[0, 1] * h1 + P[0, 2] * h2
    ph1 = P[1, 0] * h0 + P[1, 1] * h1 + P[1, 2] * h2
    ph2 = P[2, 0] * h0 + P[2, 1] * h1 + P[2, 2] * h2
    denom = lam * p.variance + (h0 * ph0 + h1 * ph1 + h2 * ph2)
    kv = (ph0 / denom, ph1 / denom, ph2 / denom)
    phv = (ph0, ph1, ph2)
    t0, t1, t2 = s.theta[0], s.theta[1], s.theta[2]
    e = y - (h0 * t0 + h1 * t1 + h2 * t2)
    q00 = _sym(P, 0, 0, kv, phv, lam)
    q01 = _sym(P, 0, 1, kv, phv, lam)
    q02 = _sym(P, 0, 2, kv, phv, lam)
    q11 = _sym(P, 1, 1, kv, phv, lam)
    q12 = _sym(P, 1, 2, kv, phv, lam)
    q22 = _sym(P, 2, 2, kv, phv, lam)
    P[0, 0] = q00
    P[0, 1] = q01
    P[0, 2] = q02
    P[1, 0] = q01
    P[1, 1] = q11
    P[1, 2] = q12
    P[2, 0] = q02
    P[2, 1] = q12
    P[2, 2] = q22
    return t0 + kv[0] * e, t1 + kv[1] * e, t2 + kv[2] * e


@jit
def _kalman(p, s, h0: float, h1: float, h2: float, y: float) -> tuple:  # noqa: ANN001
    """Random-walk Kalman step: filterpy's ``predict`` (F = I, Q = (1 - lambda) P0) and
    ``update`` (Joseph form), then symmetrised; the covariance is written to ``s``."""
    P = s.covariance
    q = 1.0 - p.forgetting
    for i in range(3):
        for j in range(3):
            P[i, j] = P[i, j] + q * p.covariance0[i, j]
    h = (h0, h1, h2)
    t = (s.theta[0], s.theta[1], s.theta[2])
    pht = np.empty(3)
    for i in range(3):
        pht[i] = P[i, 0] * h0 + P[i, 1] * h1 + P[i, 2] * h2
    S = h0 * pht[0] + h1 * pht[1] + h2 * pht[2] + p.variance
    inv = 1.0 / S
    K = np.empty(3)
    for i in range(3):
        K[i] = pht[i] * inv
    e = y - (h0 * t[0] + h1 * t[1] + h2 * t[2])
    ikh = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            ikh[i, j] = (1.0 if i == j else 0.0) - K[i] * h[j]
    tmp = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            tmp[i, j] = ikh[i, 0] * P[0, j] + ikh[i, 1] * P[1, j] + ikh[i, 2] * P[2, j]
    new = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            new[i, j] = (
                tmp[i, 0] * ikh[j, 0] + tmp[i, 1] * ikh[j, 1] + tmp[i, 2] * ikh[j, 2]
                + K[i] * p.variance * K[j]
            )
    for i in range(3):
        for j in range(3):
            P[i, j] = 0.5 * (new[i, j] + new[j, i])
    return t[0] + K[0] * e, t[1] + K[1] * e, t[2] + K[2] * e


@jit
def project(p, s, th0: float, th1: float, th2: float) -> tuple[float, float, float]:  # noqa: ANN001
    """``theta`` moved into the bounds: ``|p2|`` and the static gain within the factor
    ``parameter_ratio_max`` of nominal (the numerator keeps its shape; the nominal shape if
    degenerate)."""
    r = p.reference_force_N
    F = p.programmed_feed_mm_min
    th0 = _clip(th0, p.phi2_min, p.phi2_max)
    bsum = th1 + th2
    to_gain = (r / F) / ((1.0 - p.phi_a) * (1.0 - th0))
    g = bsum * to_gain
    g_clip = _clip(g, p.static_gain_min_N_per_mm_min, p.static_gain_max_N_per_mm_min)
    if not (g == g_clip):
        nom_sum = p.theta0[1] + p.theta0[2]
        den = bsum if bsum > 0 else 1.0
        sh1 = th1 / den if (bsum > 0 and th1 >= 0) else p.theta0[1] / nom_sum
        sh2 = th2 / den if (bsum > 0 and th2 >= 0) else p.theta0[2] / nom_sum
        target = g_clip / to_gain
        th1 = sh1 * target
        th2 = sh2 * target
    return th0, th1, th2


@jit
def step(p, s, force_N: float) -> int:  # noqa: ANN001
    """Absorb the measured force ``f[k]`` [N] (commands up to ``k - 1`` are recorded).

    Returns 1 if the estimate was updated (all guards passed), else 0.
    """
    r = p.reference_force_N
    F = p.programmed_feed_mm_min
    phi_a = p.phi_a
    f1 = s.force1_N
    f2 = s.force2_N
    mask = p.ring_mask
    # newest command u[k-1] sits at head - 1
    u1 = s.history_mm_min[(s.head - 1 - p.delay_periods) & mask]
    u2 = s.history_mm_min[(s.head - 2 - p.delay_periods) & mask]
    y = (force_N - phi_a * f1) / r
    h0 = (f1 - phi_a * f2) / r
    h1 = u1 / F
    h2 = u2 / F
    w = EXCITATION_WEIGHT
    du = (u1 - u2) / F
    excitation = (1 - w) * s.excitation + w * (du * du)
    fmin = p.min_force_fraction * r
    in_cut = (force_N > fmin) and (f1 > fmin) and (f2 > fmin)
    err = y - (h0 * s.theta[0] + h1 * s.theta[1] + h2 * s.theta[2])
    reset = in_cut and (abs(err) > p.reset_error_fraction)
    old_skip = s.skip
    s.skip = SKIP_AFTER_RESET if reset else max(old_skip - 1, 0)
    gate = in_cut and (excitation > p.excitation_threshold) and (not reset) and old_skip == 0
    if reset:
        for i in range(3):
            for j in range(3):
                s.covariance[i, j] = p.covariance0[i, j]
    if gate:
        if p.method == 0:
            th0, th1, th2 = _rls(p, s, h0, h1, h2, y)
        else:
            th0, th1, th2 = _kalman(p, s, h0, h1, h2, y)
        P = s.covariance
        tr = P[0, 0] + P[1, 1] + P[2, 2]
        scale = min(1.0, p.trace_max / tr)
        for i in range(3):
            for j in range(3):
                P[i, j] = P[i, j] * scale
        th0, th1, th2 = project(p, s, th0, th1, th2)
        s.theta[0] = th0
        s.theta[1] = th1
        s.theta[2] = th2
    s.force2_N = f1
    s.force1_N = force_N
    s.excitation = excitation
    s.updated = 1 if gate else 0
    return s.updated


@jit
def estimates(p, s) -> tuple[float, float]:  # noqa: ANN001
    """Current ``K2`` [N/(mm/min)/s] and ``p2`` [rad/s]."""
    phi2 = s.theta[0]
    p2 = math.log(phi2) / p.control_period_s
    g = (
        (s.theta[1] + s.theta[2])
        * (p.reference_force_N / p.programmed_feed_mm_min)
        / ((1.0 - p.phi_a) * (1.0 - phi2))
    )
    return g * (-p2), p2


@jit
def record_command(p, s, command_mm_min: float) -> None:  # noqa: ANN001
    """Store the command ``u[k]`` sent from this instant [mm/min]."""
    s.history_mm_min[s.head] = command_mm_min
    s.head = (s.head + 1) & p.ring_mask


PROCESS_GAIN = register_element(
    "estimator.process_gain",
    _dtypes,
    init,
    step,
    "online K2, p2 estimation (RLS or Kalman) with in-cut, excitation, reset, projection guards",
)


def estimator_records(
    params: EstimatorOptions | Sequence[EstimatorOptions],
    bandwidth_rad_s: ArrayLike,
    k2_N_min_per_mm_s: ArrayLike,
    p2_rad_s: ArrayLike,
    delay_periods: ArrayLike,
    reference_force_N: ArrayLike,
    programmed_feed_mm_min: ArrayLike,
    control_period_s: float,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of estimators (module docstring).

    Parameters
    ----------
    params : EstimatorOptions or sequence of them, length runs
        Settings, shared or per run.
    bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s : array_like, shape (runs,) or scalar
        Nominal model (Eq. 9): drive bandwidth, start values and projection centre.
    delay_periods : array_like of int, shape (runs,) or scalar
        Dead time in whole control periods ``N``.
    reference_force_N, programmed_feed_mm_min : array_like, shape (runs,) or scalar
        Scales ``r`` [N] and ``F`` [mm/min] of the regression.
    control_period_s : float
        ``T_c`` [s].

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs, (a, k2n, p2n, r, F, delays) = per_run(
        bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s, reference_force_N, programmed_feed_mm_min,
        delay_periods,
    )
    delays = delays.astype(np.int64)
    if np.any(p2n >= 0) or np.any(k2n <= 0):
        raise ValueError("nominal model needs K2 > 0 and p2 < 0")
    Tc = float(control_period_s)
    out, state = PROCESS_GAIN.records(runs, ring=ring_size(int(delays.max(initial=0)) + 2))
    settings = [params] * runs if isinstance(params, EstimatorOptions) else list(params)

    def each(name: str) -> NDArray:
        return np.array([getattr(x, name) for x in settings], dtype=float)

    out["method"] = [METHOD_CODES[x.estimator] for x in settings]
    out["phi_a"] = np.exp(-a * Tc)
    out["reference_force_N"] = r
    out["programmed_feed_mm_min"] = F
    out["control_period_s"] = Tc
    out["min_force_fraction"] = each("estimator_min_force_fraction")
    out["excitation_threshold"] = each("estimator_excitation_threshold")
    out["reset_error_fraction"] = each("estimator_reset_error_fraction")
    out["forgetting"] = each("estimator_forgetting")
    out["variance"] = each("estimator_measurement_std_fraction") ** 2
    b = np.array(
        [
            zoh_numerator(float(x), float(y), float(z), Tc)
            for x, y, z in zip(a, k2n, p2n, strict=True)
        ]
    )
    theta0 = np.column_stack([np.exp(p2n * Tc), b * (F / r)[:, None]])
    P0 = np.zeros((runs, 3, 3))
    P0[:, 0, 0] = PHI2_PRIOR_STD**2
    P0[:, 1, 1] = (B_PRIOR_FRACTION * theta0[:, 1]) ** 2
    P0[:, 2, 2] = (B_PRIOR_FRACTION * theta0[:, 2]) ** 2
    out["theta0"] = theta0
    out["covariance0"] = P0
    out["trace_max"] = COVARIANCE_TRACE_FACTOR * np.trace(P0, axis1=1, axis2=2)
    rmax = each("estimator_parameter_ratio_max")
    out["phi2_min"] = np.exp(p2n * rmax * Tc)
    out["phi2_max"] = np.exp(p2n / rmax * Tc)
    g_nom = k2n / (-p2n)
    out["static_gain_min_N_per_mm_min"] = g_nom / rmax
    out["static_gain_max_N_per_mm_min"] = g_nom * rmax
    out["delay_periods"] = delays
    out["ring_mask"] = state.dtype["history_mm_min"].shape[0] - 1
    return out, init_states(out, state)


__all__ = [
    "ESTIMATOR_KINDS",
    "EstimatorOptions",
    "PROCESS_GAIN",
        "estimates",
    "estimator_records",
    "project",
    "record_command",
    "zoh_numerator",
]
