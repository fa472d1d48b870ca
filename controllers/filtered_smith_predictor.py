"""Filtered Smith predictor: a dead-time compensator built on the disturbance observer idea.

Structure (Normey-Rico & Camacho, *Control of Dead-time Processes*, Springer 2007, ch. 7:
the filtered Smith predictor, FSP).  The primary controller ``C`` (a PI on the override)
acts on the *predicted* force, the force the delay-free model ``G_m`` expects now, corrected
by the filtered prediction error of the delayed model:

.. math:: y_p = G_m u + F_r\\,(y_m - G_m e^{-L_n s} u), \\qquad u = C (r - y_p)

with ``G_m = a K2 / ((s + a)(s - p2))`` (Eq. 9 without its dead time; times the sensor's
low-pass ``1 / (1 + s / w_s)`` when ``fsp_sensor_cutoff_hz > 0``), ``L_n`` the nominal dead
time and ``F_r`` the robustness filter (unit DC gain, so a constant disturbance or model
error is removed without offset).  ``y_m - G_m e^{-L_n s} u`` is what a disturbance observer
estimates at the plant output; ``F_r = 1`` is the plain Smith predictor.  For ``P = G_m
e^{-L_n s}`` and no disturbance the prediction error is zero and the loop is the delay-free
loop ``C G_m / (1 + C G_m)`` followed by the dead time.  With ``P = k G_m e^{-L s}`` the
characteristic equation is ``1 + C G_m [1 + F_r (k e^{-L s} - e^{-L_n s})] = 0``;
``F_r`` trades disturbance rejection (fast ``F_r``) for robustness to the gain and delay
error (slow ``F_r``).

Discrete law at the control period ``T_c`` (instant ``k``, measured force ``y[k]``):

* the model ``x' = A x + B u`` on physical states (feed velocity ``v`` [mm/min], force ``f``
  [N], filtered force ``z`` [N]) is discretised with a zero-order hold (the command is held,
  so the model's samples are exact), by :func:`model_matrices` (compiled, also used when
  the adaptive kind re-writes the model from the estimate: the states keep their meaning);
* ``y0[k]``: the model's (measured) force; ``e_p[k] = y[k] - y0[k - N]`` with ``N = L_n / T_c``
  whole periods (a ring buffer of ``y0``);
* ``F_r``: ``e_f[k] = beta e_f[k-1] + (1 - beta) e_p[k]``, ``beta = exp(-T_c / T_r)``
  (``T_r`` = ``fsp_filter_time_constant_s``; 0: ``beta = 0``, ``F_r = 1``), the first-order
  low-pass discretised as the force sensor's is;
* ``y_p[k] = y0[k] + e_f[k]``; the override PI (:func:`controllers.adaptive_pi.pi_law`,
  clamping anti-windup) on ``r - y_p[k]``; ``u[k]`` = override x programmed feed advances
  the model.

PI design for the delay-free model (rule of :mod:`controllers.pi_design` with ``L = 0``).
The zero cancels the model pole, ``ki = kp (-p2n)``; the loop ``K_c a K2n e^{-s T_c / 2} /
(s (s + a)(1 + s / w_s))`` gets the phase margin ``design_phase_margin_deg`` at the crossover
``w_c`` solving ``pi/2 - atan(w_c / a) - atan(w_c / w_s) - w_c T_c / 2 = phi_m`` (no
``atan`` term without a modelled sensor), and ``K_c = w_c sqrt(w_c^2 + a^2) sqrt(1 +
(w_c / w_s)^2) / (a K2n)``; ``kp = K_c / F``.  Given ``kp_per_N`` and ``ki_per_N_s`` are used
as they are.  ``fsp_adaptive_pi`` rescales the gains from the online ``K2, p2`` estimate as
``adaptive_pi`` does (the crossover of this rule depends on neither) and re-writes ``G_m``
from it.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import delay_size, init_states, jit, record, register_element
from acc.engine.roots import brentq
from controllers import gain_estimator as gest
from controllers.adaptive_pi import (
    adaptive_pi_gains,
    bumpless_gain,
    bumpless_start,
    pi_law,
    set_override_pi_fields,
)
from controllers.linear_loop import LoopSpec
from controllers.pi_design import PIDesignOptions, PIGains
from controllers.registry import (
    ControllerKind,
    ControllerParams,
    dead_time_periods,
    register_controller,
)
from plants.nominal_plant import NominalPlant


@dataclass(frozen=True)
class PredictorOptions:
    """``[controller]`` options of the Smith-predictor kinds.

    Attributes
    ----------
    fsp_filter_time_constant_s : float
        Time constant ``T_r`` of the robustness filter ``F_r = 1 / (T_r s + 1)`` [s], >= 0
        (0: the plain Smith predictor).
    fsp_sensor_cutoff_hz : float
        Sensor low-pass the delay-free model includes [Hz], >= 0 (0: none).  Set it to
        ``sensor.lowpass_cutoff_hz``.
    """

    fsp_filter_time_constant_s: float = 0.2
    fsp_sensor_cutoff_hz: float = 0.0

    def __post_init__(self) -> None:
        t = self.fsp_filter_time_constant_s
        if not (t >= 0 and math.isfinite(t)):
            raise ValueError(f"fsp_filter_time_constant_s must be >= 0, got {t}")
        c = self.fsp_sensor_cutoff_hz
        if not (c >= 0 and math.isfinite(c)):
            raise ValueError(f"fsp_sensor_cutoff_hz must be >= 0 (0: none), got {c}")


def design_delay_free_pi(
    plant: NominalPlant,
    programmed_feed_mm_min: float,
    control_period_s: float,
    phase_margin_deg: float = 60.0,
    sensor_cutoff_hz: float = 0.0,
) -> PIGains:
    """PI gains for a phase margin on the delay-free model (rule in the module docstring).

    Parameters
    ----------
    plant : NominalPlant
        Design model (Eq. 9); its dead time is ignored.
    programmed_feed_mm_min : float
        ``F`` [mm/min], > 0.
    control_period_s : float
        ``T_c`` [s] (the hold's half period enters the rule).
    phase_margin_deg : float
        In (0, 90) [deg].
    sensor_cutoff_hz : float
        Sensor low-pass of the model [Hz] (0: none).

    Returns
    -------
    PIGains
    """
    if not 0.0 < phase_margin_deg < 90.0:
        raise ValueError(f"phase margin must be in (0, 90) deg, got {phase_margin_deg}")
    if not programmed_feed_mm_min > 0:
        raise ValueError("programmed feed must be > 0 mm/min")
    a = plant.bandwidth_rad_s
    ws = 2.0 * math.pi * sensor_cutoff_hz
    half = control_period_s / 2.0
    pm = math.radians(phase_margin_deg)

    def excess(w: float) -> float:
        lag = math.atan(w / ws) if ws > 0 else 0.0
        return math.pi / 2.0 - math.atan(w / a) - lag - half * w - pm

    hi = a * math.tan(math.pi / 2.0 - pm)  # the drive's lag alone reaches the margin here
    wc = brentq(excess, 1e-9, hi, xtol=1e-14, rtol=1e-14)
    sensor = math.hypot(1.0, wc / ws) if ws > 0 else 1.0
    kc = wc * math.hypot(wc, a) * sensor / (a * plant.k2_N_min_per_mm_s)
    kp = kc / programmed_feed_mm_min
    return PIGains(kp, kp * (-plant.p2_rad_s), wc, phase_margin_deg)


@functools.lru_cache(maxsize=1024)
def _designed(
    nominal: NominalPlant, feed: float, period: float, margin: float, sensor: float
) -> PIGains:
    return design_delay_free_pi(nominal, feed, period, margin, sensor)


def predictor_gains(
    params: ControllerParams, nominal: NominalPlant, control_period_s: float
) -> PIGains:
    """The PI gains a run uses: the scenario's, or designed on the delay-free model."""
    opts = params.group(PIDesignOptions)
    if opts.kp_per_N is not None and opts.ki_per_N_s is not None:
        return PIGains(opts.kp_per_N, opts.ki_per_N_s, math.nan, math.nan)
    return _designed(
        nominal,
        params.programmed_feed_mm_min,
        control_period_s,
        opts.design_phase_margin_deg,
        params.group(PredictorOptions).fsp_sensor_cutoff_hz,
    )


# --- compiled model discretisation ---------------------------------------------------------
#: Model states: feed velocity, force, filtered force.
_N_STATES = 3


#: Matrices of :func:`model_matrices`'s workspace: the augmented ``M`` (scaled in place),
#: then :func:`_expm`'s sum, series term and product.
_WORK = 4


@jit
def _matmul(X: np.ndarray, Y: np.ndarray, Z: np.ndarray) -> None:
    """``Z = X Y`` of the model's augmented matrices (``Z`` neither ``X`` nor ``Y``)."""
    n = _N_STATES + 1  # a constant: the loops unrolled and vectorised
    for i in range(n):
        for j in range(n):
            Z[i, j] = 0.0
    for i in range(n):
        for k in range(n):
            x = X[i, k]
            if x != 0.0:
                for j in range(n):
                    Z[i, j] += x * Y[k, j]


@jit
def _expm(M: np.ndarray, work: np.ndarray) -> np.ndarray:
    """``exp(M)`` of the model's augmented matrix (4, 4): scaling to a norm <= 1/2, a
    20-term Taylor series, squaring back (truncation below 1e-19 of the scaled series).
    ``M`` is scaled in place; ``work``: three more matrices of that size, shape (3, 4, 4);
    the result is ``work[0]``.

    In a workspace rather than arrays of its own: an adaptive predictor re-discretises its
    model every control period, and an allocated array costs an allocation and reference
    counts changed by x86 ``lock`` instructions (a 4x4 exponential made about 30 of each).
    """
    n = _N_STATES + 1  # M's size, a constant: the loops unrolled and vectorised
    norm = 0.0
    for i in range(n):
        row = 0.0
        for j in range(n):
            row += abs(M[i, j])
        norm = max(norm, row)
    squarings = 0
    while norm > 0.5:
        norm *= 0.5
        squarings += 1
    # element loops rather than array expressions: the same operations, compiled in a
    # fraction of the time (each numpy expression compiles a kernel of its own)
    scale = 2.0**squarings
    E = work[0]
    term = work[1]
    product = work[2]
    for i in range(n):
        for j in range(n):
            E[i, j] = 0.0
            term[i, j] = 0.0
        E[i, i] = 1.0
        term[i, i] = 1.0
    for i in range(n):  # M scaled, kept in M's place
        for j in range(n):
            M[i, j] = M[i, j] / scale
    for k in range(1, 21):
        _matmul(term, M, product)
        for i in range(n):
            for j in range(n):
                term[i, j] = product[i, j] / k
                E[i, j] += term[i, j]
    for _ in range(squarings):
        _matmul(E, E, product)
        for i in range(n):
            for j in range(n):
                E[i, j] = product[i, j]
    return E


@jit
def model_matrices(
    bandwidth_rad_s: float,
    k2_N_min_per_mm_s: float,
    p2_rad_s: float,
    sensor_cutoff_hz: float,
    control_period_s: float,
    Ad: np.ndarray,
    Bd: np.ndarray,
    work: np.ndarray,
) -> None:
    """Zero-order-hold discretisation of the delay-free model into ``Ad`` (3, 3), ``Bd`` (3,).

    States ``(v, f, z)``: ``v' = a (u - v)``, ``f' = p2 f + K2 v``, ``z' = w_s (f - z)``
    (``z`` stays 0 without a sensor model, ``w_s = 0``).  ``work``: a workspace of shape
    (:data:`_WORK`, 4, 4).
    """
    ws = 2.0 * np.pi * sensor_cutoff_hz
    T = control_period_s
    M = work[0]
    for i in range(_N_STATES + 1):
        for j in range(_N_STATES + 1):
            M[i, j] = 0.0
    M[0, 0] = -bandwidth_rad_s * T
    M[0, 3] = bandwidth_rad_s * T
    M[1, 0] = k2_N_min_per_mm_s * T
    M[1, 1] = p2_rad_s * T
    M[2, 1] = ws * T
    M[2, 2] = -ws * T
    E = _expm(M, work[1:4])
    for i in range(_N_STATES):
        for j in range(_N_STATES):
            Ad[i, j] = E[i, j]
        Bd[i] = E[i, _N_STATES]


def _dtypes(estimator_ring: int = 16, ring: int = 16) -> tuple[np.dtype, np.dtype]:
    est_p, est_s = gest.PROCESS_GAIN.dtypes(ring=estimator_ring)
    params = record(
        "controller.fsp",
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
            ("sensor_cutoff_hz", "f8"),  # of the model; 0: none
            ("filter_pole", "f8"),  # beta = exp(-T_c / T_r)
            ("delay_periods", "i8"),
            ("ring_mask", "i8"),
            ("control_period_s", "f8"),
            ("clamping", "b1"),
            ("has_estimator", "b1"),
            ("estimator", est_p),
        ],
    )
    state = record(
        "controller.fsp",
        [
            ("integral", "f8"),
            ("last_kp_per_N", "f8"),  # the proportional gain of the last period (bumpless)
            ("model", "f8", (_N_STATES,)),
            ("next_model", "f8", (_N_STATES,)),
            ("model_A", "f8", (_N_STATES, _N_STATES)),
            ("model_B", "f8", (_N_STATES,)),
            ("model_work", "f8", (_WORK, _N_STATES + 1, _N_STATES + 1)),  # model_matrices's
            ("filtered_error_N", "f8"),
            ("head", "i8"),
            ("history_N", "f8", (ring,)),
            ("estimator", est_s),
        ],
    )
    return params, state


@jit
def fsp_init(p, s) -> None:  # noqa: ANN001
    """Integrator at the initial override (with the safe start: the PI's first output),
    estimator at its start model, the predictor's model that model, at rest."""
    s.integral = p.initial_override
    s.last_kp_per_N = np.nan
    for i in range(_N_STATES):
        s.model[i] = 0.0
    s.filtered_error_N = 0.0
    s.head = 0
    for i in range(s.history_N.shape[0]):
        s.history_N[i] = 0.0
    k2 = p.k2_N_min_per_mm_s
    p2 = p.p2_rad_s
    if p.has_estimator:  # the model starts where the estimate does (the safe start's plant)
        gest.init(p.estimator, s.estimator)
        k2, p2 = gest.estimates(p.estimator, s.estimator)
        s.integral = bumpless_start(p, p.estimator, s.estimator)
    model_matrices(p.bandwidth_rad_s, k2, p2, p.sensor_cutoff_hz,
                   p.control_period_s, s.model_A, s.model_B, s.model_work)


@jit
def fsp_step(p, s, measured_force_N: float, diagnostics: np.ndarray) -> float:  # noqa: ANN001
    """One control period (module docstring); writes the controller diagnostics (the gains
    and the estimate; ``disturbance_estimate_mm_min`` stays NaN: the predictor's correction
    is a force)."""
    y = measured_force_N
    kp = p.kp_per_N
    ki = p.ki_per_N_s
    k2h = p.k2_N_min_per_mm_s
    p2h = p.p2_rad_s
    updated = 0.0
    if p.has_estimator:
        updated = float(gest.step(p.estimator, s.estimator, y))
        k2h, p2h = gest.estimates(p.estimator, s.estimator)
        kp, ki = adaptive_pi_gains(kp, ki, p.k2_N_min_per_mm_s, p.p2_rad_s, k2h, p2h)
        if updated != 0.0:
            model_matrices(p.bandwidth_rad_s, k2h, p2h, p.sensor_cutoff_hz,
                           p.control_period_s, s.model_A, s.model_B, s.model_work)
    y0 = s.model[2] if p.sensor_cutoff_hz > 0.0 else s.model[1]
    s.history_N[s.head] = y0
    delayed = s.history_N[(s.head - p.delay_periods) & p.ring_mask]
    s.head = (s.head + 1) & p.ring_mask
    beta = p.filter_pole
    s.filtered_error_N = beta * s.filtered_error_N + (1.0 - beta) * (y - delayed)
    predicted = y0 + s.filtered_error_N
    if p.has_estimator:
        s.integral = bumpless_gain(p.estimator, s.integral, s.last_kp_per_N, kp,
                                   p.reference_force_N - predicted)
    s.last_kp_per_N = kp
    s.integral, override = pi_law(
        s.integral,
        p.reference_force_N - predicted,
        kp,
        ki,
        p.control_period_s,
        0.0,
        p.override_min,
        p.override_max,
        p.clamping,
    )
    command = override * p.programmed_feed_mm_min
    if p.has_estimator:
        gest.record_command(p.estimator, s.estimator, command)
    for i in range(_N_STATES):
        acc = s.model_B[i] * command
        for j in range(_N_STATES):
            acc += s.model_A[i, j] * s.model[j]
        s.next_model[i] = acc
    for i in range(_N_STATES):
        s.model[i] = s.next_model[i]
    diagnostics[0] = kp
    diagnostics[1] = ki
    diagnostics[2] = k2h
    diagnostics[3] = p2h
    diagnostics[4] = k2h / (-p2h)
    diagnostics[5] = updated
    return override


FSP = register_element(
    "controller.fsp",
    _dtypes,
    fsp_init,
    fsp_step,
    "filtered Smith predictor (Normey-Rico & Camacho) around a fixed or adaptive PI",
)


def fsp_records(
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
    delay_periods: NDArray,
    filter_time_constant_s: NDArray,
    sensor_cutoff_hz: NDArray,
    control_period_s: float,
    anti_windup: str | Sequence[str] = "clamping",
    estimator: tuple[NDArray, NDArray] | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of filtered Smith predictors.

    Parameters
    ----------
    reference_force_N, kp_per_N, ki_per_N_s, override_min, override_max, initial_override,
    programmed_feed_mm_min : ndarray, shape (runs,)
        As :func:`controllers.pi.pi_records`; ``F`` [mm/min].
    bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s : ndarray, shape (runs,)
        Delay-free model (Eq. 9) [rad/s], [N/(mm/min)/s], [rad/s].
    delay_periods : ndarray of int, shape (runs,)
        Nominal dead time in control periods ``N`` >= 0.
    filter_time_constant_s : ndarray, shape (runs,)
        ``T_r`` [s], >= 0.
    sensor_cutoff_hz : ndarray, shape (runs,)
        The model's sensor low-pass [Hz] (0: none).
    control_period_s : float
    anti_windup : {"clamping", "none"} or sequence of them
    estimator : (params, state) or None
        :func:`controllers.gain_estimator.estimator_records`; present: the gains and the
        model adapt.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs = len(np.atleast_1d(reference_force_N))
    delays = np.broadcast_to(np.asarray(delay_periods), (runs,)).astype(np.int64)
    if np.any(delays < 0):
        raise ValueError("delay_periods must be >= 0")
    tr = np.broadcast_to(np.asarray(filter_time_constant_s, dtype=float), (runs,))
    if np.any(~(tr >= 0)):
        raise ValueError("fsp_filter_time_constant_s must be >= 0")
    sizes = {"ring": delay_size(int(delays.max(initial=0)) + 1)}
    if estimator is not None:
        sizes["estimator_ring"] = estimator[1].dtype["history_mm_min"].shape[0]
    params, state = FSP.records(runs, **sizes)
    set_override_pi_fields(
        params, control_period_s, anti_windup, estimator,
        reference_force_N=reference_force_N, kp_per_N=kp_per_N, ki_per_N_s=ki_per_N_s,
        override_min=override_min, override_max=override_max,
        initial_override=initial_override, programmed_feed_mm_min=programmed_feed_mm_min,
        bandwidth_rad_s=bandwidth_rad_s, k2_N_min_per_mm_s=k2_N_min_per_mm_s,
        p2_rad_s=p2_rad_s, sensor_cutoff_hz=sensor_cutoff_hz,
    )
    with np.errstate(divide="ignore"):
        params["filter_pole"] = np.where(tr > 0, np.exp(-control_period_s / np.where(tr > 0, tr,
                                                                                      1.0)), 0.0)
    params["delay_periods"] = delays
    params["ring_mask"] = state.dtype["history_N"].shape[0] - 1
    return params, init_states(params, state)


def _kind(adaptive: bool):  # noqa: ANN202
    def build(params, nominal, control_period_s, safe_override, design=None):  # noqa: ANN001, ANN202
        gains = [predictor_gains(p, n, control_period_s) for p, n in zip(params, nominal,
                                                                         strict=True)]
        opts = [p.group(PredictorOptions) for p in params]
        delays = [dead_time_periods(n, control_period_s) for n in nominal]
        programmed = np.array([p.programmed_feed_mm_min for p in params])
        reference = np.array([p.reference_force_N for p in params])
        a = np.array([n.bandwidth_rad_s for n in nominal])
        k2 = np.array([n.k2_N_min_per_mm_s for n in nominal])
        p2 = np.array([n.p2_rad_s for n in nominal])
        estimator = None
        if adaptive:
            estimator = gest.estimator_records(
                [p.group(gest.EstimatorOptions) for p in params],
                a, k2, p2, delays, reference, programmed, control_period_s, design=design,
            )
        return fsp_records(
            reference,
            np.array([g.kp_per_N for g in gains]),
            np.array([g.ki_per_N_s for g in gains]),
            np.array([p.override_min for p in params]),
            np.array([p.override_max for p in params]),
            np.array([p.initial_override for p in params]),
            programmed,
            a,
            k2,
            p2,
            np.array(delays),
            np.array([o.fsp_filter_time_constant_s for o in opts]),
            np.array([o.fsp_sensor_cutoff_hz for o in opts]),
            control_period_s,
            anti_windup=[p.anti_windup for p in params],
            estimator=estimator,
        )

    def loop(spec: LoopSpec, params, nominal) -> LoopSpec:  # noqa: ANN001
        gains = predictor_gains(params, nominal, spec.control_period_s)
        opts = params.group(PredictorOptions)
        spec = spec.replace(
            kp_per_N=gains.kp_per_N,
            ki_per_N_s=gains.ki_per_N_s,
            fsp_filter_time_constant_s=float(opts.fsp_filter_time_constant_s),
            fsp_sensor_cutoff_hz=float(opts.fsp_sensor_cutoff_hz),
        )
        if adaptive:  # a converged estimate: gains rescaled, the model is the plant's
            kp, ki = adaptive_pi_gains(
                spec.kp_per_N, spec.ki_per_N_s, spec.nominal_k2_N_min_per_mm_s,
                spec.nominal_p2_rad_s, spec.k2_N_min_per_mm_s, spec.p2_rad_s,
            )
            spec = spec.replace(
                kp_per_N=kp,
                ki_per_N_s=ki,
                nominal_k2_N_min_per_mm_s=spec.k2_N_min_per_mm_s,
                nominal_p2_rad_s=spec.p2_rad_s,
            )
        return spec

    return build, loop


_fsp_build, _fsp_loop = _kind(adaptive=False)
FSP_PI = register_controller(
    ControllerKind(
        name="fsp_pi",
        doc="filtered Smith predictor: PI designed on the delay-free model, robustness filter",
        options=(PIDesignOptions, PredictorOptions),
        records=_fsp_build,
        linear_loop=_fsp_loop,
        tunables=("kp_per_N", "ki_per_N_s", "fsp_filter_time_constant_s"),
        delays_by_nominal_dead_time=True,
    )
)
_afsp_build, _afsp_loop = _kind(adaptive=True)
FSP_ADAPTIVE_PI = register_controller(
    ControllerKind(
        name="fsp_adaptive_pi",
        doc="filtered Smith predictor with the delay-free model and PI from the online estimate",
        options=(PIDesignOptions, gest.EstimatorOptions, PredictorOptions),
        records=_afsp_build,
        linear_loop=_afsp_loop,
        tunables=("kp_per_N", "ki_per_N_s", "fsp_filter_time_constant_s"),
        delays_by_nominal_dead_time=True,
        uses_design_set=True,
    )
)


__all__ = [
    "FSP",
    "FSP_ADAPTIVE_PI",
    "FSP_PI",
    "PredictorOptions",
    "design_delay_free_pi",
    "fsp_records",
    "model_matrices",
    "predictor_gains",
]
