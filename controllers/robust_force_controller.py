"""The robust adaptive force controller: PI (fixed or adaptive) with an optional disturbance
observer, the structure of Kim & Chung Fig. 8.

One control period at instant ``k`` with measured force ``y[k]`` [N]:

1. the gain estimator (if any) absorbs ``y[k]``: estimates ``K2_hat, p2_hat``;
2. the PI gains: fixed, or from the estimate (:func:`controllers.adaptive_pi.adaptive_pi_gains`);
3. the observer (if any) gives ``d_hat[k]`` [mm/min] from ``y[k]`` and the commands up to
   ``k - 1``, inverting the nominal model or (``observer_model="estimated"``) the estimate;
4. ``override = clip(kp e + i - d_hat / F + g u_r, min, max)`` with clamping anti-windup on
   the override actually sent (:func:`controllers.adaptive_pi.pi_law`), where ``u_r`` is the
   optional resonant term on ``e`` (:mod:`controllers.resonator`, ``resonant_frequency_hz``
   > 0; else 0) and ``g = K2n / K2_hat`` with an estimator (the resonator's gain rescaled
   with the estimate as ``kp`` is), 1 without;
5. the command ``u[k] = override F`` [mm/min] goes into the estimator's and the observer's
   delay lines.

The four kinds of the scenario map onto it as: ``adaptive_pi`` = estimator + adaptive gains;
``dob_pi`` = fixed gains + observer on the nominal plant; ``dob_adaptive_pi`` = estimator +
adaptive gains + observer on the estimated model.  With neither, the law is exactly
:class:`controllers.pi.FeedOverridePI`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import init, init_states, jit, record, register_element
from controllers import disturbance_observer as dob
from controllers import gain_estimator as gest
from controllers.adaptive_pi import (
    adaptive_pi_gains,
    bumpless_gain,
    bumpless_start,
    pi_law,
    set_override_pi_fields,
)
from controllers.disturbance_observer import OBSERVER_MODELS
from controllers.linear_loop import LoopSpec
from controllers.pi_design import PIDesignOptions
from controllers.registry import (
    ControllerKind,
    dead_time_periods,
    pi_arguments,
    register_controller,
    resolved_gains,
)
from controllers.resonator import (
    RESONATOR_PARAMS,
    RESONATOR_STATE,
    ResonantOptions,
    refuse_resonant,
    resonator_records,
    resonator_reset,
    resonator_update,
)

#: Controller diagnostics recorded with the traces, in the order a controller writes them
#: into its ``diagnostics`` buffer (kinds without them leave NaN).
DIAGNOSTIC_NAMES = (
    "kp_per_N",
    "ki_per_N_s",
    "estimated_k2_N_min_per_mm_s",
    "estimated_p2_rad_s",
    "estimated_static_gain_N_per_mm_min",
    "estimator_updated",
    "disturbance_estimate_mm_min",
)


def _dtypes(
    estimator_ring: int = 16, observer_order: int = 4, observer_ring: int = 16
) -> tuple[np.dtype, np.dtype]:
    est_p, est_s = gest.PROCESS_GAIN.dtypes(ring=estimator_ring)
    obs_p, obs_s = dob.DISTURBANCE.dtypes(order=observer_order, ring=observer_ring)
    params = record(
        "controller.robust",
        [
            ("reference_force_N", "f8"),
            ("kp_per_N", "f8"),  # fixed gains, or the nominal ones the adaptive rule rescales
            ("ki_per_N_s", "f8"),
            ("override_min", "f8"),
            ("override_max", "f8"),
            ("initial_override", "f8"),
            ("programmed_feed_mm_min", "f8"),
            ("bandwidth_rad_s", "f8"),  # nominal model (Eq. 9)
            ("k2_N_min_per_mm_s", "f8"),
            ("p2_rad_s", "f8"),
            ("control_period_s", "f8"),
            ("clamping", "b1"),
            ("has_estimator", "b1"),
            ("has_observer", "b1"),
            ("observer_on_estimate", "b1"),
            ("resonator", RESONATOR_PARAMS),
            ("estimator", est_p),
            ("observer", obs_p),
        ],
    )
    state = record(
        "controller.robust",
        [
            ("integral", "f8"),
            ("last_kp_per_N", "f8"),  # the proportional gain of the last period (bumpless)
            ("resonator", RESONATOR_STATE),
            ("estimator", est_s),
            ("observer", obs_s),
        ],
    )
    return params, state


@jit
def robust_init(p, s) -> None:  # noqa: ANN001
    """Integrator at the initial override (with the safe start: the PI's first output),
    estimator at its start model, at rest."""
    s.integral = p.initial_override
    resonator_reset(s.resonator)
    if p.has_estimator:
        init(p.estimator, s.estimator)
        s.integral = bumpless_start(p, p.estimator, s.estimator)
    s.last_kp_per_N = np.nan
    if p.has_observer:
        init(p.observer, s.observer)


@jit
def robust_step(p, s, measured_force_N: float, diagnostics: np.ndarray) -> float:  # noqa: ANN001
    """One control period (module docstring); writes :data:`DIAGNOSTIC_NAMES`."""
    y = measured_force_N
    F = p.programmed_feed_mm_min
    k2m = p.k2_N_min_per_mm_s
    p2m = p.p2_rad_s
    kp = p.kp_per_N
    ki = p.ki_per_N_s
    k2h = k2m
    p2h = p2m
    updated = 0.0
    gain_ratio = 1.0
    if p.has_estimator:
        updated = float(gest.step(p.estimator, s.estimator, y))
        k2h, p2h = gest.estimates(p.estimator, s.estimator)
        gain_ratio = k2m / k2h
        kp, ki = adaptive_pi_gains(kp, ki, k2m, p2m, k2h, p2h)
        if p.observer_on_estimate:
            k2m = k2h
            p2m = p2h
    d = 0.0
    if p.has_observer:
        d = dob.estimate(p.observer, s.observer, y, p.bandwidth_rad_s, k2m, p2m)
    offset = -d / F
    if p.resonator.on:
        offset = offset + gain_ratio * resonator_update(p.resonator, s.resonator,
                                                        p.reference_force_N - y)
    if p.has_estimator:
        s.integral = bumpless_gain(p.estimator, s.integral, s.last_kp_per_N, kp,
                                   p.reference_force_N - y)
    s.last_kp_per_N = kp
    s.integral, override = pi_law(
        s.integral,
        p.reference_force_N - y,
        kp,
        ki,
        p.control_period_s,
        offset,
        p.override_min,
        p.override_max,
        p.clamping,
    )
    command = override * F
    if p.has_estimator:
        gest.record_command(p.estimator, s.estimator, command)
    if p.has_observer:
        dob.advance(p.observer, s.observer, y, command)
    diagnostics[0] = kp
    diagnostics[1] = ki
    diagnostics[2] = k2h
    diagnostics[3] = p2h
    diagnostics[4] = k2h / (-p2h)
    diagnostics[5] = updated
    diagnostics[6] = d
    return override


ROBUST = register_element(
    "controller.robust",
    _dtypes,
    robust_init,
    robust_step,
    "PI or adaptive PI (online K2, p2) with an optional Q-filter disturbance observer",
)


def robust_records(
    reference_force_N: NDArray,
    kp_per_N: NDArray,
    ki_per_N_s: NDArray,
    override_min: NDArray,
    override_max: NDArray,
    initial_override: NDArray,
    programmed_feed_mm_min: NDArray,
    bandwidth_rad_s: NDArray,
    k2_N_min_per_mm_s: NDArray,
    p2_rad_s: NDArray,
    control_period_s: float,
    anti_windup: str | Sequence[str] = "clamping",
    estimator: tuple[NDArray, NDArray] | None = None,
    observer: tuple[NDArray, NDArray] | None = None,
    observer_model: str | Sequence[str] = "nominal",
    resonator: NDArray | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of robust force controllers.

    Parameters
    ----------
    reference_force_N, kp_per_N, ki_per_N_s, override_min, override_max, initial_override,
    programmed_feed_mm_min : ndarray, shape (runs,)
        As :func:`controllers.pi.pi_records`; ``F`` [mm/min].
    bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s : ndarray, shape (runs,)
        Nominal model (Eq. 9).
    control_period_s : float
    anti_windup : {"clamping", "none"} or sequence of them, length runs
    estimator : (params, state) or None
        :func:`controllers.gain_estimator.estimator_records`; present: the gains adapt.
    observer : (params, state) or None
        :func:`controllers.disturbance_observer.observer_records`.
    observer_model : {"nominal", "estimated"} or sequence of them, length runs
        Model the observer inverts ("estimated" needs an estimator).
    resonator : ndarray of RESONATOR_PARAMS, shape (runs,), or None
        :func:`controllers.resonator.resonator_records` (on flag and ``b0, b1, a1, a2``);
        None: no resonant term.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs = len(np.atleast_1d(reference_force_N))
    models = [observer_model] * runs if isinstance(observer_model, str) else list(observer_model)
    for model in models:
        if model not in OBSERVER_MODELS:
            raise ValueError(f"dob_model must be one of {OBSERVER_MODELS}, got {model!r}")
        if model == "estimated" and observer is not None and estimator is None:
            raise ValueError("dob_model = 'estimated' needs a gain estimator")
    sizes = {}
    if estimator is not None:
        sizes["estimator_ring"] = estimator[1].dtype["history_mm_min"].shape[0]
    if observer is not None:
        sizes["observer_order"] = observer[0].dtype["bank_B"].shape[0]
        sizes["observer_ring"] = observer[1].dtype["history_mm_min"].shape[0]
    params, state = ROBUST.records(runs, **sizes)
    set_override_pi_fields(
        params, control_period_s, anti_windup, estimator,
        reference_force_N=reference_force_N, kp_per_N=kp_per_N, ki_per_N_s=ki_per_N_s,
        override_min=override_min, override_max=override_max,
        initial_override=initial_override, programmed_feed_mm_min=programmed_feed_mm_min,
        bandwidth_rad_s=bandwidth_rad_s, k2_N_min_per_mm_s=k2_N_min_per_mm_s,
        p2_rad_s=p2_rad_s,
    )
    params["has_observer"] = observer is not None
    params["observer_on_estimate"] = [m == "estimated" and estimator is not None for m in models]
    if resonator is not None:
        params["resonator"] = resonator
    if observer is not None:
        params["observer"] = observer[0]
    return params, init_states(params, state)


def _kind_records(kind: str):  # noqa: ANN202
    adaptive = kind in ("adaptive_pi", "dob_adaptive_pi")
    observed = kind in ("dob_pi", "dob_adaptive_pi")

    def build(params, nominal, control_period_s, safe_override, design=None):  # noqa: ANN001, ANN202
        common = pi_arguments(params, nominal, control_period_s)
        delays = [dead_time_periods(n, control_period_s) for n in nominal]
        programmed = np.array([p.programmed_feed_mm_min for p in params])
        a = np.array([n.bandwidth_rad_s for n in nominal])
        k2 = np.array([n.k2_N_min_per_mm_s for n in nominal])
        p2 = np.array([n.p2_rad_s for n in nominal])
        estimator = None
        if adaptive:
            estimator = gest.estimator_records(
                [p.group(gest.EstimatorOptions) for p in params],
                a, k2, p2, delays, common["reference_force_N"], programmed, control_period_s,
                design=design,
            )
        observer = None
        models = ["nominal"] * len(params)
        if observed:
            opts = [p.group(dob.ObserverOptions) for p in params]
            observer = dob.observer_records(
                [o.q_polynomials() for o in opts],
                delays,
                control_period_s,
                [np.inf if o.dob_disturbance_limit_mm_min is None
                 else o.dob_disturbance_limit_mm_min for o in opts],
                [o.dob_sensor_cutoff_hz for o in opts],
            )
            if adaptive:
                models = [o.dob_model for o in opts]
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
            resonator=resonator_records(
                [p.group(ResonantOptions) for p in params], control_period_s
            ),
        )

    def loop(spec: LoopSpec, params, nominal) -> LoopSpec:  # noqa: ANN001
        refuse_resonant(params)
        gains = resolved_gains(params, nominal, spec.control_period_s)
        spec = spec.replace(kp_per_N=gains.kp_per_N, ki_per_N_s=gains.ki_per_N_s)
        if adaptive:  # a converged estimate: the gains rescaled to the plant
            kp, ki = adaptive_pi_gains(
                spec.kp_per_N, spec.ki_per_N_s, spec.nominal_k2_N_min_per_mm_s,
                spec.nominal_p2_rad_s, spec.k2_N_min_per_mm_s, spec.p2_rad_s,
            )
            spec = spec.replace(kp_per_N=kp, ki_per_N_s=ki)
        if observed:
            opts = params.group(dob.ObserverOptions)
            spec = spec.replace(
                dob_tau_s=opts.dob_tau_s,
                dob_q_numerator=tuple(float(a) for a in opts.dob_q_numerator),
                dob_q_order=int(opts.dob_q_order),
                dob_sensor_cutoff_hz=float(opts.dob_sensor_cutoff_hz),
            )
            if adaptive and opts.dob_model == "estimated":  # inverts the (converged) estimate
                spec = spec.replace(
                    nominal_k2_N_min_per_mm_s=spec.k2_N_min_per_mm_s,
                    nominal_p2_rad_s=spec.p2_rad_s,
                )
        return spec

    return build, loop


_DOCS = {
    "adaptive_pi": "PI re-designed every period from the online K2, p2 estimate",
    "dob_pi": "fixed PI around a Q-filter disturbance observer on the nominal plant",
    "dob_adaptive_pi": "adaptive PI around a disturbance observer on the estimated model",
}
for _name, _doc in _DOCS.items():
    _build, _loop = _kind_records(_name)
    _groups = [PIDesignOptions, ResonantOptions]
    if "adaptive" in _name:
        _groups.append(gest.EstimatorOptions)
    if "dob" in _name:
        _groups.append(dob.ObserverOptions)
    register_controller(
        ControllerKind(
            name=_name,
            doc=_doc,
            options=tuple(_groups),
            records=_build,
            linear_loop=_loop,
            tunables=("kp_per_N", "ki_per_N_s") + (("dob_tau_s",) if "dob" in _name else ()),
            delays_by_nominal_dead_time=True,
            uses_design_set="adaptive" in _name,
        )
    )


__all__ = ["DIAGNOSTIC_NAMES", "ROBUST", "robust_records"]
