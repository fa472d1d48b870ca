"""A scalar root in a bracket by Brent's method, without importing ``scipy.optimize``.

``scipy.optimize`` takes about 0.35 s to import (linear programming, least squares, the
whole package), and ``acc run`` of one scenario needs nothing of it but a bracketed scalar
root in a few places (the PI design's crossover, the safe feed of the geometric force
model).  :func:`brentq` is the same algorithm as
``scipy.optimize.brentq`` (Brent 1973 with the extrapolation step of SciPy's
``Zeros/brentq.c``), step for step, so the roots are the same to the last bit (tested
against SciPy).
"""

from __future__ import annotations

import math
from collections.abc import Callable

#: Smallest relative tolerance accepted (SciPy's: 4 machine epsilons).
MIN_RTOL = 4.0 * 2.220446049250313e-16


def brentq(
    f: Callable[[float], float],
    a: float,
    b: float,
    xtol: float = 2e-12,
    rtol: float = MIN_RTOL,
    maxiter: int = 100,
) -> float:
    """A root of ``f`` in ``[a, b]``, where ``f(a)`` and ``f(b)`` differ in sign.

    Parameters
    ----------
    f : callable
        ``f(x) -> float``, continuous on the bracket.
    a, b : float
        The bracket's ends.
    xtol, rtol : float
        The root ``x0`` returned satisfies ``abs(x - x0) <= xtol + rtol * abs(x0)`` for the
        true root ``x``; ``xtol > 0``, ``rtol >= 4 eps``.
    maxiter : int
        Iterations at most, >= 0.

    Returns
    -------
    float
        The root.

    Raises
    ------
    ValueError
        A tolerance out of range, or ``f(a)`` and ``f(b)`` of the same sign.
    RuntimeError
        No convergence within ``maxiter`` iterations.
    """
    if not xtol > 0:
        raise ValueError(f"xtol too small ({xtol:g} <= 0)")
    if not rtol >= MIN_RTOL:
        raise ValueError(f"rtol too small ({rtol:g} < {MIN_RTOL:g})")
    if maxiter < 0:
        raise ValueError("maxiter must be >= 0")
    xpre, xcur = float(a), float(b)
    fpre, fcur = float(f(xpre)), float(f(xcur))
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise ValueError("f(a) and f(b) must have different signs")
    xblk = fblk = spre = scur = 0.0
    for _ in range(maxiter):
        if fpre != 0.0 and fcur != 0.0 and (
            math.copysign(1.0, fpre) != math.copysign(1.0, fcur)
        ):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2.0
        sbis = (xblk - xcur) / 2.0
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # extrapolate
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):  # short step
                spre, scur = scur, stry
            else:  # bisect
                spre = scur = sbis
        else:  # bisect
            spre = scur = sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = float(f(xcur))
    raise RuntimeError(f"Failed to converge after {maxiter} iterations, value is {xcur!r}")


__all__ = ["MIN_RTOL", "brentq"]
