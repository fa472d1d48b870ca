"""The robust adaptive force controller: PI (fixed or adaptive) with an optional disturbance
observer, the structure of Kim & Chung Fig. 8.

One control period at instant ``k`` with measured force ``y[k]`` [N]:

1. the gain estimator (if any) absorbs ``y[k]``: estimates ``K2_hat, p2_hat``;
2. the PI gains: fixed, or from the estimate (:func:`controllers.adaptive_pi.adaptive_pi_gains`);
3. the observer (if any) gives ``d_hat[k]`` [mm/min] from ``y[k]`` and the commands up to
   ``k - 1``, inverting the nominal model or (``observer_model="estimated"``) the estimate;
4. ``override = clip(kp e + i - d_hat / F, min, max)`` with clamping anti-windup on the
   override actually sent (:func:`controllers.adaptive_pi.pi_law`);
5. the command ``u[k] = override F`` [mm/min] goes into the estimator's and the observer's
   delay lines.

The four kinds of the scenario map onto it as: ``adaptive_pi`` = estimator + adaptive gains;
``dob_pi`` = fixed gains + observer on the nominal plant; ``dob_adaptive_pi`` = estimator +
adaptive gains + observer on the estimated model.  With neither, the law is exactly
:class:`controllers.pi.FeedOverridePI`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from controllers.adaptive_pi import adaptive_pi_gains, pi_law
from controllers.disturbance_observer import DisturbanceObserver, DisturbanceObserverState
from controllers.gain_estimator import GainEstimatorState, ProcessGainEstimator
from controllers.pi import ANTI_WINDUP_KINDS

OBSERVER_MODELS = ("nominal", "estimated")

#: Names returned by :meth:`RobustForceController.diagnostics`, each shape (runs,).
DIAGNOSTIC_NAMES = (
    "kp_per_N",
    "ki_per_N_s",
    "estimated_k2_N_min_per_mm_s",
    "estimated_p2_rad_s",
    "estimated_static_gain_N_per_mm_min",
    "estimator_updated",
    "disturbance_estimate_mm_min",
)


class RobustForceControllerState(NamedTuple):
    """Controller state.

    Attributes
    ----------
    integral : ndarray, shape (runs,)
        PI integrator [-].
    estimator : GainEstimatorState or None
    observer : DisturbanceObserverState or None
    kp_per_N, ki_per_N_s : ndarray, shape (runs,)
        Gains used in the last period.
    disturbance_mm_min : ndarray, shape (runs,)
        Observer estimate used in the last period [mm/min] (0 without observer).
    """

    integral: NDArray[np.float64]
    estimator: GainEstimatorState | None
    observer: DisturbanceObserverState | None
    kp_per_N: NDArray[np.float64]
    ki_per_N_s: NDArray[np.float64]
    disturbance_mm_min: NDArray[np.float64]


class RobustForceController:
    """A batch of PI / adaptive PI controllers with an optional disturbance observer.

    Parameters
    ----------
    reference_force_N : array_like, shape (runs,) or scalar
        ``r`` [N].
    kp_per_N, ki_per_N_s : array_like, shape (runs,) or scalar
        Fixed gains, or the nominal gains the adaptive rule rescales.
    override_min, override_max, initial_override : array_like, shape (runs,) or scalar
        Clamp and integrator start [-].
    programmed_feed_mm_min : array_like, shape (runs,) or scalar
        ``F`` [mm/min].
    bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s : array_like, shape (runs,) or scalar
        Nominal model (Eq. 9).
    control_period_s : float
    runs : int
    anti_windup : {"clamping", "none"}
    estimator : ProcessGainEstimator, optional
        Present: the gains adapt to its estimate.
    observer : DisturbanceObserver, optional
    observer_model : {"nominal", "estimated"}
        Model the observer inverts ("estimated" needs an estimator).
    """

    def __init__(
        self,
        reference_force_N: ArrayLike,
        kp_per_N: ArrayLike,
        ki_per_N_s: ArrayLike,
        override_min: ArrayLike,
        override_max: ArrayLike,
        initial_override: ArrayLike,
        programmed_feed_mm_min: ArrayLike,
        bandwidth_rad_s: ArrayLike,
        k2_N_min_per_mm_s: ArrayLike,
        p2_rad_s: ArrayLike,
        control_period_s: float,
        runs: int,
        anti_windup: str = "clamping",
        estimator: ProcessGainEstimator | None = None,
        observer: DisturbanceObserver | None = None,
        observer_model: str = "nominal",
    ) -> None:
        if anti_windup not in ANTI_WINDUP_KINDS:
            raise ValueError(f"anti_windup must be one of {ANTI_WINDUP_KINDS}, got {anti_windup!r}")
        if observer_model not in OBSERVER_MODELS:
            raise ValueError(f"dob_model must be one of {OBSERVER_MODELS}, got {observer_model!r}")
        if observer_model == "estimated" and observer is not None and estimator is None:
            raise ValueError("dob_model = 'estimated' needs a gain estimator")

        def vec(x: ArrayLike) -> NDArray[np.float64]:
            return np.broadcast_to(np.asarray(x, dtype=float), (runs,)).copy()

        self.runs = runs
        self.reference_force_N = vec(reference_force_N)
        self.kp_per_N = vec(kp_per_N)
        self.ki_per_N_s = vec(ki_per_N_s)
        self.override_min = vec(override_min)
        self.override_max = vec(override_max)
        self.initial_override = vec(initial_override)
        self.programmed_feed_mm_min = vec(programmed_feed_mm_min)
        self.bandwidth_rad_s = vec(bandwidth_rad_s)
        self.k2_N_min_per_mm_s = vec(k2_N_min_per_mm_s)
        self.p2_rad_s = vec(p2_rad_s)
        self.control_period_s = float(control_period_s)
        self.anti_windup = anti_windup
        self.estimator = estimator
        self.observer = observer
        self.observer_model = observer_model
        if np.any(self.override_min > self.override_max):
            raise ValueError("override_min must be <= override_max")

    def init(self) -> RobustForceControllerState:
        """Integrator at the initial override, estimator at the nominal model, at rest."""
        return RobustForceControllerState(
            self.initial_override.copy(),
            None if self.estimator is None else self.estimator.init(),
            None if self.observer is None else self.observer.init(),
            self.kp_per_N.copy(),
            self.ki_per_N_s.copy(),
            np.zeros(self.runs),
        )

    def step(
        self, state: RobustForceControllerState, measured_force_N: NDArray[np.float64]
    ) -> tuple[RobustForceControllerState, NDArray[np.float64]]:
        """One control period (module docstring).

        Parameters
        ----------
        state : RobustForceControllerState
        measured_force_N : ndarray, shape (runs,)
            Measured force at this control instant [N].

        Returns
        -------
        state : RobustForceControllerState
            The input state is not modified.
        override : ndarray, shape (runs,)
            Clamped feedrate override [-].
        """
        y = np.asarray(measured_force_N, dtype=float)
        F = self.programmed_feed_mm_min
        est = state.estimator
        k2m, p2m = self.k2_N_min_per_mm_s, self.p2_rad_s
        kp, ki = self.kp_per_N, self.ki_per_N_s
        if self.estimator is not None:
            est = self.estimator.update(est, y)
            k2h, p2h = self.estimator.estimates(est)
            kp, ki = adaptive_pi_gains(kp, ki, k2m, p2m, k2h, p2h)
            if self.observer_model == "estimated":
                k2m, p2m = k2h, p2h
        d = np.zeros(self.runs)
        if self.observer is not None:
            d = self.observer.estimate(state.observer, y, self.bandwidth_rad_s, k2m, p2m)
        integral, override = pi_law(
            state.integral,
            self.reference_force_N - y,
            kp,
            ki,
            self.control_period_s,
            -d / F,
            self.override_min,
            self.override_max,
            self.anti_windup,
        )
        command = override * F
        if self.estimator is not None:
            est = self.estimator.record_command(est, command)
        obs = state.observer
        if self.observer is not None:
            obs = self.observer.advance(obs, y, command)
        return RobustForceControllerState(integral, est, obs, kp, ki, d), override

    def diagnostics(self, state: RobustForceControllerState) -> dict[str, NDArray[np.float64]]:
        """Internal signals after the last period, each shape (runs,) (:data:`DIAGNOSTIC_NAMES`).

        Without an estimator the estimated model is the nominal one and ``estimator_updated``
        is 0.
        """
        if self.estimator is not None and state.estimator is not None:
            k2, p2 = self.estimator.estimates(state.estimator)
            updated = state.estimator.updated.astype(float)
        else:
            k2, p2, updated = self.k2_N_min_per_mm_s, self.p2_rad_s, np.zeros(self.runs)
        return {
            "kp_per_N": state.kp_per_N.copy(),
            "ki_per_N_s": state.ki_per_N_s.copy(),
            "estimated_k2_N_min_per_mm_s": np.array(k2, dtype=float),
            "estimated_p2_rad_s": np.array(p2, dtype=float),
            "estimated_static_gain_N_per_mm_min": np.asarray(k2 / (-p2), dtype=float),
            "estimator_updated": updated,
            "disturbance_estimate_mm_min": state.disturbance_mm_min.copy(),
        }


__all__ = [
    "DIAGNOSTIC_NAMES",
    "OBSERVER_MODELS",
    "RobustForceController",
    "RobustForceControllerState",
]
