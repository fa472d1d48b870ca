"""Friction on a feed axis: linearised viscous, Coulomb plus viscous, or feed-dependent.

Peng (seed 000) identifies the friction of his manually lubricated guideways from the
steady current at each feed (Fig. 2.5; L426): the coefficient ``B`` is inversely
proportional to the speed, so the friction is mostly a constant (Coulomb) torque.  Three
models (spec M0-10):

``"linear"``
    ``T_f = B W`` with the average ``B`` (0.09 N m s/rad).  Every analytic number of the
    thesis uses it; it is part of the exact linear ZOH.
``"coulomb_viscous"``
    ``T_f = T_C sign(W) + B W``.  ``B W`` stays in the exact ZOH; the Coulomb torque is
    held over each plant step (same approximation as :mod:`plants.motor_drive`), with a
    stick rule at rest: a body at rest stays at rest while the net driving torque is within
    ``+-T_C`` (the friction then balances it exactly), and a speed that would change sign
    within a step is stopped at zero at the end of the step.  Optionally ``T_C
    tanh(W / w_eps)`` instead of the stick rule (``coulomb_smoothing_rad_s = w_eps > 0``).
``"speed_dependent_linear"``
    ``B = K_c / |f_c|`` evaluated once per run from the commanded feed ``f_c`` [counts/s]
    (Eq. 3.55, ``K_c`` = 450 from the Fig. 3.18 caption, L1031); what Peng simulated.  At the
    commanded feed this is the constant torque ``B W = K_c / K_e`` (0.707 N m), close to
    the measured tare ``K_t I_f = 0.3 x 2.5 = 0.75`` N m (L882).

:func:`coulomb_hold` is written for any consistent units (torque and shaft speed, or force
and slide speed), so the oscillating axis uses it too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import jit

#: Friction models and their codes in compiled records.
FRICTION_MODELS = {"linear": 0, "coulomb_viscous": 1, "speed_dependent_linear": 2}


@dataclass(frozen=True)
class FrictionParams:
    """Friction of one feed axis at the motor shaft.

    Attributes
    ----------
    model : {"linear", "coulomb_viscous", "speed_dependent_linear"}
    coulomb_friction_Nm : float
        ``T_C`` [N m], >= 0 (``"coulomb_viscous"``; Peng's measured tare is 0.75).
    coulomb_smoothing_rad_s : float
        ``w_eps`` [rad/s] of ``T_C tanh(W/w_eps)``; 0 (default) uses the stick rule.
    speed_dependent_constant_Nm_count_rad : float
        ``K_c`` of ``B = K_c/f_c`` [N m counts/rad] (f_c in counts/s), > 0.
    """

    model: str = "linear"
    coulomb_friction_Nm: float = 0.0
    coulomb_smoothing_rad_s: float = 0.0
    speed_dependent_constant_Nm_count_rad: float = 450.0

    def __post_init__(self) -> None:
        if self.model not in FRICTION_MODELS:
            raise ValueError(
                f"friction_model must be one of {', '.join(FRICTION_MODELS)}, got {self.model!r}"
            )
        for name in ("coulomb_friction_Nm", "coulomb_smoothing_rad_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
        k = self.speed_dependent_constant_Nm_count_rad
        if not (math.isfinite(k) and k > 0):
            raise ValueError(f"speed_dependent_constant_Nm_count_rad must be > 0, got {k!r}")

    @property
    def code(self) -> int:
        """Integer code of the model in compiled records."""
        return FRICTION_MODELS[self.model]

    @property
    def held_coulomb_Nm(self) -> float:
        """Coulomb torque held over each step by the plant [N m] (0 unless
        ``"coulomb_viscous"``)."""
        return self.coulomb_friction_Nm if self.model == "coulomb_viscous" else 0.0

    def viscous_coefficient(
        self, viscous_friction_Nm_s_rad: float, commanded_feed_counts_s: float | None = None
    ) -> float:
        """``B`` of the linear part [N m s/rad].

        ``"linear"`` and ``"coulomb_viscous"``: the given ``B``.  ``"speed_dependent_linear"``:
        ``K_c / |f_c|`` for the run's commanded feed ``f_c`` [counts/s] (required, != 0).
        """
        if self.model != "speed_dependent_linear":
            return float(viscous_friction_Nm_s_rad)
        if commanded_feed_counts_s is None or commanded_feed_counts_s == 0:
            raise ValueError(
                "friction_model 'speed_dependent_linear' needs the run's commanded feed (!= 0)"
            )
        return self.speed_dependent_constant_Nm_count_rad / abs(commanded_feed_counts_s)

    def tare_torque_Nm(self, encoder_counts_per_rad: float) -> float:
        """``K_c / K_e`` [N m]: the torque of ``B = K_c/f_c`` at any commanded feed."""
        return self.speed_dependent_constant_Nm_count_rad / encoder_counts_per_rad


@jit
def coulomb_hold(level: float, smoothing: float, speed: float, drive: float) -> tuple:
    """Coulomb friction to hold over the next step, and whether the body sticks.

    Parameters
    ----------
    level : float
        Coulomb level ``T_C`` (torque or force), >= 0; 0 gives no friction.
    smoothing : float
        ``w_eps`` of ``T_C tanh(speed/w_eps)`` (speed units); 0 for the stick rule.
    speed : float
        Speed at the start of the step.
    drive : float
        Net driving torque (or force) at rest, without the friction (the stick test).

    Returns
    -------
    friction : float
        Friction acting as a load (positive opposes positive speed).
    stuck : bool
        True when the body is at rest and stays at rest over the step.
    """
    if level <= 0.0:
        return 0.0, False
    if smoothing > 0.0:
        return level * math.tanh(speed / smoothing), False
    if speed > 0.0:
        return level, False
    if speed < 0.0:
        return -level, False
    if abs(drive) <= level:
        return drive, True
    return (level if drive > 0.0 else -level), False


def coulomb_friction(
    level: float, smoothing: float, speed: ArrayLike, drive: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """:func:`coulomb_hold` over arrays (for plots and tests): friction and stick flags."""
    s, d = np.broadcast_arrays(np.asarray(speed, float), np.asarray(drive, float))
    out = np.empty(s.shape)
    stuck = np.empty(s.shape, dtype=bool)
    for i in np.ndindex(s.shape):
        out[i], stuck[i] = coulomb_hold(float(level), float(smoothing), float(s[i]), float(d[i]))
    return out, stuck


__all__ = ["FRICTION_MODELS", "FrictionParams", "coulomb_friction", "coulomb_hold"]
