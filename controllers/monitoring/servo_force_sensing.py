"""The feed drive as a force sensor: Peng's current sensor and force estimators (seed 000, Ch. 3).

**Current sensor (3.41)-(3.52), spec M0-8.**  With the digital filter replaced by its Tustin
equivalent ``D(s) = K'_p K_d (s + a')/(s + b')`` (3.44), the armature current of the closed
position loop is driven by the reference ``X_r`` [counts] and the cutting torque ``T_c``
[N m]::

    I_a(s) = (b3 s^3 + b2 s^2 + b1 s)/Delta X_r(s) + (g2 s^2 + g1 s + g0)/Delta T_c(s)
    Delta = a4 s^4 + a3 s^3 + a2 s^2 + a1 s + a0,   R' = R_a + K_v K_a,
    K_b' = K_b + K_v K_I T_g H_g,   K = K_d S_g K_I K_v K'_p
    b3 = J_e K,  b2 = (J_e a' + B) K,  b1 = a' B K
    a4 = L_a J_e,  a3 = J_e R' + B L_a + b' L_a J_e
    a2 = b'(J_e R' + B L_a) + B R' + K_t K_b'                (corrected, spec O-5)
    a1 = b'(B R' + K_t K_b') + K_e K K_t                      (corrected)
    a0 = K_e K K_t a'
    g2 = K_b',  g1 = b' K_b' + K_e K,  g0 = K_e K a'

Steady values (3.53)-(3.58): a ramp ``X_r = f_c t`` gives ``I_ar = f_c B / (K_e K_t)``, a
torque step ``I_ac = T_c / K_t``.  :func:`closed_loop_state_space` builds the same loop as a
state-space model (plant (2.24) and the Tustin filter) so the formulas can be checked
against python-control's conversion.

**Inverse-model estimator (3.39)-(3.40), spec A0-3.**  The exact ZOH velocity loop
``x(k+1) = Phi_v x(k) + H_v u(k)`` (x = [I_a, W], u = [V_c, T_c]) inverted one sample late::

    u(k-1) = H_v^-1 [x(k) - Phi_v x(k-1)]
    T_c(k-1) = c1 I_a(k) + c2 W(k) + c3 I_a(k-1) + c4 W(k-1),   F_c = T_c / k_FT

with ``c1 + c3 = K_t`` and ``c2 + c4 = -B`` (steady state of the continuous model).  ``B``
depends on the feed (``B = K_c / f_c``, M0-10), so :func:`inverse_model_coefficient_table`
tabulates the four coefficients over feeds and :func:`interpolate_coefficients` picks a
feed's.  The estimator amplifies noise roughly as ``1/T``; an optional first-order low-pass
(exact discretisation, ``exp(-2 pi f_c T)``) smooths its output, which for this linear
estimator equals pre-filtering the current and speed with the same filter (Peng used
50 Hz, L734) once the filter's initial transient has passed.

**Steady-state estimator (3.60)-(3.62).**  ``T_c = K_t I_a - T_tare``, with the tare torque
``K_c / K_e`` (model; ``K_c`` [N m count/rad] is the constant of ``B = K_c/f_c``),
``K_t I_f`` (measured tare current, 2.5 A at L882) or ``B W`` with the measured speed
(``"viscous"``: the steady state (3.36) of a linear-friction axis; at the commanded feed it
equals (3.61)'s ``f_c B / K_e``); valid after the current transient (``settle_time_s``, the
thesis waits 50 ms).  From (3.35) its error is the inertia torque ``J_e dW/dt``.

Both estimators are compiled elements (``estimator.peng_inverse_model``,
``estimator.peng_steady_state``) with the slot contract of the existing current estimator:
``step(p, s, current_A, speed_rad_s) -> (torque_Nm, force_N)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, record, register_element
from controllers.axis.lead_lag import LeadLagParams
from plants.axis.servo_axis import ServoAxisParams

#: Tare-torque models of the steady-state estimator.
TARE_MODELS = ("speed_dependent", "measured_current", "viscous")


# --- current sensor ----------------------------------------------------------------------
def current_sensor_coefficients(
    axis: ServoAxisParams, controller: LeadLagParams, period_s: float
) -> dict[str, float]:
    """Coefficients of (3.52) with the corrected ``alpha_2``, ``alpha_1`` (spec O-5).

    Parameters
    ----------
    axis : ServoAxisParams
    controller : LeadLagParams
        ``K_p, a, b, K_d``; its Tustin equivalent at ``period_s`` is used (3.44).
    period_s : float
        Control period ``T`` [s].

    Returns
    -------
    dict
        ``beta3, beta2, beta1, alpha4 ... alpha0, gamma2, gamma1, gamma0`` (SI, counts).
    """
    kp_t, a_t, b_t = controller.tustin_equivalent(period_s)
    la, je, bv, kt = (axis.armature_inductance_H, axis.inertia_kg_m2,
                      axis.viscous_friction_Nm_s_rad, axis.torque_constant_Nm_A)
    r1, kb1, ke = axis.loop_resistance_ohm, axis.loop_back_emf_V_s_rad, axis.encoder_counts_per_rad
    k = controller.dac_gain_V_per_count * axis.command_to_voltage_V_V * kp_t
    return {
        "beta3": je * k, "beta2": (je * a_t + bv) * k, "beta1": a_t * bv * k,
        "alpha4": la * je,
        "alpha3": je * r1 + bv * la + b_t * la * je,
        "alpha2": b_t * (je * r1 + bv * la) + bv * r1 + kt * kb1,
        "alpha1": b_t * (bv * r1 + kt * kb1) + ke * k * kt,
        "alpha0": ke * k * kt * a_t,
        "gamma2": kb1, "gamma1": b_t * kb1 + ke * k, "gamma0": ke * k * a_t,
    }


def current_sensor_tf(
    axis: ServoAxisParams, controller: LeadLagParams, period_s: float, input_name: str = "torque"
) -> Any:
    """``I_a/T_c`` [A/(N m)] (``input_name="torque"``) or ``I_a/X_r`` [A/count]
    (``"reference"``) of (3.52) as a python-control ``TransferFunction``."""
    import control

    c = current_sensor_coefficients(axis, controller, period_s)
    den = [c["alpha4"], c["alpha3"], c["alpha2"], c["alpha1"], c["alpha0"]]
    if input_name == "torque":
        num = [c["gamma2"], c["gamma1"], c["gamma0"]]
        names = ("load_torque_Nm", "current_A")
    elif input_name == "reference":
        num = [c["beta3"], c["beta2"], c["beta1"], 0.0]
        names = ("reference_counts", "current_A")
    else:
        raise ValueError(f"input_name must be 'torque' or 'reference', got {input_name!r}")
    return control.tf(num, den, inputs=[names[0]], outputs=[names[1]], name="current_sensor")


def closed_loop_state_space(
    axis: ServoAxisParams, controller: LeadLagParams, period_s: float
) -> Any:
    """Continuous closed position loop with the Tustin filter, as python-control ``ss``.

    States ``[I_a, W, X_a (counts), z]`` (``z' = -b' z + E``), inputs ``[X_r (counts),
    T_c (N m)]``, output ``I_a`` [A]; ``V_c = K'_p K_d [E + (a' - b') z]``, ``E = X_r - X_a``.
    """
    import control

    kp_t, a_t, b_t = controller.tustin_equivalent(period_s)
    k = kp_t * controller.dac_gain_V_per_count
    A_c, B_c = axis.continuous_matrices("counts")
    bv = B_c[:, 0]
    A = np.zeros((4, 4))
    A[:3, :3] = A_c
    A[:3, 2] -= bv * k  # V_c = k (X_r - X_a) + k (a' - b') z
    A[:3, 3] = bv * k * (a_t - b_t)
    A[3, 2] = -1.0
    A[3, 3] = -b_t
    B = np.zeros((4, 2))
    B[:3, 0] = bv * k
    B[:3, 1] = B_c[:, 1]
    B[3, 0] = 1.0
    C = np.array([[1.0, 0.0, 0.0, 0.0]])
    return control.ss(A, B, C, np.zeros((1, 2)), inputs=["reference_counts", "load_torque_Nm"],
                      outputs=["current_A"], name="position_loop_current")


def steady_currents_A(
    axis: ServoAxisParams, feed_counts_s: float, load_torque_Nm: float
) -> tuple[float, float]:
    """``(I_ar, I_ac)``: steady current of a ramp ``f_c`` [counts/s], ``f_c B/(K_e K_t)``
    (3.54), and of a torque step, ``T_c / K_t`` (3.58) [A]."""
    kt = axis.torque_constant_Nm_A
    return (feed_counts_s * axis.viscous_friction_Nm_s_rad / (axis.encoder_counts_per_rad * kt),
            load_torque_Nm / kt)


def gain_bandwidth_rad_s(tf: Any, drop_dB: float = -3.0) -> float:
    """First frequency [rad/s] where ``|tf(j w)|`` falls ``|drop_dB|`` below its DC gain,
    by a logarithmic scan and bisection (the current sensor's bandwidth for ``I_a/T_c``)."""
    num = np.asarray(tf.num[0][0], float)
    den = np.asarray(tf.den[0][0], float)
    dc = abs(np.polyval(num, 0.0) / np.polyval(den, 0.0))
    target = dc * 10.0 ** (drop_dB / 20.0)

    def excess(w: float) -> float:
        return abs(np.polyval(num, 1j * w) / np.polyval(den, 1j * w)) - target

    grid = np.logspace(-3, 7, 2001)
    vals = np.array([excess(w) for w in grid])
    below = np.flatnonzero(vals < 0)
    if below.size == 0:
        return math.inf
    i = below[0]
    lo, hi = (grid[i - 1], grid[i]) if i > 0 else (0.0, grid[0])
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


# --- inverse-model estimator -------------------------------------------------------------
def inverse_model_coefficients(axis: Any, step_s: float) -> NDArray[np.float64]:
    """``(c1, c2, c3, c4)`` of (3.40) from the exact ZOH of the velocity loop.

    Parameters
    ----------
    axis : VelocityLoopParams or ServoAxisParams
        Its ``B`` is used as it is (see :func:`inverse_model_coefficient_table`).
    step_s : float
        Sample period ``T`` [s].

    Returns
    -------
    ndarray, shape (4,)
        [N m/A, N m s/rad, N m/A, N m s/rad].
    """
    phi, h = axis.discretise(step_s)
    m = np.linalg.inv(h)
    row = m[1]
    prev = -(m @ phi)[1]
    return np.array([row[0], row[1], prev[0], prev[1]])


def inverse_model_coefficient_table(
    axis: ServoAxisParams, step_s: float, feeds_mm_s: ArrayLike
) -> NDArray[np.float64]:
    """Coefficients over feed (L734: "four coefficients" per speed), ``B`` from the axis's
    friction model at each feed.

    Returns
    -------
    ndarray, shape (n_feeds, 4)
    """
    feeds = np.atleast_1d(np.asarray(feeds_mm_s, float))
    return np.array([
        inverse_model_coefficients(axis.with_effective_friction(f).velocity_loop, step_s)
        for f in feeds
    ])


def interpolate_coefficients(
    table: ArrayLike, feeds_mm_s: ArrayLike, feed_mm_s: float
) -> NDArray[np.float64]:
    """Coefficients at a feed [mm/s], linear in feed between table rows (clamped)."""
    t = np.asarray(table, float)
    f = np.asarray(feeds_mm_s, float)
    return np.array([np.interp(feed_mm_s, f, t[:, i]) for i in range(4)])


@dataclass(frozen=True)
class ServoForceEstimatorParams:
    """Settings of Peng's force estimators.

    Attributes
    ----------
    lowpass_cutoff_Hz : float
        First-order low-pass on the estimate [Hz]; 0 = none (Peng: 50).
    settle_time_s : float
        Steady-state estimator: output 0 until this time [s] (thesis: 0.05).
    tare_model : {"speed_dependent", "measured_current", "viscous"}
        Steady-state tare torque ``K_c / K_e``, ``K_t I_f`` or ``B W`` (measured speed).
    tare_current_A : float
        ``I_f`` [A] (2.5, L882).
    """

    lowpass_cutoff_Hz: float = 0.0
    settle_time_s: float = 0.0
    tare_model: str = "speed_dependent"
    tare_current_A: float = 2.5

    def __post_init__(self) -> None:
        for name in ("lowpass_cutoff_Hz", "settle_time_s", "tare_current_A"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {v!r}")
        if self.tare_model not in TARE_MODELS:
            raise ValueError(f"tare_model must be one of {TARE_MODELS}, got {self.tare_model!r}")

    def lowpass_pole(self, step_s: float) -> float:
        """``exp(-2 pi f_c T)`` of the exact discrete first-order low-pass (0 = none)."""
        return 0.0 if self.lowpass_cutoff_Hz == 0 else math.exp(
            -2.0 * math.pi * self.lowpass_cutoff_Hz * step_s)


def _inverse_dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "estimator.peng_inverse_model",
        [("coefficients", "f8", (4,)), ("force_to_torque_m", "f8"), ("lowpass_pole", "f8")],
    )
    state = record(
        "estimator.peng_inverse_model",
        [("current_A", "f8"), ("speed_rad_s", "f8"), ("torque_Nm", "f8"), ("begun", "b1")],
    )
    return params, state


@jit
def inverse_init(p, s) -> None:  # noqa: ANN001
    """No previous sample yet."""
    s.current_A = 0.0
    s.speed_rad_s = 0.0
    s.torque_Nm = 0.0
    s.begun = False


@jit
def inverse_step(p, s, current_A: float, speed_rad_s: float) -> tuple[float, float]:  # noqa: ANN001
    """Take ``(I_a(k), W(k))``; return ``(T_c(k-1) [N m], F_c(k-1) [N])`` (low-passed when
    set; 0 at the first sample)."""
    c = p.coefficients
    raw = 0.0
    if s.begun:
        raw = c[0] * current_A + c[1] * speed_rad_s + c[2] * s.current_A + c[3] * s.speed_rad_s
        s.torque_Nm = p.lowpass_pole * s.torque_Nm + (1.0 - p.lowpass_pole) * raw
    s.begun = True
    s.current_A = current_A
    s.speed_rad_s = speed_rad_s
    return s.torque_Nm, s.torque_Nm / p.force_to_torque_m


INVERSE_MODEL = register_element(
    "estimator.peng_inverse_model",
    _inverse_dtypes,
    inverse_init,
    inverse_step,
    "cutting torque and feed force from I_a and W by the inverted ZOH velocity loop "
    "(Peng 3.39-3.40), one sample late",
)


def inverse_model_records(
    axes: Sequence[ServoAxisParams], step_s: float,
    settings: ServoForceEstimatorParams | Sequence[ServoForceEstimatorParams] = (
        ServoForceEstimatorParams()),
    commanded_feed_mm_s: ArrayLike | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of inverse-model estimators.

    Parameters
    ----------
    axes : sequence of ServoAxisParams, length runs
    step_s : float
        Sample period [s].
    settings : ServoForceEstimatorParams or sequence (one per run)
    commanded_feed_mm_s : array_like, shape (runs,), optional
        Feed for the speed-dependent ``B`` (its coefficients, L734).
    """
    axes = list(axes)
    n = len(axes)
    sets = [settings] * n if isinstance(settings, ServoForceEstimatorParams) else list(settings)
    feeds = [None] * n if commanded_feed_mm_s is None else list(
        np.broadcast_to(np.asarray(commanded_feed_mm_s, float), (n,)))
    params, state = INVERSE_MODEL.records(n)
    for r, (axis, st, f) in enumerate(zip(axes, sets, feeds, strict=True)):
        params[r]["coefficients"] = inverse_model_coefficients(
            axis.with_effective_friction(f).velocity_loop, step_s)
        params[r]["force_to_torque_m"] = axis.force_to_torque_m
        params[r]["lowpass_pole"] = st.lowpass_pole(step_s)
    return params, init_states(params, state)


def _steady_dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "estimator.peng_steady_state",
        [("torque_constant_Nm_A", "f8"), ("tare_torque_Nm", "f8"),
         ("tare_viscous_Nm_s_rad", "f8"), ("force_to_torque_m", "f8"),
         ("lowpass_pole", "f8"), ("settle_steps", "i8")],
    )
    state = record("estimator.peng_steady_state", [("torque_Nm", "f8"), ("k", "i8")])
    return params, state


@jit
def steady_init(p, s) -> None:  # noqa: ANN001
    """At the first sample, nothing estimated."""
    s.torque_Nm = 0.0
    s.k = 0


@jit
def steady_step(p, s, current_A: float, speed_rad_s: float) -> tuple[float, float]:  # noqa: ANN001
    """``T_c = K_t I_a - T_tare`` [N m] and ``F_c`` [N] at this sample (0 while settling);
    ``T_tare = T_0 + B_tare W`` (``B_tare`` = 0 unless the tare model is ``"viscous"``)."""
    raw = (p.torque_constant_Nm_A * current_A - p.tare_torque_Nm
           - p.tare_viscous_Nm_s_rad * speed_rad_s)
    if s.k >= p.settle_steps:
        s.torque_Nm = p.lowpass_pole * s.torque_Nm + (1.0 - p.lowpass_pole) * raw
    s.k += 1
    return s.torque_Nm, s.torque_Nm / p.force_to_torque_m


STEADY_STATE = register_element(
    "estimator.peng_steady_state",
    _steady_dtypes,
    steady_init,
    steady_step,
    "cutting torque and feed force from the steady current minus the tare (Peng 3.60-3.62)",
)


def tare_torque_Nm(axis: ServoAxisParams, settings: ServoForceEstimatorParams) -> float:
    """Constant part of the tare: ``K_c / K_e`` (``"speed_dependent"``, 3.62), ``K_t I_f``
    (``"measured_current"``) or 0 (``"viscous"``, whose tare ``B W`` follows the speed)
    [N m]."""
    if settings.tare_model == "viscous":
        return 0.0
    if settings.tare_model == "measured_current":
        return axis.torque_constant_Nm_A * settings.tare_current_A
    return axis.speed_dependent_constant_Nm_count_rad / axis.encoder_counts_per_rad


def steady_state_records(
    axes: Sequence[ServoAxisParams], step_s: float,
    settings: ServoForceEstimatorParams | Sequence[ServoForceEstimatorParams] = (
        ServoForceEstimatorParams()),
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of steady-state estimators (one axis per run)."""
    axes = list(axes)
    n = len(axes)
    sets = [settings] * n if isinstance(settings, ServoForceEstimatorParams) else list(settings)
    params, state = STEADY_STATE.records(n)
    for r, (axis, st) in enumerate(zip(axes, sets, strict=True)):
        params[r]["torque_constant_Nm_A"] = axis.torque_constant_Nm_A
        params[r]["tare_torque_Nm"] = tare_torque_Nm(axis, st)
        params[r]["tare_viscous_Nm_s_rad"] = (
            axis.viscous_friction_Nm_s_rad if st.tare_model == "viscous" else 0.0)
        params[r]["force_to_torque_m"] = axis.force_to_torque_m
        params[r]["lowpass_pole"] = st.lowpass_pole(step_s)
        params[r]["settle_steps"] = int(round(st.settle_time_s / step_s))
    return params, init_states(params, state)


__all__ = [
    "INVERSE_MODEL",
    "STEADY_STATE",
    "TARE_MODELS",
    "ServoForceEstimatorParams",
    "closed_loop_state_space",
    "current_sensor_coefficients",
    "current_sensor_tf",
    "gain_bandwidth_rad_s",
    "interpolate_coefficients",
    "inverse_model_coefficient_table",
    "inverse_model_coefficients",
    "inverse_model_records",
    "steady_currents_A",
    "steady_state_records",
    "tare_torque_Nm",
]
