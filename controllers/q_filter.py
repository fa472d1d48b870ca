"""The Q filter of the disturbance observer, Kim & Chung Eq. (11).

.. math:: Q(s) = \\frac{1}{(\\tau s + 1)^n}, \\qquad n = 3 \\text{ in the paper}

a binomial low-pass with unit DC gain, ``Q(0) = 1``.  Its -3 dB frequency solves
``(1 + (w tau)^2)^n = 2``, i.e. ``w_3dB tau = sqrt(2^(1/n) - 1)`` (0.5098 for ``n = 3``).

Realisability of the observer needs ``Q / Pn`` proper: with the two-pole nominal plant of
Eq. (9), ``n >= 2``; the paper's ``n = 3`` leaves ``Q / Pn`` strictly proper.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import binom

#: Order of the paper's Q filter, Eq. (11).
PAPER_ORDER = 3


def _check(tau_s: float, order: int) -> None:
    if not tau_s > 0:
        raise ValueError(f"Q-filter time constant tau_s must be > 0, got {tau_s}")
    if int(order) != order or order < 1:
        raise ValueError(f"Q-filter order must be a whole number >= 1, got {order}")


def q_filter_denominator(tau_s: float, order: int = PAPER_ORDER) -> NDArray[np.float64]:
    """Coefficients of ``(tau s + 1)^n``, highest power first, shape (order + 1,)."""
    _check(tau_s, order)
    k = np.arange(order, -1, -1)
    return binom(order, k) * tau_s**k


def q_filter(tau_s: float, order: int = PAPER_ORDER) -> Any:
    """``Q(s) = 1 / (tau s + 1)^n`` as a python-control transfer function.

    Parameters
    ----------
    tau_s : float
        Time constant ``tau`` [s], > 0.
    order : int
        ``n`` (3 in Eq. 11).
    """
    import control

    return control.tf([1.0], q_filter_denominator(tau_s, order))


def q_frequency_response(
    omega_rad_s: ArrayLike, tau_s: float, order: int = PAPER_ORDER
) -> NDArray[np.complex128]:
    """``Q(j w)``, same shape as ``omega_rad_s`` [-]."""
    _check(tau_s, order)
    w = np.asarray(omega_rad_s, dtype=float)
    return (1.0 + 1j * w * tau_s) ** (-order)


def q_cutoff_rad_s(tau_s: float, order: int = PAPER_ORDER) -> float:
    """-3 dB frequency ``sqrt(2^(1/n) - 1) / tau`` [rad/s]."""
    _check(tau_s, order)
    return math.sqrt(2.0 ** (1.0 / order) - 1.0) / tau_s


__all__ = [
    "PAPER_ORDER",
    "q_cutoff_rad_s",
    "q_filter",
    "q_filter_denominator",
    "q_frequency_response",
]
