"""Controller selection: the ``[controller]`` scenario section and the factory behind it.

Kinds:

``"pi"``
    Fixed-gain feedrate-override PI (:mod:`controllers.pi`); gains from the scenario or, when
    omitted, from the nominal plant by :func:`controllers.pi_design.design_pi`.
``"constant"``
    Fixed override (the conventional constant feed).  ``constant_override`` omitted means the
    safe feed: the largest constant feed whose steady force is at most the reference on
    every depth of the part.
``"adaptive_pi"``
    PI whose gains follow the online estimate of ``K2`` and ``p2``
    (:mod:`controllers.adaptive_pi`, :mod:`controllers.gain_estimator`).
``"dob_pi"``
    Fixed PI around a disturbance observer on the nominal plant
    (:mod:`controllers.disturbance_observer`, Eqs. 10-11).
``"dob_adaptive_pi"``
    Adaptive PI around a disturbance observer that inverts the estimated model
    (``dob_model = "estimated"``, default) or the nominal one.

The last three run the compiled element
:data:`controllers.robust_force_controller.ROBUST`; its estimator and observer delay whole
control periods, the nominal dead time rounded to the nearest whole period.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from controllers.disturbance_observer import observer_records
from controllers.gain_estimator import GainEstimatorParams, estimator_records
from controllers.pi import ANTI_WINDUP_KINDS, constant_records, pi_records
from controllers.pi_design import PIGains, design_pi
from controllers.q_filter import q_filter_denominator
from controllers.robust_force_controller import OBSERVER_MODELS, robust_records
from plants.nominal_plant import NominalPlant

CONTROLLER_KINDS = ("pi", "constant", "adaptive_pi", "dob_pi", "dob_adaptive_pi")
#: Kinds with a disturbance observer / with a gain estimator.
OBSERVER_KINDS = ("dob_pi", "dob_adaptive_pi")
ADAPTIVE_KINDS = ("adaptive_pi", "dob_adaptive_pi")


@dataclass(frozen=True)
class ControllerParams:
    """The ``[controller]`` section.

    Attributes
    ----------
    kind : {"pi", "constant"}
        Which controller runs.
    reference_force_N : float
        Force reference [N], > 0.
    programmed_feed_mm_min : float
        Programmed feed the override multiplies [mm/min], > 0.
    override_min, override_max : float
        Override clamp [-], 0 <= min <= max.
    initial_override : float
        Override (integrator) at start [-].
    kp_per_N, ki_per_N_s : float or None
        PI gains [1/N], [1/(N s)]; None designs them from the nominal plant.
    design_phase_margin_deg : float
        Phase margin of the design rule [deg].
    anti_windup : {"clamping", "none"}
        Integrator anti-windup.
    constant_override : float or None
        Override of the ``"constant"`` kind [-]; None = the safe feed.
    dob_tau_s : float
        Q-filter time constant ``tau`` of Eq. (11) [s], > 0 (``dob_*`` kinds).
    dob_disturbance_limit_mm_min : float or None
        Saturation of the disturbance estimate ``|d_hat|`` [mm/min]; None = none.
    dob_model : {"estimated", "nominal"}
        Model the observer of ``dob_adaptive_pi`` inverts.
    estimator : {"rls", "kalman"}
        Gain estimator of the adaptive kinds.
    estimator_forgetting, estimator_measurement_std_fraction, estimator_min_force_fraction,
    estimator_excitation_threshold, estimator_reset_error_fraction,
    estimator_parameter_ratio_max : float
        See :class:`controllers.gain_estimator.GainEstimatorParams` (same names without the
        ``estimator_`` prefix).
    """

    kind: str = "pi"
    reference_force_N: float = 500.0
    programmed_feed_mm_min: float = 120.0
    override_min: float = 0.1
    override_max: float = 2.0
    initial_override: float = 1.0
    kp_per_N: float | None = None
    ki_per_N_s: float | None = None
    design_phase_margin_deg: float = 60.0
    anti_windup: str = "clamping"
    constant_override: float | None = None
    dob_tau_s: float = 0.1
    dob_disturbance_limit_mm_min: float | None = None
    dob_model: str = "estimated"
    estimator: str = "rls"
    estimator_forgetting: float = 0.98
    estimator_measurement_std_fraction: float = 0.002
    estimator_min_force_fraction: float = 0.1
    estimator_excitation_threshold: float = 1e-3
    estimator_reset_error_fraction: float = 0.05
    estimator_parameter_ratio_max: float = 5.0

    @property
    def estimator_params(self) -> GainEstimatorParams:
        """The ``estimator_*`` keys as :class:`GainEstimatorParams`."""
        return GainEstimatorParams(
            method=self.estimator,
            forgetting=self.estimator_forgetting,
            measurement_std_fraction=self.estimator_measurement_std_fraction,
            min_force_fraction=self.estimator_min_force_fraction,
            excitation_threshold=self.estimator_excitation_threshold,
            reset_error_fraction=self.estimator_reset_error_fraction,
            parameter_ratio_max=self.estimator_parameter_ratio_max,
        )

    def __post_init__(self) -> None:
        if self.kind not in CONTROLLER_KINDS:
            raise ValueError(f"kind must be one of {CONTROLLER_KINDS}, got {self.kind!r}")
        if not self.reference_force_N > 0:
            raise ValueError(f"reference_force_N must be > 0, got {self.reference_force_N}")
        if not self.programmed_feed_mm_min > 0:
            raise ValueError(
                f"programmed_feed_mm_min must be > 0, got {self.programmed_feed_mm_min}"
            )
        if not 0 <= self.override_min <= self.override_max:
            raise ValueError(
                f"override_min/override_max must satisfy 0 <= min <= max, got "
                f"{self.override_min}, {self.override_max}"
            )
        if self.anti_windup not in ANTI_WINDUP_KINDS:
            raise ValueError(f"anti_windup must be one of {ANTI_WINDUP_KINDS}")
        if (self.kp_per_N is None) != (self.ki_per_N_s is None):
            raise ValueError("kp_per_N and ki_per_N_s: give both or neither")
        if self.kp_per_N is not None and not (self.kp_per_N >= 0 and self.ki_per_N_s >= 0):
            raise ValueError("kp_per_N and ki_per_N_s must be >= 0")
        if not 0 < self.design_phase_margin_deg < 90:
            raise ValueError("design_phase_margin_deg must be in (0, 90)")
        if self.constant_override is not None and not self.constant_override >= 0:
            raise ValueError("constant_override must be >= 0")
        if not self.dob_tau_s > 0:
            raise ValueError(f"dob_tau_s must be > 0, got {self.dob_tau_s}")
        limit = self.dob_disturbance_limit_mm_min
        if limit is not None and not limit >= 0:
            raise ValueError(f"dob_disturbance_limit_mm_min must be >= 0, got {limit}")
        if self.dob_model not in OBSERVER_MODELS:
            raise ValueError(f"dob_model must be one of {OBSERVER_MODELS}, got {self.dob_model!r}")
        self.estimator_params  # noqa: B018  (validates the estimator_* keys)


def resolved_gains(
    params: ControllerParams, nominal: NominalPlant, control_period_s: float
) -> PIGains:
    """The PI gains a run uses: the scenario's, or the designed ones (memoised)."""
    if params.kp_per_N is not None and params.ki_per_N_s is not None:
        return PIGains(params.kp_per_N, params.ki_per_N_s, math.nan, math.nan)
    return _designed(
        nominal, params.programmed_feed_mm_min, control_period_s, params.design_phase_margin_deg
    )


@functools.lru_cache(maxsize=4096)
def _designed(
    nominal: NominalPlant, feed_mm_min: float, control_period_s: float, margin_deg: float
) -> PIGains:
    return design_pi(nominal, feed_mm_min, control_period_s, margin_deg)


def dead_time_periods(nominal: NominalPlant, control_period_s: float) -> int:
    """Nominal dead time in whole control periods (rounded to the nearest)."""
    return int(round(nominal.dead_time_s / control_period_s))


def controller_records(
    params: Sequence[ControllerParams],
    nominal: Sequence[NominalPlant],
    control_period_s: float,
    safe_override: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Compiled-element records of the controllers of runs that share a kind.

    Parameters
    ----------
    params : sequence of ControllerParams, length runs
    nominal : sequence of NominalPlant, length runs
    control_period_s : float
        Controller period [s].
    safe_override : ndarray, shape (runs,)
        Override of the safe constant feed of each run [-] (used by ``"constant"``).

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    kinds = {p.kind for p in params}
    if len(kinds) != 1:
        raise ValueError(f"one batch runs one controller kind, got {sorted(kinds)}")
    kind = kinds.pop()
    if kind == "constant":
        ov = [
            s if p.constant_override is None else p.constant_override
            for p, s in zip(params, safe_override, strict=True)
        ]
        return constant_records(np.array(ov, dtype=float))
    gains = [resolved_gains(p, n, control_period_s) for p, n in zip(params, nominal, strict=True)]
    common = _pi_arguments(params, gains)
    if kind == "pi":
        return pi_records(
            **common,
            control_period_s=control_period_s,
            anti_windup=[p.anti_windup for p in params],
        )
    return _robust_records(kind, params, nominal, control_period_s, common)


def _pi_arguments(
    params: Sequence[ControllerParams], gains: Sequence[PIGains]
) -> dict[str, np.ndarray]:
    """Per-run PI arguments shared by every PI-based controller, each shape (runs,)."""
    return {
        "reference_force_N": np.array([p.reference_force_N for p in params]),
        "kp_per_N": np.array([g.kp_per_N for g in gains]),
        "ki_per_N_s": np.array([g.ki_per_N_s for g in gains]),
        "override_min": np.array([p.override_min for p in params]),
        "override_max": np.array([p.override_max for p in params]),
        "initial_override": np.array([p.initial_override for p in params]),
    }


def _robust_records(
    kind: str,
    params: Sequence[ControllerParams],
    nominal: Sequence[NominalPlant],
    control_period_s: float,
    common: dict[str, np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    delays = [dead_time_periods(n, control_period_s) for n in nominal]
    programmed = np.array([p.programmed_feed_mm_min for p in params])
    a = np.array([n.bandwidth_rad_s for n in nominal])
    k2 = np.array([n.k2_N_min_per_mm_s for n in nominal])
    p2 = np.array([n.p2_rad_s for n in nominal])
    estimator = None
    if kind in ADAPTIVE_KINDS:
        estimator = estimator_records(
            [p.estimator_params for p in params],
            a, k2, p2, delays, common["reference_force_N"], programmed, control_period_s,
        )
    observer = None
    models = ["estimated" if kind == "dob_adaptive_pi" else "nominal"] * len(params)
    if kind in OBSERVER_KINDS:
        limits = [
            np.inf if p.dob_disturbance_limit_mm_min is None else p.dob_disturbance_limit_mm_min
            for p in params
        ]
        observer = observer_records(
            [([1.0], tuple(q_filter_denominator(p.dob_tau_s))) for p in params],
            delays,
            control_period_s,
            limits,
        )
        if kind == "dob_adaptive_pi":
            models = [p.dob_model for p in params]
    return robust_records(
        **common,
        programmed_feed_mm_min=programmed,
        bandwidth_rad_s=a,
        k2_N_min_per_mm_s=k2,
        p2_rad_s=p2,
        control_period_s=control_period_s,
        anti_windup=[p.anti_windup for p in params],
        estimator=estimator,
        observer=observer,
        observer_model=models,
    )


__all__ = [
    "ADAPTIVE_KINDS",
    "CONTROLLER_KINDS",
    "OBSERVER_KINDS",
    "ControllerParams",
    "controller_records",
    "dead_time_periods",
    "resolved_gains",
]
