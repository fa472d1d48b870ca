"""ISO 230-2 positioning accuracy and repeatability of a numerically controlled axis (spec §6.2).

Bidirectional runs: each of ``n`` cycles approaches the ``m`` targets ``P_i`` in the positive
(forward, up-arrow) and in the negative (backward, down-arrow) direction; ``x_ij`` is the
position deviation *measured - target* of cycle ``j`` at target ``i``.  Per target::

    mean unidirectional      xf_i = (1/n) sum_j xf_ij,   xb_i likewise (over cycles)
    mean bidirectional       x_i  = (xf_i + xb_i) / 2
    reversal value           B_i  = xf_i - xb_i
    estimator of std. unc.   sf_i = sqrt( sum_j (xf_ij - xf_i)^2 / (n - 1) ),  sb_i likewise
    unidirectional repeat.   Rf_i = 4 sf_i,  Rb_i = 4 sb_i
    bidirectional repeat.    R_i  = max(2 sf_i + 2 sb_i + |B_i|, Rf_i, Rb_i)

and for the axis::

    B = max |B_i|,   mean reversal = mean B_i
    R = max R_i,  Rf = max Rf_i,  Rb = max Rb_i
    E = max(xf_i, xb_i) - min(xf_i, xb_i)                    systematic deviation
    Ef = max xf_i - min xf_i,  Eb likewise
    M = max x_i - min x_i                                    mean bidirectional range
    A = max(xf_i + 2 sf_i, xb_i + 2 sb_i) - min(xf_i - 2 sf_i, xb_i - 2 sb_i)
    Af = max(xf_i + 2 sf_i) - min(xf_i - 2 sf_i),  Ab likewise

Means are over cycles (not targets), forward data stays forward, E's minimum is a minimum,
and R takes both directions: the four defects of the public script the spec reviewed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True, eq=False)
class PositioningAccuracy:
    """ISO 230-2 quantities of one axis (units of the input, e.g. mm or um).

    Attributes
    ----------
    targets : ndarray, shape (m,)
    mean_forward, mean_backward, mean_bidirectional : ndarray, shape (m,)
    std_forward, std_backward : ndarray, shape (m,)
        ``s`` with ``n - 1`` in the denominator.
    reversal : ndarray, shape (m,)
        ``B_i``.
    repeatability_forward, repeatability_backward, repeatability : ndarray, shape (m,)
        ``Rf_i, Rb_i, R_i``.
    A, A_forward, A_backward, B, mean_reversal, E, E_forward, E_backward, M, R, R_forward, \
R_backward : float
    """

    targets: NDArray[np.float64]
    mean_forward: NDArray[np.float64]
    mean_backward: NDArray[np.float64]
    mean_bidirectional: NDArray[np.float64]
    std_forward: NDArray[np.float64]
    std_backward: NDArray[np.float64]
    reversal: NDArray[np.float64]
    repeatability_forward: NDArray[np.float64]
    repeatability_backward: NDArray[np.float64]
    repeatability: NDArray[np.float64]
    A: float
    A_forward: float
    A_backward: float
    B: float
    mean_reversal: float
    E: float
    E_forward: float
    E_backward: float
    M: float
    R: float
    R_forward: float
    R_backward: float


def iso230_2(
    targets: ArrayLike, forward: ArrayLike, backward: ArrayLike, *, deviations: bool = False
) -> PositioningAccuracy:
    """Evaluate bidirectional positioning runs by ISO 230-2.

    Parameters
    ----------
    targets : array_like, shape (m,)
        Target positions ``P_i``.
    forward, backward : array_like, shape (n, m)
        Measured positions (or deviations, with ``deviations=True``) of ``n >= 2`` cycles
        approaching each target in the positive and the negative direction.
    deviations : bool
        The runs are already deviations ``x_ij``.

    Returns
    -------
    PositioningAccuracy
    """
    p = np.asarray(targets, dtype=float)
    f = np.asarray(forward, dtype=float)
    b = np.asarray(backward, dtype=float)
    if f.ndim != 2 or f.shape != b.shape or f.shape[1] != p.size:
        raise ValueError("forward and backward must have shape (cycles, targets)")
    if f.shape[0] < 2:
        raise ValueError("at least two cycles are needed for a standard uncertainty")
    if not deviations:
        f = f - p
        b = b - p
    xf, xb = f.mean(axis=0), b.mean(axis=0)
    sf, sb = f.std(axis=0, ddof=1), b.std(axis=0, ddof=1)
    x = 0.5 * (xf + xb)
    rev = xf - xb
    rf, rb = 4.0 * sf, 4.0 * sb
    r = np.maximum.reduce([2.0 * sf + 2.0 * sb + np.abs(rev), rf, rb])
    both = np.concatenate([xf, xb])
    return PositioningAccuracy(
        targets=p, mean_forward=xf, mean_backward=xb, mean_bidirectional=x,
        std_forward=sf, std_backward=sb, reversal=rev, repeatability_forward=rf,
        repeatability_backward=rb, repeatability=r,
        A=float(max(np.max(xf + 2 * sf), np.max(xb + 2 * sb))
                - min(np.min(xf - 2 * sf), np.min(xb - 2 * sb))),
        A_forward=float(np.max(xf + 2 * sf) - np.min(xf - 2 * sf)),
        A_backward=float(np.max(xb + 2 * sb) - np.min(xb - 2 * sb)),
        B=float(np.max(np.abs(rev))), mean_reversal=float(np.mean(rev)),
        E=float(both.max() - both.min()),
        E_forward=float(xf.max() - xf.min()), E_backward=float(xb.max() - xb.min()),
        M=float(x.max() - x.min()),
        R=float(r.max()), R_forward=float(rf.max()), R_backward=float(rb.max()),
    )


__all__ = ["PositioningAccuracy", "iso230_2"]
