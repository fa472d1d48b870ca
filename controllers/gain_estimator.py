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
``"output_error"``: the output-error (maximum-likelihood for white sensor noise) fit of
``(G, p2)`` over a grid of poles, below; it is the one method free of the noise bias.

Guards (every one keeps the estimate where it is rather than guessing):

* start from the stiffest plant of the declared design set (``estimator_start =
  "stiffest"``, the default: the largest static gain of ``[design] gain_ratio_range`` with
  the nominal pole, so that the gains the adaptive rule derives from it are those of a fixed
  design for that plant) or from the nominal model (Eq. 9), covariance ``P0``;
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
* the estimate is projected so that ``G`` stays in the design set's gain range and ``p2`` in
  its pole range (by default the nominal pole scaled by ``parameter_ratio_max`` either way).

The bias of the regression comes only from what the model leaves out: sensor noise (an
equation-error estimate is biased by noise on ``f[k-1]``), a sensor low-pass, and dead-time
mismatch.

Output error (``"output_error"``).  The equation-error regression above puts the noisy
``f[k-1]`` among the regressors; at the shipped 5 N this biases ``rls`` and ``kalman`` to
their projection bounds unless the sensor filter is on.  The output-error method never
regresses on a measured force.  It runs the process model of :mod:`plants.force_process`
(chip load ``x`` with ``dx/dt = p (x - v)``, force ``G x``) for ``M`` =
:data:`POLE_GRID_POINTS` candidate poles ``p_i``, log-spaced over the projection range
``[p2_nom r_max, p2_nom / r_max]``, driven by the drive velocity ``v`` that the known drive
model (Eq. 6: ``a``, ``N``) gives from the recorded commands.  The sensor's first-order
low-pass (cut-off ``estimator_sensor_cutoff_hz``; 0: none) is part of each candidate:
``z_i`` is its chip load seen through the filter.  Each candidate is discretised exactly
(matrix exponential of ``(v, x, z, u)`` over ``T_c``, the command held), once per run.
For every candidate the gain is linear and has a closed form; with weighted sums since the
last reset,

``G_i = S_yz,i / S_zz,i``,  ``J_i = S_yy - S_yz,i^2 / S_zz,i`` (the residual sum of squares),

and the estimate is the minimum of the profile ``J(ln|p|)``: the grid point ``c`` of least
``J``, refined by the cubic through the four grid points around the minimum (``c`` and the
lower of its neighbours in the middle; spacing ``h``), whose local minimum is kept within
one step of ``c``.  The cubic's curvature there, ``J''`` in grid steps, gives the standard
error of ``ln|p2|``, ``sqrt(2 s^2 h^2 / J'')`` with ``s^2 = J_min / (n - 2)``; ``p2`` moves
only when it is below ``estimator_pole_std_max`` (an information guard: a settled loop says
almost nothing about ``p2``, and its estimate then stays where the last transient put it).
``G`` is the candidates' ``G_i`` interpolated at ``p2`` by the cubic through the four grid
points around it.  Measured on closed-loop data (the stepped part, 5 N, 20 Hz), the refined
minimum of 24 candidates is within 1e-3 of ``ln|p2|`` of the minimum over a 1001-point grid
(the parabola on 48 candidates, the previous method, within 2e-3), far inside the
statistical error the guard admits (0.05); ``tests/test_output_error_estimator.py``
checks it against such a brute-force profile.  This is the prediction-error criterion of an
output-error model (Ljung, *System Identification*, 2nd ed., sec. 4.2, 7.3), minimised
globally over ``p2``; it is consistent in closed loop here because the measurement noise at
``k`` cannot have reached the commands ``u[j <= k-1-N]`` the model sees (white noise, or the
20 Hz low-pass whose correlation over ``N + 1`` periods is ``exp(-w_c (N+1) T_c) ~ 1e-6``).

Guards of the output-error method:

* in the cut as above; the candidates run in and out of it (a low force may be a low feed
  in the cut, not air; after an air approach at a steady feed every chip load equals it);
* entering the cut, or an *onset* of a prediction error above ``reset_error_fraction``
  (the best candidate's one-step error; a depth step changes the force at once, by 12-22 %
  between Table 1 rows), restarts the sums: the fit after a step uses post-step data only.
  The chip loads carry on (the chip load is continuous across a depth change).  With the
  sensor filter modelled, the samples within which the filter still holds the pre-step
  force (``exp(-w_c j T_c) > 1e-3``) are skipped;
* the sums forget with ``lambda`` only in periods whose excitation measure exceeds
  ``excitation_threshold``: a settled loop brings no new information on ``p2``, so the
  last transient's is kept;
* ``p2`` stays on the grid (the projection range) and ``G`` in the design set's range.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import delay_size, init_states, jit, per_run, record, register_element
from controllers.discretisation import hold_discretisation
from plants.design_set import DesignSet

ESTIMATOR_KINDS = ("rls", "kalman", "output_error")
#: Where the estimate starts (:class:`EstimatorOptions`).
ESTIMATOR_STARTS = ("stiffest", "nominal")

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
#: Candidate poles of the output-error method (log-spaced over the projection range; the
#: minimum of the profile between them is found by cubic interpolation, module docstring).
POLE_GRID_POINTS = 24
#: Part of a pre-step force the sensor filter may still hold when the output-error fit
#: restarts [-] (sets the samples skipped after a reset).
FILTER_SETTLED = 1e-3


@dataclass(frozen=True)
class EstimatorOptions:
    """Settings of the process-gain estimator: the ``estimator_*`` keys of ``[controller]``
    (the adaptive kinds' option group).

    Attributes
    ----------
    estimator : {"rls", "kalman", "output_error"}
        Recursive least squares with forgetting, a random-walk Kalman filter (both on the
        equation-error regression), or the output-error fit over a grid of poles (free of
        the noise bias; module docstring).
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
    estimator_sensor_cutoff_hz : float
        Cut-off of the force sensor's first-order low-pass [Hz] as the estimator models it
        (set it to ``sensor.lowpass_cutoff_hz``); 0: no filter, >= 0.  Used by
        ``"output_error"``; ``"rls"`` and ``"kalman"`` have no filter in their model.
    estimator_pole_std_max : float
        ``"output_error"``: ``p2`` moves only when the standard error of ``ln|p2|`` (from the
        curvature of the fit) is below this [-], > 0.
    estimator_start : {"stiffest", "nominal"}
        Where the estimate starts: at the stiffest plant of the scenario's ``[design]`` set
        (its largest static gain, the nominal pole: the PI then starts as cautious as a
        fixed design for that plant; the default), or at the nominal model (Eq. 9).
    """

    estimator: str = "output_error"
    estimator_forgetting: float = 0.98
    estimator_measurement_std_fraction: float = 0.002
    estimator_min_force_fraction: float = 0.02
    estimator_excitation_threshold: float = 1e-3
    estimator_reset_error_fraction: float = 0.05
    estimator_parameter_ratio_max: float = 5.0
    estimator_sensor_cutoff_hz: float = 0.0
    estimator_pole_std_max: float = 0.05
    estimator_start: str = "stiffest"

    def __post_init__(self) -> None:
        if self.estimator_start not in ESTIMATOR_STARTS:
            raise ValueError(
                f"estimator_start must be one of {ESTIMATOR_STARTS}, got {self.estimator_start!r}"
            )
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
        if not (math.isfinite(self.estimator_sensor_cutoff_hz)
                and self.estimator_sensor_cutoff_hz >= 0):
            raise ValueError("estimator_sensor_cutoff_hz must be finite and >= 0")
        if not self.estimator_pole_std_max > 0:
            raise ValueError("estimator_pole_std_max must be > 0")


@functools.lru_cache(maxsize=4096)
def zoh_numerator(
    bandwidth_rad_s: float, k2_N_min_per_mm_s: float, p2_rad_s: float, control_period_s: float
) -> tuple[float, float]:
    """``b1, b2`` of the zero-order-hold discretisation of ``a K2 / ((s + a)(s - p2))``.

    The realisation ``v' = -a v + a u``, ``f' = p2 f + K2 v`` is discretised exactly
    (:func:`controllers.discretisation.hold_discretisation`, zero-order hold: ``Phi``,
    ``Gamma``) and written as a transfer function with a monic denominator: with
    ``C = (0, 1)``, ``C adj(z I - Phi) Gamma = b1 z + b2``, ``b1 = Gamma_f``,
    ``b2 = Phi_fv Gamma_v - Phi_vv Gamma_f``.  Equal to ``scipy.signal.cont2discrete`` of the
    transfer function to rounding (tested).
    """
    a = bandwidth_rad_s
    A = np.array([[-a, 0.0], [k2_N_min_per_mm_s, p2_rad_s]])
    B = np.array([[a], [0.0]])
    phi, gamma, _, _ = hold_discretisation(
        (A, B, np.array([[0.0, 1.0]]), np.zeros((1, 1))), control_period_s, "zoh")
    b1 = gamma[1, 0]
    b2 = phi[1, 0] * gamma[0, 0] - phi[0, 0] * gamma[1, 0]
    return float(b1), float(b2)


@functools.lru_cache(maxsize=256)
def candidate_models(
    bandwidth_rad_s: float,
    pole_rad_s: tuple[float, ...],
    cutoff_hz: float,
    control_period_s: float,
) -> NDArray[np.float64]:
    """Exact one-period updates of the output-error method's candidate models.

    For each pole ``p`` the states are the drive velocity ``v``, the chip load ``x``
    (``dx/dt = p (x - v)``) and the filtered chip load ``z`` (``dz/dt = w_c (x - z)``), driven
    by the delayed command ``u`` held over the period: the rows of ``expm(A T_c)`` for ``x``
    and ``z`` of the augmented system ``(v, x, z, u)``.  Without a filter ``z`` is ``x``.

    Parameters
    ----------
    bandwidth_rad_s : float
        Drive bandwidth ``a`` [rad/s].
    pole_rad_s : tuple of float, length M
        Candidate poles [rad/s], < 0.
    cutoff_hz : float
        Sensor low-pass cut-off [Hz]; 0: none.
    control_period_s : float
        ``T_c`` [s].

    Returns
    -------
    ndarray, shape (M, 2, 4)
        ``[i, 0]``: ``x[k+1] = c . (v, x, z, u)[k]``; ``[i, 1]``: the same for ``z[k+1]``.
    """
    from scipy.linalg import expm

    a = bandwidth_rad_s
    wc = 2.0 * math.pi * cutoff_hz
    out = np.empty((len(pole_rad_s), 2, 4))
    for i, pole in enumerate(pole_rad_s):
        A = np.zeros((4, 4))
        A[0, 0], A[0, 3] = -a, a
        A[1, 0], A[1, 1] = -pole, pole
        A[2, 1], A[2, 2] = wc, -wc
        E = expm(A * control_period_s)
        out[i, 0] = E[1]
        out[i, 1] = E[2] if wc > 0 else E[1]
    out.flags.writeable = False
    return out


METHOD_CODES = {"rls": 0, "kalman": 1, "output_error": 2}


def _dtypes(ring: int = 16, poles: int = POLE_GRID_POINTS) -> tuple[np.dtype, np.dtype]:
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
            # output error: candidate poles, log-spaced; ln|p| of the first; spacing in ln|p|
            ("pole_grid_rad_s", "f8", (poles,)),
            ("log_pole0", "f8"),
            ("log_pole_step", "f8"),
            # candidate_models, one row per coefficient, candidates contiguous (the loops
            # over candidates vectorise): x <- (v, x, u) in rows 0-2; z <- (v, x, z, u) in
            # rows 3-6 (without the filter z is x, rows 3-6 unused)
            ("candidate_coefficients", "f8", (7, poles)),
            ("filtered", "b1"),  # the sensor's low-pass is modelled (cut-off > 0)
            ("pole_std_max", "f8"),
            ("skip_after_reset", "i8"),
            ("safe_start", "b1"),  # started at the stiffest plant of the design set
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
            # output error
            ("velocity_mm_min", "f8"),  # drive model's v
            ("chip_load", "f8", (poles,)),  # x_i [mm/min]
            ("filtered_chip_load", "f8", (poles,)),  # z_i [mm/min]
            ("sum_zz", "f8", (poles,)),  # weighted sums since the last reset, scaled (z/F)
            ("sum_yz", "f8", (poles,)),
            ("sum_yy", "f8"),
            ("profile", "f8", (poles,)),  # J_i of the last fit (inf: no chip load yet)
            ("candidate_gain", "f8", (poles,)),  # G_i = S_yz,i / S_zz,i, scaled (r / F)
            ("samples", "f8"),  # weighted number of samples in the sums
            ("best", "i8"),  # candidate of least J (-1: none since the reset)
            ("best_gain", "f8"),  # its G_i, scaled (r / F)
            ("p2_rad_s", "f8"),  # the estimate
            ("static_gain_N_per_mm_min", "f8"),
            ("pole_log_std", "f8"),  # standard error of ln|p2| at the last fit (inf: none)
            ("pole_grid_position", "f8"),  # p2 on the grid: ln|p2| = log_pole0 + this * step
            ("was_in_cut", "i8"),
            ("was_large_error", "i8"),
        ],
    )
    return params, state


@jit
def _clear_sums(s) -> None:  # noqa: ANN001
    """Restart the output-error fit (no samples)."""
    for i in range(s.sum_zz.shape[0]):
        s.sum_zz[i] = 0.0
        s.sum_yz[i] = 0.0
        s.profile[i] = np.inf
        s.candidate_gain[i] = np.nan
    s.sum_yy = 0.0
    s.samples = 0.0
    s.best = -1
    s.best_gain = 0.0
    s.pole_log_std = np.inf


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
    s.velocity_mm_min = 0.0
    for i in range(s.chip_load.shape[0]):
        s.chip_load[i] = 0.0
        s.filtered_chip_load[i] = 0.0
    _clear_sums(s)
    g, p2 = _physical(p, p.theta0[0], p.theta0[1], p.theta0[2])
    s.p2_rad_s = p2
    s.static_gain_N_per_mm_min = g
    s.pole_grid_position = (math.log(-p2) - p.log_pole0) / p.log_pole_step
    s.was_in_cut = 0
    s.was_large_error = 0


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


# The output-error loops run over the candidates with the arrays held in locals and no
# branch inside, with numpy's error model (a division by zero gives inf or NaN instead of
# raising) and multiply-adds fused, so that the compiler vectorises them: they are most of
# the estimator's cost.
_VECTOR: dict[str, Any] = {"error_model": "numpy", "fastmath": {"contract"}}


@jit(**_VECTOR)
def _output_error_propagate(p, s, delayed_mm_min: float) -> None:  # noqa: ANN001
    """Advance the drive model and every candidate by one period under the command
    ``u[k-1-N]`` [mm/min]."""
    v = s.velocity_mm_min
    u = delayed_mm_min
    c = p.candidate_coefficients
    x = s.chip_load
    z = s.filtered_chip_load
    m = x.shape[0]
    if p.filtered:
        for i in range(m):
            xi = x[i]
            z[i] = c[3, i] * v + c[4, i] * xi + c[5, i] * z[i] + c[6, i] * u
            x[i] = c[0, i] * v + c[1, i] * xi + c[2, i] * u
    else:  # z is x
        for i in range(m):
            zi = c[0, i] * v + c[1, i] * z[i] + c[2, i] * u
            z[i] = zi
            x[i] = zi
    phi = p.phi_a
    v = phi * v + (1.0 - phi) * delayed_mm_min
    s.velocity_mm_min = v


@jit
def _least(x) -> int:  # noqa: ANN001
    """Index of the first least element of ``x`` (no NaN; inf never the least), -1 if all are
    inf: the index one sequential scan with a strict ``<`` finds."""
    least = np.inf
    for i in range(x.shape[0]):
        least = min(least, x[i])
    if not least < np.inf:
        return -1
    for i in range(x.shape[0]):
        if x[i] == least:
            return i
    return -1


@jit(error_model="numpy")
def _cubic(j0: float, j1: float, j2: float, j3: float) -> tuple[float, float, float, float]:
    """Power coefficients ``a0 + a1 t + a2 t^2 + a3 t^3`` of the cubic through
    ``(0, j0), (1, j1), (2, j2), (3, j3)`` (Newton's forward differences)."""
    d1 = j1 - j0
    d2 = j2 - 2.0 * j1 + j0
    d3 = j3 - 3.0 * j2 + 3.0 * j1 - j0
    return j0, d1 - 0.5 * d2 + d3 / 3.0, 0.5 * d2 - 0.5 * d3, d3 / 6.0


@jit(error_model="numpy")
def _refine_pole(p, s, best: int) -> None:  # noqa: ANN001
    """Move ``p2`` to the minimum of the cubic through the profile around the grid point
    ``best`` if its standard error passes the guard; set ``pole_log_std`` (module
    docstring)."""
    J = s.profile
    m = J.shape[0]
    c = min(max(best, 1), m - 2)
    lower = c - 1 if J[c - 1] < J[c + 1] else c  # the minimum lies in [lower, lower + 1]
    k = min(max(lower - 1, 0), m - 4)  # the cubic's grid points k ... k + 3
    a0, a1, a2, a3 = _cubic(J[k], J[k + 1], J[k + 2], J[k + 3])
    disc = a2 * a2 - 3.0 * a3 * a1
    s.pole_log_std = np.inf
    if not (disc > 0.0 and s.samples > 3.0):
        return  # no local minimum
    root = math.sqrt(disc)
    # the root of J' where J'' = 2 root > 0, in the form without cancellation
    t = -a1 / (a2 + root) if a2 >= 0.0 else (root - a2) / (3.0 * a3)
    t = _clip(t, c - 1.0 - k, c + 1.0 - k)
    curvature = 6.0 * a3 * t + 2.0 * a2  # J'' [per grid step^2]
    if not curvature > 0.0:
        return
    j_min = max(a0 + t * (a1 + t * (a2 + t * a3)), 0.0)
    h = p.log_pole_step
    spread = 2.0 * j_min * h * h  # the variance times (n - 2) J''
    weight = (s.samples - 2.0) * curvature
    s.pole_log_std = math.sqrt(spread / weight)
    if spread < p.pole_std_max * p.pole_std_max * weight:  # the standard error below the bound
        s.pole_grid_position = k + t
        s.p2_rad_s = -math.exp(p.log_pole0 + (k + t) * h)


@jit(error_model="numpy")
def _gain_at(s, position: float) -> float:  # noqa: ANN001
    """The candidates' ``G_i = S_yz,i / S_zz,i`` interpolated at a grid position by the
    cubic through the four grid points around it (clamped to the grid)."""
    g = s.candidate_gain
    m = g.shape[0]
    t = _clip(position, 0.0, m - 1.0)
    i0 = min(max(int(t), 0), m - 2)  # t >= 0: the floor
    k = min(max(i0 - 1, 0), m - 4)
    u = t - k
    g0 = g[k]
    g1 = g[k + 1]
    g2 = g[k + 2]
    g3 = g[k + 3]
    u1 = u - 1.0
    u2 = u - 2.0
    u3 = u - 3.0
    return (
        -g0 * u1 * u2 * u3 / 6.0
        + g1 * u * u2 * u3 / 2.0
        - g2 * u * u1 * u3 / 2.0
        + g3 * u * u1 * u2 / 6.0
    )


@jit(**_VECTOR)
def _output_error_fit(p, s, y: float, forgetting: float) -> None:  # noqa: ANN001
    """Absorb the scaled force ``y = f[k] / r`` into the sums and refit (module docstring)."""
    F = p.programmed_feed_mm_min
    to_scaled = 1.0 / F
    z = s.filtered_chip_load
    szz = s.sum_zz
    syz = s.sum_yz
    profile = s.profile
    gains = s.candidate_gain
    m = szz.shape[0]
    syy = forgetting * s.sum_yy + y * y
    s.sum_yy = syy
    s.samples = forgetting * s.samples + 1.0
    for i in range(m):
        zi = z[i] * to_scaled
        a = forgetting * szz[i] + zi * zi
        b = forgetting * syz[i] + y * zi
        szz[i] = a
        syz[i] = b
        g = b / a
        gains[i] = g
        # inf where S_zz = 0 (no chip load yet; then S_yz = 0 too): never the least
        profile[i] = syy - b * g if a > 0.0 else np.inf
    best = _least(profile)
    if best < 0:  # no chip load yet: nothing to fit
        return
    s.best = best
    s.best_gain = gains[best]
    _refine_pole(p, s, best)
    gain = _gain_at(s, s.pole_grid_position) * p.reference_force_N / F
    s.static_gain_N_per_mm_min = _clip(
        gain, p.static_gain_min_N_per_mm_min, p.static_gain_max_N_per_mm_min
    )


@jit
def _output_error_step(p, s, force_N: float, in_cut: bool, excited: bool) -> int:  # noqa: ANN001
    """The output-error method's reset, skip and fit for ``f[k]`` (candidates advanced)."""
    r = p.reference_force_N
    err = 0.0
    if s.best >= 0:
        z = s.filtered_chip_load[s.best] / p.programmed_feed_mm_min
        err = force_N / r - s.best_gain * z
    large = in_cut and abs(err) > p.reset_error_fraction
    reset = in_cut and ((s.was_in_cut == 0) or (large and s.was_large_error == 0))
    s.was_in_cut = 1 if in_cut else 0
    s.was_large_error = 1 if large else 0
    if reset:
        _clear_sums(s)
        s.skip = p.skip_after_reset
    if not in_cut:
        return 0
    if s.skip > 0:
        s.skip -= 1
        return 0
    _output_error_fit(p, s, force_N / r, p.forgetting if excited else 1.0)
    return 1


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
    w = EXCITATION_WEIGHT
    du = (u1 - u2) / F
    excitation = (1 - w) * s.excitation + w * (du * du)
    fmin = p.min_force_fraction * r
    in_cut = (force_N > fmin) and (f1 > fmin) and (f2 > fmin)
    if p.method == 2:
        _output_error_propagate(p, s, u1)
        s.updated = _output_error_step(p, s, force_N, in_cut, excitation > p.excitation_threshold)
        s.force2_N = f1
        s.force1_N = force_N
        s.excitation = excitation
        return s.updated
    y = (force_N - phi_a * f1) / r
    h0 = (f1 - phi_a * f2) / r
    h1 = u1 / F
    h2 = u2 / F
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
def _physical(p, th0: float, th1: float, th2: float) -> tuple[float, float]:  # noqa: ANN001
    """Static gain [N/(mm/min)] and ``p2`` [rad/s] of a regression vector ``theta``."""
    p2 = math.log(th0) / p.control_period_s
    g = (th1 + th2) * (p.reference_force_N / p.programmed_feed_mm_min) / (
        (1.0 - p.phi_a) * (1.0 - th0)
    )
    return g, p2


@jit
def estimates(p, s) -> tuple[float, float]:  # noqa: ANN001
    """Current ``K2`` [N/(mm/min)/s] and ``p2`` [rad/s]."""
    if p.method == 2:
        return -s.p2_rad_s * s.static_gain_N_per_mm_min, s.p2_rad_s
    g, p2 = _physical(p, s.theta[0], s.theta[1], s.theta[2])
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
    design: DesignSet | Sequence[DesignSet] | None = None,
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
    design : DesignSet or sequence of them, length runs, optional
        The declared plant set: the projection range of the static gain (and of the pole,
        when declared) and the stiffest plant the estimate starts from.  None: the gain
        within ``estimator_parameter_ratio_max`` of nominal either way.

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
    out, state = PROCESS_GAIN.records(runs, ring=delay_size(int(delays.max(initial=0)) + 2))
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
    rmax = each("estimator_parameter_ratio_max")
    g_nom = k2n / (-p2n)
    given = [design] * runs if design is None or isinstance(design, DesignSet) else list(design)
    sets = [DesignSet(gain_ratio_range=(1.0 / x, x)) if d is None else d
            for x, d in zip(rmax, given, strict=True)]
    gain_lo = np.array([d.gain_ratio_range[0] for d in sets]) * g_nom
    gain_hi = np.array([d.gain_ratio_range[1] for d in sets]) * g_nom
    poles = np.array([d.poles_rad_s(pn, x) for pn, x, d in zip(p2n, rmax, sets, strict=True)])
    stiffest = np.array([x.estimator_start == "stiffest" for x in settings])
    p2s = np.where(stiffest, np.clip(p2n, poles[:, 0], poles[:, 1]), p2n)
    k2s = np.where(stiffest, gain_hi * (-p2s), k2n)
    b = np.array(
        [
            zoh_numerator(float(x), float(y), float(z), Tc)
            for x, y, z in zip(a, k2s, p2s, strict=True)
        ]
    )
    theta0 = np.column_stack([np.exp(p2s * Tc), b * (F / r)[:, None]])
    P0 = np.zeros((runs, 3, 3))
    P0[:, 0, 0] = PHI2_PRIOR_STD**2
    P0[:, 1, 1] = (B_PRIOR_FRACTION * theta0[:, 1]) ** 2
    P0[:, 2, 2] = (B_PRIOR_FRACTION * theta0[:, 2]) ** 2
    out["theta0"] = theta0
    out["safe_start"] = stiffest
    out["covariance0"] = P0
    out["trace_max"] = COVARIANCE_TRACE_FACTOR * np.trace(P0, axis1=1, axis2=2)
    out["phi2_min"] = np.exp(poles[:, 0] * Tc)
    out["phi2_max"] = np.exp(poles[:, 1] * Tc)
    out["static_gain_min_N_per_mm_min"] = gain_lo
    out["static_gain_max_N_per_mm_min"] = gain_hi
    out["delay_periods"] = delays
    out["ring_mask"] = state.dtype["history_mm_min"].shape[0] - 1
    # output error: candidate poles over the projection range, their exact updates
    cutoff = each("estimator_sensor_cutoff_hz")
    m = POLE_GRID_POINTS
    log0 = np.log(-poles[:, 1])
    step = np.maximum((np.log(-poles[:, 0]) - log0) / (m - 1), 1e-12)  # a one-pole set
    out["log_pole0"] = log0
    out["log_pole_step"] = step
    out["pole_std_max"] = each("estimator_pole_std_max")
    out["filtered"] = cutoff > 0
    for i in range(runs):
        grid = tuple(-np.exp(log0[i] + step[i] * np.arange(m)))
        out["pole_grid_rad_s"][i] = grid
        c = candidate_models(float(a[i]), grid, float(cutoff[i]), Tc)
        out["candidate_coefficients"][i] = np.concatenate(
            [c[:, 0, [0, 1, 3]].T, c[:, 1, :].T]
        )
    wcT = 2.0 * np.pi * cutoff * Tc
    out["skip_after_reset"] = np.where(
        wcT > 0, np.ceil(-np.log(FILTER_SETTLED) / np.where(wcT > 0, wcT, 1.0)), 0
    ).astype(np.int64)
    return out, init_states(out, state)


__all__ = [
    "ESTIMATOR_KINDS",
    "ESTIMATOR_STARTS",
    "EstimatorOptions",
    "POLE_GRID_POINTS",
    "PROCESS_GAIN",
    "candidate_models",
    "estimates",
    "estimator_records",
    "project",
    "record_command",
    "zoh_numerator",
]
