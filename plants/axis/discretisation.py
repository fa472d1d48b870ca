"""Exact zero-order-hold discretisation of linear blocks, batched over runs.

For ``x' = A x + B u`` with ``u`` held over a step of length ``T``::

    x(k+1) = Phi x(k) + Gamma u(k),   Phi = e^{A T},   Gamma = int_0^T e^{A t} dt B

Both come from one exponential of the augmented matrix ``[[A, B], [0, 0]] T`` (Van Loan),
which stays exact when ``A`` is singular (integrators).  ``scipy.linalg.expm`` takes a stack
``(runs, n, n)``, so a batch of parameter sets is discretised in one call.

:func:`zoh_mean_matrices` also gives the *mean* of the state over the step,
``(1/T) int_0^T x(k + t/T) dt = Cbar x(k) + Dbar u(k)``, from the exponential of a doubly
augmented matrix: what a sensor that reports the displacement per sample (the mean speed)
measures.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import expm


def zoh_matrices(A: ArrayLike, B: ArrayLike, step_s: float) -> tuple[NDArray, NDArray]:
    """Exact ZOH ``(Phi, Gamma)`` of ``x' = A x + B u`` at ``step_s``.

    Parameters
    ----------
    A : array_like, shape (..., n, n)
    B : array_like, shape (..., n, m)
    step_s : float
        Hold period ``T`` [s], > 0.

    Returns
    -------
    Phi : ndarray, shape (..., n, n)
    Gamma : ndarray, shape (..., n, m)
    """
    if not step_s > 0:
        raise ValueError(f"step_s must be > 0, got {step_s}")
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    n, m = A.shape[-1], B.shape[-1]
    lead = np.broadcast_shapes(A.shape[:-2], B.shape[:-2])
    M = np.zeros((*lead, n + m, n + m))
    M[..., :n, :n] = A
    M[..., :n, n:] = B
    E = expm(M * step_s)
    return E[..., :n, :n], E[..., :n, n:]


def zoh_mean_matrices(
    A: ArrayLike, B: ArrayLike, step_s: float
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """``(Phi, Gamma, Cbar, Dbar)``: the exact ZOH step and the mean of the state over it.

    ``Cbar = (1/T) int_0^T e^{A t} dt`` and ``Dbar = (1/T) int_0^T int_0^t e^{A s} ds dt B``,
    so that the state averaged over step ``k`` is ``Cbar x(k) + Dbar u(k)``.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n, m)
    step_s : float
        ``T`` [s], > 0.
    """
    if not step_s > 0:
        raise ValueError(f"step_s must be > 0, got {step_s}")
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    n, m = A.shape[-1], B.shape[-1]
    # [[A, I, 0], [0, 0, B], [0, 0, 0]] (blocks n, n, m): its exponential holds
    # e^{AT}, int e^{At}, and the double integral times B.
    M = np.zeros((2 * n + m, 2 * n + m))
    M[:n, :n] = A
    M[:n, n : 2 * n] = np.eye(n)
    M[n : 2 * n, 2 * n :] = B
    E = expm(M * step_s)
    phi = E[:n, :n]
    integral = E[:n, n : 2 * n]
    double_b = E[:n, 2 * n :]
    gamma = integral @ B
    return phi, gamma, integral / step_s, double_b / step_s


__all__ = ["zoh_matrices", "zoh_mean_matrices"]
