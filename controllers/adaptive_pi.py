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

import numpy as np
from numpy.typing import NDArray


def adaptive_pi_gains(
    nominal_kp_per_N: NDArray[np.float64],
    nominal_ki_per_N_s: NDArray[np.float64],
    nominal_k2_N_min_per_mm_s: NDArray[np.float64],
    nominal_p2_rad_s: NDArray[np.float64],
    k2_hat_N_min_per_mm_s: NDArray[np.float64],
    p2_hat_rad_s: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """PI gains for the estimated model (module docstring).

    Parameters
    ----------
    nominal_kp_per_N, nominal_ki_per_N_s : ndarray, shape (runs,)
        Gains for the nominal plant [1/N], [1/(N s)].
    nominal_k2_N_min_per_mm_s, nominal_p2_rad_s : ndarray, shape (runs,)
        Nominal ``K2n`` [N/(mm/min)/s] and ``p2n`` [rad/s].
    k2_hat_N_min_per_mm_s, p2_hat_rad_s : ndarray, shape (runs,)
        Estimated ``K2`` (> 0) and ``p2`` (< 0).

    Returns
    -------
    kp_per_N, ki_per_N_s : ndarray, shape (runs,)
    """
    ratio = nominal_k2_N_min_per_mm_s / k2_hat_N_min_per_mm_s
    return nominal_kp_per_N * ratio, nominal_ki_per_N_s * ratio * p2_hat_rad_s / nominal_p2_rad_s


def pi_law(
    integral: NDArray[np.float64],
    error_N: NDArray[np.float64],
    kp_per_N: NDArray[np.float64],
    ki_per_N_s: NDArray[np.float64],
    control_period_s: float,
    offset: NDArray[np.float64],
    override_min: NDArray[np.float64],
    override_max: NDArray[np.float64],
    anti_windup: str,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One period of the override PI with an offset inside the clamp.

    ``w = kp e + i + offset``, ``override = clip(w, min, max)``,
    ``i <- i + ki T_c e`` unless (clamping) ``w`` is beyond a limit and ``e`` pushes further.

    Parameters
    ----------
    integral : ndarray, shape (runs,)
        Integrator ``i[k]`` [-].
    error_N : ndarray, shape (runs,)
        ``r - y[k]`` [N].
    kp_per_N, ki_per_N_s : ndarray, shape (runs,)
        Gains of this period.
    control_period_s : float
    offset : ndarray, shape (runs,)
        Added to the PI output before the clamp [-].
    override_min, override_max : ndarray, shape (runs,)
    anti_windup : {"clamping", "none"}

    Returns
    -------
    integral : ndarray, shape (runs,)
        ``i[k + 1]``.
    override : ndarray, shape (runs,)
    """
    w = kp_per_N * error_N + integral + offset
    override = np.clip(w, override_min, override_max)
    di = ki_per_N_s * control_period_s * error_N
    if anti_windup == "clamping":
        hold = ((w > override_max) & (error_N > 0)) | ((w < override_min) & (error_N < 0))
        di = np.where(hold, 0.0, di)
    return integral + di, override


__all__ = ["adaptive_pi_gains", "pi_law"]
