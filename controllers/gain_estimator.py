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
measured through ``h`` with variance ``sigma^2`` (filterpy's ``predict``/``update``).

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

from dataclasses import dataclass
from typing import NamedTuple

import control
import numpy as np
from filterpy.kalman import predict as kf_predict
from filterpy.kalman import update as kf_update
from numpy.typing import ArrayLike, NDArray

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
class GainEstimatorParams:
    """Settings of the process-gain estimator.

    Attributes
    ----------
    method : {"rls", "kalman"}
        Recursive least squares with forgetting, or a random-walk Kalman filter.
    forgetting : float
        RLS forgetting factor ``lambda`` per control period, in (0, 1]; the Kalman filter's
        random walk is ``(1 - lambda) P0`` per period.
    measurement_std_fraction : float
        Kalman measurement standard deviation of ``y`` [fraction of the reference], > 0.
    min_force_fraction : float
        No update unless the last three forces exceed this fraction of the reference [-].
    excitation_threshold : float
        No update unless the excitation measure exceeds this [-], >= 0.
    reset_error_fraction : float
        Prediction error that resets the covariance [fraction of the reference], > 0.
    parameter_ratio_max : float
        ``|p2|`` and the static gain are kept within this factor of nominal [-], > 1.
    """

    method: str = "rls"
    forgetting: float = 0.98
    measurement_std_fraction: float = 0.002
    min_force_fraction: float = 0.1
    excitation_threshold: float = 1e-3
    reset_error_fraction: float = 0.05
    parameter_ratio_max: float = 5.0

    def __post_init__(self) -> None:
        if self.method not in ESTIMATOR_KINDS:
            raise ValueError(f"estimator must be one of {ESTIMATOR_KINDS}, got {self.method!r}")
        if not 0 < self.forgetting <= 1:
            raise ValueError(f"estimator_forgetting must be in (0, 1], got {self.forgetting}")
        if not self.measurement_std_fraction > 0:
            raise ValueError("estimator_measurement_std_fraction must be > 0")
        if not self.min_force_fraction >= 0:
            raise ValueError("estimator_min_force_fraction must be >= 0")
        if not self.excitation_threshold >= 0:
            raise ValueError("estimator_excitation_threshold must be >= 0")
        if not self.reset_error_fraction > 0:
            raise ValueError("estimator_reset_error_fraction must be > 0")
        if not self.parameter_ratio_max > 1:
            raise ValueError("estimator_parameter_ratio_max must be > 1")


class GainEstimatorState(NamedTuple):
    """Estimator state.

    Attributes
    ----------
    theta : ndarray, shape (runs, 3)
        ``(phi_2, b1 F / r, b2 F / r)``.
    covariance : ndarray, shape (runs, 3, 3)
        Covariance of ``theta``.
    force_N : ndarray, shape (runs, 2)
        ``f[k-1], f[k-2]`` [N].
    history_mm_min : ndarray, shape (runs, max_delay + 2)
        Ring buffer of past commands [mm/min].
    head : int
        Slot the next command is written to.
    excitation : ndarray, shape (runs,)
        Excitation measure [-].
    skip : ndarray of int, shape (runs,)
        Samples still to skip after a reset.
    updated : ndarray of bool, shape (runs,)
        Whether the last call updated the estimate.
    """

    theta: NDArray[np.float64]
    covariance: NDArray[np.float64]
    force_N: NDArray[np.float64]
    history_mm_min: NDArray[np.float64]
    head: int
    excitation: NDArray[np.float64]
    skip: NDArray[np.int64]
    updated: NDArray[np.bool_]


def zoh_numerator(
    bandwidth_rad_s: float, k2_N_min_per_mm_s: float, p2_rad_s: float, control_period_s: float
) -> tuple[float, float]:
    """``b1, b2`` of the zero-order-hold discretisation of ``a K2 / ((s + a)(s - p2))``."""
    a = bandwidth_rad_s
    sysd = control.c2d(
        control.tf([a * k2_N_min_per_mm_s], np.polymul([1.0, a], [1.0, -p2_rad_s])),
        control_period_s,
        method="zoh",
    )
    num = np.atleast_1d(np.squeeze(sysd.num[0][0]))
    den = np.atleast_1d(np.squeeze(sysd.den[0][0]))
    num = num / den[0]
    num = np.r_[np.zeros(2 - len(num)), num][-2:]
    return float(num[0]), float(num[1])


class ProcessGainEstimator:
    """A batch of online estimators of ``K2`` and ``p2`` (module docstring).

    Parameters
    ----------
    params : GainEstimatorParams
        Shared settings.
    bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s : array_like, shape (runs,) or scalar
        Nominal model (Eq. 9): drive bandwidth, start values and projection centre.
    delay_periods : array_like of int, shape (runs,) or scalar
        Dead time in whole control periods ``N``.
    reference_force_N, programmed_feed_mm_min : array_like, shape (runs,) or scalar
        Scales ``r`` [N] and ``F`` [mm/min] of the regression.
    control_period_s : float
        ``T_c`` [s].
    runs : int
    """

    def __init__(
        self,
        params: GainEstimatorParams,
        bandwidth_rad_s: ArrayLike,
        k2_N_min_per_mm_s: ArrayLike,
        p2_rad_s: ArrayLike,
        delay_periods: ArrayLike,
        reference_force_N: ArrayLike,
        programmed_feed_mm_min: ArrayLike,
        control_period_s: float,
        runs: int,
    ) -> None:
        def vec(x: ArrayLike) -> NDArray[np.float64]:
            return np.broadcast_to(np.asarray(x, dtype=float), (runs,)).copy()

        self.params = params
        self.runs = runs
        self.control_period_s = float(control_period_s)
        self.bandwidth_rad_s = vec(bandwidth_rad_s)
        self.k2_nominal = vec(k2_N_min_per_mm_s)
        self.p2_nominal = vec(p2_rad_s)
        self.delay_periods = np.broadcast_to(np.asarray(delay_periods), (runs,)).astype(np.int64)
        self.reference_force_N = vec(reference_force_N)
        self.programmed_feed_mm_min = vec(programmed_feed_mm_min)
        if np.any(self.p2_nominal >= 0) or np.any(self.k2_nominal <= 0):
            raise ValueError("nominal model needs K2 > 0 and p2 < 0")
        Tc = self.control_period_s
        self.phi_a = np.exp(-self.bandwidth_rad_s * Tc)
        scale = self.programmed_feed_mm_min / self.reference_force_N
        b = np.array(
            [
                zoh_numerator(a, k, p, Tc)
                for a, k, p in zip(
                    self.bandwidth_rad_s, self.k2_nominal, self.p2_nominal, strict=True
                )
            ]
        )
        self.theta0 = np.column_stack([np.exp(self.p2_nominal * Tc), b * scale[:, None]])
        self.P0 = np.zeros((runs, 3, 3))
        self.P0[:, 0, 0] = PHI2_PRIOR_STD**2
        self.P0[:, 1, 1] = (B_PRIOR_FRACTION * self.theta0[:, 1]) ** 2
        self.P0[:, 2, 2] = (B_PRIOR_FRACTION * self.theta0[:, 2]) ** 2
        self.trace_max = COVARIANCE_TRACE_FACTOR * np.trace(self.P0, axis1=1, axis2=2)
        rmax = params.parameter_ratio_max
        self.phi2_bounds = (
            np.exp(self.p2_nominal * rmax * Tc),
            np.exp(self.p2_nominal / rmax * Tc),
        )
        g_nom = self.k2_nominal / (-self.p2_nominal)
        self.gain_bounds = (g_nom / rmax, g_nom * rmax)
        self._rows = np.arange(runs)
        self._size = int(self.delay_periods.max(initial=0)) + 2

    # --- estimates ----------------------------------------------------------------------
    def estimates(
        self, state: GainEstimatorState
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Current ``K2`` [N/(mm/min)/s] and ``p2`` [rad/s], each shape (runs,)."""
        return self._physical(state.theta)

    def static_gain(self, state: GainEstimatorState) -> NDArray[np.float64]:
        """Current static gain ``G = K2 / (-p2)`` [N/(mm/min)], shape (runs,)."""
        k2, p2 = self._physical(state.theta)
        return k2 / (-p2)

    def _physical(self, theta: NDArray) -> tuple[NDArray, NDArray]:
        phi2 = theta[:, 0]
        p2 = np.log(phi2) / self.control_period_s
        g = (
            (theta[:, 1] + theta[:, 2])
            * (self.reference_force_N / self.programmed_feed_mm_min)
            / ((1.0 - self.phi_a) * (1.0 - phi2))
        )
        return g * (-p2), p2

    def _project(self, theta: NDArray, idx: NDArray) -> NDArray:
        out = theta.copy()
        out[:, 0] = np.clip(out[:, 0], self.phi2_bounds[0][idx], self.phi2_bounds[1][idx])
        bsum = out[:, 1] + out[:, 2]
        to_gain = (self.reference_force_N[idx] / self.programmed_feed_mm_min[idx]) / (
            (1.0 - self.phi_a[idx]) * (1.0 - out[:, 0])
        )
        g = bsum * to_gain
        g_clip = np.clip(g, self.gain_bounds[0][idx], self.gain_bounds[1][idx])
        bad = ~(g == g_clip)
        if np.any(bad):
            # keep the numerator's shape, move its sum to the bound (nominal shape if degenerate)
            shape = np.where(
                (bsum[:, None] > 0) & (out[:, 1:] >= 0),
                out[:, 1:] / np.where(bsum > 0, bsum, 1.0)[:, None],
                self.theta0[idx, 1:] / self.theta0[idx, 1:].sum(axis=1, keepdims=True),
            )
            target = g_clip / to_gain
            out[bad, 1:] = shape[bad] * target[bad, None]
        return out

    # --- protocol -----------------------------------------------------------------------
    def init(self) -> GainEstimatorState:
        """Nominal estimate, covariance ``P0``, at rest."""
        return GainEstimatorState(
            self.theta0.copy(),
            self.P0.copy(),
            np.zeros((self.runs, 2)),
            np.zeros((self.runs, self._size)),
            0,
            np.zeros(self.runs),
            np.zeros(self.runs, dtype=np.int64),
            np.zeros(self.runs, dtype=bool),
        )

    def update(self, state: GainEstimatorState, force_N: NDArray[np.float64]) -> GainEstimatorState:
        """Absorb the force ``f[k]`` (commands up to ``k - 1`` are known).

        Parameters
        ----------
        state : GainEstimatorState
        force_N : ndarray, shape (runs,)
            Measured force at this control instant [N].

        Returns
        -------
        GainEstimatorState
            The input state is not modified.
        """
        p = self.params
        r, F = self.reference_force_N, self.programmed_feed_mm_min
        f1, f2 = state.force_N[:, 0], state.force_N[:, 1]
        hist = state.history_mm_min
        # newest command u[k-1] sits at head - 1
        u1 = hist[self._rows, (state.head - 1 - self.delay_periods) % self._size]
        u2 = hist[self._rows, (state.head - 2 - self.delay_periods) % self._size]
        y = (force_N - self.phi_a * f1) / r
        h = np.column_stack([(f1 - self.phi_a * f2) / r, u1 / F, u2 / F])
        w = EXCITATION_WEIGHT
        excitation = (1 - w) * state.excitation + w * ((u1 - u2) / F) ** 2
        fmin = p.min_force_fraction * r
        in_cut = (force_N > fmin) & (f1 > fmin) & (f2 > fmin)
        err = y - np.einsum("ri,ri->r", h, state.theta)
        reset = in_cut & (np.abs(err) > p.reset_error_fraction)
        skip = np.where(reset, SKIP_AFTER_RESET, np.maximum(state.skip - 1, 0))
        gate = in_cut & (excitation > p.excitation_threshold) & ~reset & (state.skip == 0)
        theta = state.theta.copy()
        cov = np.where(reset[:, None, None], self.P0, state.covariance)
        if np.any(gate):
            idx = np.flatnonzero(gate)
            if p.method == "rls":
                th, P = _rls(
                    theta[idx],
                    cov[idx],
                    h[idx],
                    y[idx],
                    p.forgetting,
                    p.measurement_std_fraction**2,
                )
            else:
                th, P = self._kalman(theta[idx], cov[idx], h[idx], y[idx], idx)
            tr = np.trace(P, axis1=1, axis2=2)
            P = P * np.minimum(1.0, self.trace_max[idx] / tr)[:, None, None]
            theta[idx] = self._project(th, idx)
            cov[idx] = P
        return GainEstimatorState(
            theta,
            cov,
            np.column_stack([force_N, f1]),
            hist,
            state.head,
            excitation,
            skip,
            gate,
        )

    def record_command(
        self, state: GainEstimatorState, command_mm_min: NDArray[np.float64]
    ) -> GainEstimatorState:
        """Store the command ``u[k]`` sent from this instant [mm/min], shape (runs,)."""
        hist = state.history_mm_min.copy()
        hist[:, state.head] = command_mm_min
        return state._replace(history_mm_min=hist, head=(state.head + 1) % self._size)

    def _kalman(self, theta: NDArray, cov: NDArray, h: NDArray, y: NDArray, idx: NDArray):
        lam = self.params.forgetting
        R = self.params.measurement_std_fraction**2
        th_out = np.empty_like(theta)
        P_out = np.empty_like(cov)
        for j, run in enumerate(idx):
            x, P = kf_predict(theta[j], cov[j], np.eye(3), (1.0 - lam) * self.P0[run])
            x, P = kf_update(x, P, y[j], R, h[j][None, :])
            th_out[j] = np.ravel(x)
            P_out[j] = 0.5 * (P + P.T)
        return th_out, P_out


def _rls(theta: NDArray, P: NDArray, h: NDArray, y: NDArray, lam: float, var: float):
    """One RLS step with forgetting ``lam``; ``P`` is a covariance, ``var`` the noise variance.

    Shapes (n, 3), (n, 3, 3), (n, 3), (n,).  With ``var = 1`` this is the textbook RLS; the
    scaling makes ``P0`` a prior covariance comparable with the Kalman variant.
    """
    Ph = np.einsum("rij,rj->ri", P, h)
    denom = lam * var + np.einsum("ri,ri->r", h, Ph)
    K = Ph / denom[:, None]
    err = y - np.einsum("ri,ri->r", h, theta)
    theta = theta + K * err[:, None]
    P = (P - np.einsum("ri,rj->rij", K, Ph)) / lam
    return theta, 0.5 * (P + np.swapaxes(P, 1, 2))


__all__ = [
    "ESTIMATOR_KINDS",
    "GainEstimatorParams",
    "GainEstimatorState",
    "ProcessGainEstimator",
    "zoh_numerator",
]
