"""Adaptive PI: gains recomputed every control period from the estimated process model.

Rule (the rule of :mod:`controllers.pi_design`, applied to the estimate).  With the PI zero
on the estimated pole, ``T_i = 1 / (-p2_hat)``, the loop from force error to force is

.. math:: L(s) = K_c \\frac{a \\hat K_2\\, e^{-\\theta s}}{s (s + a)}, \\qquad
          \\theta = L + T_c / 2 .

Its crossover ``w_c`` solves ``pi/2 - atan(w_c / a) - theta w_c = phi_m`` and depends on
neither ``K2`` nor ``p2``; so the nominal design's ``w_c`` is kept and only the gain is
rescaled to put ``|L(j w_c)| = 1`` for the estimated ``K2``:

``kp = kp_n K2n / K2_hat``,  ``ki = ki_n (K2n / K2_hat) (p2_hat / p2n)``

where ``kp_n, ki_n`` are the nominal gains (for the designed ones ``ki_n = kp_n (-p2n)``,
so ``ki = kp (-p2_hat)``: the zero follows the estimated pole).  When the estimate equals
the plant, the loop has exactly the designed crossover and phase margin at every depth.

The PI law with an offset.  :func:`pi_law` is one period of the override PI of
:mod:`controllers.pi` with an additive offset inside the clamp (the disturbance observer's
correction), so the clamping anti-windup sees the override actually sent.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import jit
from controllers.gain_estimator import estimates

ANTI_WINDUP_KINDS = ("clamping", "none")


@jit(python_entry=True)
def adaptive_pi_gains(
    nominal_kp_per_N: float,
    nominal_ki_per_N_s: float,
    nominal_k2_N_min_per_mm_s: float,
    nominal_p2_rad_s: float,
    k2_hat_N_min_per_mm_s: float,
    p2_hat_rad_s: float,
) -> tuple[float, float]:
    """PI gains for the estimated model (module docstring); scalars or arrays alike.

    Parameters
    ----------
    nominal_kp_per_N, nominal_ki_per_N_s : float or ndarray, shape (runs,)
        Gains for the nominal plant [1/N], [1/(N s)].
    nominal_k2_N_min_per_mm_s, nominal_p2_rad_s : float or ndarray, shape (runs,)
        Nominal ``K2n`` [N/(mm/min)/s] and ``p2n`` [rad/s].
    k2_hat_N_min_per_mm_s, p2_hat_rad_s : float or ndarray, shape (runs,)
        Estimated ``K2`` (> 0) and ``p2`` (< 0).

    Returns
    -------
    kp_per_N, ki_per_N_s : float or ndarray, shape (runs,)
    """
    ratio = nominal_k2_N_min_per_mm_s / k2_hat_N_min_per_mm_s
    return nominal_kp_per_N * ratio, nominal_ki_per_N_s * ratio * p2_hat_rad_s / nominal_p2_rad_s


@jit
def pi_law(
    integral: float,
    error_N: float,
    kp_per_N: float,
    ki_per_N_s: float,
    control_period_s: float,
    offset: float,
    override_min: float,
    override_max: float,
    clamping: bool,
) -> tuple[float, float]:
    """One period of the override PI with an offset inside the clamp.

    ``w = kp e + i + offset``, ``override = clip(w, min, max)``,
    ``i <- i + ki T_c e`` unless (``clamping``) ``w`` is beyond a limit and ``e`` pushes
    further.

    Parameters
    ----------
    integral : float
        Integrator ``i[k]`` [-].
    error_N : float
        ``r - y[k]`` [N].
    kp_per_N, ki_per_N_s : float
        Gains of this period.
    control_period_s : float
    offset : float
        Added to the PI output before the clamp [-].
    override_min, override_max : float
    clamping : bool
        Conditional integration (True) or none.

    Returns
    -------
    integral : float
        ``i[k + 1]``.
    override : float
    """
    w = kp_per_N * error_N + integral + offset
    override = w
    if w < override_min:
        override = override_min
    elif w > override_max:
        override = override_max
    di = ki_per_N_s * control_period_s * error_N
    if clamping and (
        ((w > override_max) and (error_N > 0)) or ((w < override_min) and (error_N < 0))
    ):
        di = 0.0
    return integral + di, override


@jit
def bumpless_start(p, estimator_params, estimator_state) -> float:  # noqa: ANN001
    """The integrator an adaptive PI starts from [-].

    Without the safe start, ``initial_override``.  With it (the estimator's start at the
    stiffest plant), ``initial_override - kp0 r``: the PI's first output, taken when no force
    has been measured yet (``e = r``), is the initial override itself, not the proportional
    kick ``kp0 r`` on top of it, which the dead time would let through before any force can
    answer it.  ``kp0`` is the gain of the start model (:func:`adaptive_pi_gains`).

    Parameters
    ----------
    p : controller params record
        With ``initial_override``, ``reference_force_N``, the nominal gains ``kp_per_N``,
        ``ki_per_N_s`` and the nominal model ``k2_N_min_per_mm_s``, ``p2_rad_s``.
    estimator_params, estimator_state : estimator records, initialised
        :mod:`controllers.gain_estimator`.
    """
    if not estimator_params.safe_start:
        return p.initial_override
    k2h, p2h = estimates(estimator_params, estimator_state)
    kp, _ = adaptive_pi_gains(p.kp_per_N, p.ki_per_N_s, p.k2_N_min_per_mm_s, p.p2_rad_s,
                              k2h, p2h)
    return p.initial_override - kp * p.reference_force_N


@jit
def bumpless_gain(
    estimator_params,  # noqa: ANN001
    integral: float,
    last_kp_per_N: float,
    kp_per_N: float,
    error_N: float,
) -> float:
    """The integrator after a change of the proportional gain, with the safe start [-].

    ``i + (kp_last - kp) e``: the PI's output ``kp e + i`` for this period's error is what the
    last period's gain would give, so a new estimate changes the override's rate, never its
    value (a bumpless hand-over: the jump ``(kp - kp_last) e`` at the first trusted estimate
    after a cautious start, with ``e`` still near the reference, would be a feed kick).  The
    integrator unchanged without the safe start or on the first period (``kp_last`` NaN).
    """
    if not estimator_params.safe_start or not last_kp_per_N == last_kp_per_N:
        return integral
    return integral + (last_kp_per_N - kp_per_N) * error_N


def clamping(anti_windup: str | Sequence[str], runs: int) -> NDArray[np.bool_]:
    """Per-run conditional-integration flags, shape (runs,), from one anti-windup kind or a
    sequence of them (ValueError for an unknown kind)."""
    kinds = [anti_windup] * runs if isinstance(anti_windup, str) else list(anti_windup)
    for kind in kinds:
        if kind not in ANTI_WINDUP_KINDS:
            raise ValueError(f"anti_windup must be one of {ANTI_WINDUP_KINDS}, got {kind!r}")
    return np.broadcast_to(np.array([k == "clamping" for k in kinds]), (runs,))


def set_override_pi_fields(
    params: NDArray,
    control_period_s: float,
    anti_windup: str | Sequence[str],
    estimator: tuple[NDArray, NDArray] | None,
    **values: object,
) -> None:
    """Fill the fields every override-PI controller's params record shares.

    Parameters
    ----------
    params : ndarray of records, shape (runs,)
        With the fields named in ``values``, ``override_min``, ``override_max``,
        ``control_period_s``, ``clamping``, ``has_estimator`` and ``estimator``.
    control_period_s : float
        ``T_c`` [s].
    anti_windup : {"clamping", "none"} or sequence of them, length runs
    estimator : (params, state) or None
        :func:`controllers.gain_estimator.estimator_records`.
    **values
        Field name -> value (scalar or shape (runs,)), e.g. ``kp_per_N``.
    """
    for name, value in values.items():
        params[name] = value
    if np.any(params["override_min"] > params["override_max"]):
        raise ValueError("override_min must be <= override_max")
    params["control_period_s"] = control_period_s
    params["clamping"] = clamping(anti_windup, len(params))
    params["has_estimator"] = estimator is not None
    if estimator is not None:
        params["estimator"] = estimator[0]


__all__ = ["ANTI_WINDUP_KINDS", "adaptive_pi_gains", "bumpless_gain", "bumpless_start",
           "clamping", "pi_law",
           "set_override_pi_fields"]
