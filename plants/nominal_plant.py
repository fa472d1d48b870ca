"""Nominal feed-to-force plant used for design, Kim & Chung Eq. (9).

.. math:: P_n(s) = \\frac{a K_{2n} e^{-L s}}{(s + a)(s - p_{2n})}
          = \\frac{368.68\\, e^{-0.1 s}}{(s + 29.33)(s + 3.75)}

from commanded feedrate [mm/min] to cutting force [N]; the paper bases it on the 3 mm
radial depth of Table 1.  The delay-free part is returned as a python-control transfer
function; the delay is kept apart (exact in frequency responses, Pade only on request).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class NominalPlant:
    """Design model of feed drive and force process.

    Attributes
    ----------
    bandwidth_rad_s : float
        Feed-drive bandwidth ``a`` [rad/s].
    dead_time_s : float
        Feed-drive dead time ``L`` [s].
    k2_N_min_per_mm_s : float
        Nominal process gain ``K2n`` [N/(mm/min)/s].
    p2_rad_s : float
        Nominal process pole ``p2n`` [rad/s], < 0.
    """

    bandwidth_rad_s: float = 29.33
    dead_time_s: float = 0.1
    k2_N_min_per_mm_s: float = 12.57
    p2_rad_s: float = -3.75

    def __post_init__(self) -> None:
        if not self.bandwidth_rad_s > 0:
            raise ValueError("bandwidth_rad_s must be > 0")
        if not self.dead_time_s >= 0:
            raise ValueError("dead_time_s must be >= 0")
        if not self.k2_N_min_per_mm_s > 0:
            raise ValueError("k2_N_min_per_mm_s must be > 0")
        if not self.p2_rad_s < 0:
            raise ValueError("p2_rad_s must be < 0")

    @property
    def gain(self) -> float:
        """High-frequency gain ``a K2n`` of Eq. (9) [N/(mm/min)/s^2] (368.68 by default)."""
        return self.bandwidth_rad_s * self.k2_N_min_per_mm_s

    @property
    def static_gain_N_per_mm_min(self) -> float:
        """DC gain ``K2n / (-p2n)`` [N/(mm/min)]."""
        return self.k2_N_min_per_mm_s / (-self.p2_rad_s)

    def rational_part(self) -> Any:
        """Delay-free part of Eq. (9) as a python-control transfer function."""
        import control

        return control.tf(
            [self.gain], np.polymul([1.0, self.bandwidth_rad_s], [1.0, -self.p2_rad_s])
        )

    def frequency_response(self, omega_rad_s: ArrayLike) -> NDArray[np.complex128]:
        """``Pn(j w)`` with the exact delay, shape of ``omega_rad_s``."""
        w = np.asarray(omega_rad_s, dtype=float)
        s = 1j * w
        return (
            self.gain
            * np.exp(-self.dead_time_s * s)
            / ((s + self.bandwidth_rad_s) * (s - self.p2_rad_s))
        )

    def with_pade(self, order: int = 5) -> Any:
        """Eq. (9) with the delay replaced by a Pade approximant of the given order."""
        import control

        num, den = control.pade(self.dead_time_s, order)
        return self.rational_part() * control.tf(num, den)


__all__ = ["NominalPlant"]
