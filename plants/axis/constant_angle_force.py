"""Lacerda & Belo's cutting-force disturbance on an XY table: a force at a constant angle.

Seed 001, Eqs. (8)-(10) (spec M1-2)::

    (8)  F_w = k_s s^k1 p^k2        (Ber et al. 1988; s = feed [m/rev], p = depth [m])
    (9)  V = c n N                   (so s = c n = V/N, N the spindle speed [rev/s])
    (10) [RECON] F_x = -F_w cos(alpha + phi),  F_y = -F_w sin(alpha + phi)

``alpha`` is the path tangent angle and ``phi`` the constant angle of the force to the
tangent (Fig. 2, missing from the source); for ``phi = 0`` the force opposes the feed.  The
Coulomb terms of Eq. (10) belong to the axes (:mod:`plants.axis.elastic_axis`).  The source
gives no values for ``k_s, k1, k2``.

In the axis slot's convention a load is positive when it opposes positive motion, so the
loads are ``+F_w cos(alpha + phi)`` and ``+F_w sin(alpha + phi)``.  They depend only on the
reference (the tangent angle and the speed), so they are evaluated once per run over the
whole path, not inside the loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


def ber_cutting_force_N(k_s: float, feed_m_rev: ArrayLike, depth_m: float, k1: float,
                        k2: float) -> NDArray[np.float64]:
    """Eq. (8): ``F_w = k_s s^k1 p^k2`` [N] (units of ``k_s`` as fitted, N m^-(k1+k2)).

    Parameters
    ----------
    k_s : float
        Coefficient, >= 0.
    feed_m_rev : array_like
        Feed per spindle revolution ``s = V / N`` [m/rev], >= 0 (Eq. 9).
    depth_m : float
        Depth of cut ``p`` [m], >= 0.
    k1, k2 : float
        Exponents.
    """
    s = np.asarray(feed_m_rev, float)
    if k_s < 0 or depth_m < 0 or np.any(s < 0):
        raise ValueError("k_s, feed_m_rev and depth_m must be >= 0")
    return k_s * s**k1 * depth_m**k2


@dataclass(frozen=True)
class ConstantAngleForceParams:
    """A cutting force of fixed magnitude at a fixed angle to the path tangent.

    Attributes
    ----------
    force_N : float
        ``F_w`` [N] while the reference moves (0: no cutting force).  [ASSUMED] constant
        magnitude: at the constant feed of a circular test Eq. (8) is a constant.
    angle_deg : float
        ``phi`` [deg], the angle of the force to the tangent (0: against the feed).
    moving_speed_mm_s : float
        The force acts where the reference speed exceeds this [mm/s] (none at rest).
    """

    force_N: float = 0.0
    angle_deg: float = 0.0
    moving_speed_mm_s: float = 1e-9

    def __post_init__(self) -> None:
        for name in ("force_N", "angle_deg", "moving_speed_mm_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"{name} must be a finite number, got {v!r}")
        if self.force_N < 0 or self.moving_speed_mm_s < 0:
            raise ValueError("force_N and moving_speed_mm_s must be >= 0")

    def loads(self, tangent_angle_rad: ArrayLike, speed_mm_s: ArrayLike
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Loads on x and y [N] (positive opposes positive motion), per sample.

        Parameters
        ----------
        tangent_angle_rad, speed_mm_s : array_like, shape (n,) or (runs, n)
            The reference's tangent angle [rad] and path speed [mm/s].

        Returns
        -------
        load_x_N, load_y_N : ndarray, the broadcast shape
        """
        a = np.asarray(tangent_angle_rad, float) + math.radians(self.angle_deg)
        on = np.asarray(speed_mm_s, float) > self.moving_speed_mm_s
        f = np.where(on, self.force_N, 0.0)
        return f * np.cos(a), f * np.sin(a)


__all__ = ["ConstantAngleForceParams", "ber_cutting_force_N"]
