"""Errors between a ball-screw axis's motor encoder and its table (Xu et al., spec M3-2, M3-5).

The motor encoder turns ``theta_en`` [rev]; the screw's nominal travel is
``u = (p / i) theta_en`` (Eq. 1; ``p`` lead [mm], ``i`` motor:screw reduction).  The table,
read by a linear scale, is at::

    d_st = u + e_pitch(u) + e_backlash + F / k_axial

* ``e_pitch``: accumulated lead error (linear, um per m of travel), a periodic error with the
  screw lead as period, and an optional pitch map (piecewise linear over knots);
* ``e_backlash = -(b/2) sign(v)``: the table lags the screw by half the backlash in the
  direction of motion; the last direction is held while at rest (start: +);
* ``F / k_axial``: elastic deflection under the axial force ``F`` [N] (> 0 pushes the table
  in +x).

The structure is [ASSUMED] (the paper gives no numbers); the defaults are zero errors.

Feedback (M3-5): *semi-closed*, the loop holds ``u`` at the command plus an additive pitch
compensation ``c(x)``, so the table error is ``e_pitch + e_backlash + F/k + c``; *full-closed*,
the loop holds the scale at the command, so the table error is the scale's own error (0
here) plus the servo's dynamic error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

FEEDBACK_MODES = ("semi_closed", "full_closed")


@dataclass(frozen=True)
class AxisErrorParams:
    """Geometric and elastic errors of one ball-screw axis.

    Attributes
    ----------
    screw_lead_mm : float
        ``p`` [mm].
    reduction_ratio : float
        ``i`` motor turns per screw turn [-].
    accumulated_lead_error_um_per_m : float
        Linear lead error [um/m].
    periodic_error_um : float
        Amplitude of the error with the lead as period [um].
    pitch_map_positions_mm, pitch_map_um : tuple of float
        Pitch-error map knots [mm] and values [um], interpolated linearly (empty: none).
    backlash_um : float
        ``b`` [um].
    axial_stiffness_N_um : float
        ``k_axial`` [N/um]; ``inf``: rigid.
    """

    screw_lead_mm: float = 10.0
    reduction_ratio: float = 1.0
    accumulated_lead_error_um_per_m: float = 0.0
    periodic_error_um: float = 0.0
    pitch_map_positions_mm: tuple[float, ...] = ()
    pitch_map_um: tuple[float, ...] = ()
    backlash_um: float = 0.0
    axial_stiffness_N_um: float = math.inf

    def __post_init__(self) -> None:
        if not (self.screw_lead_mm > 0 and self.reduction_ratio > 0):
            raise ValueError("screw_lead_mm and reduction_ratio must be > 0")
        if len(self.pitch_map_positions_mm) != len(self.pitch_map_um):
            raise ValueError("pitch_map_positions_mm and pitch_map_um must have equal lengths")
        if self.backlash_um < 0 or not self.axial_stiffness_N_um > 0:
            raise ValueError("backlash_um must be >= 0 and axial_stiffness_N_um > 0")

    @property
    def travel_per_rev_mm(self) -> float:
        """``p / i`` [mm per motor revolution]."""
        return self.screw_lead_mm / self.reduction_ratio

    def pitch_error_mm(self, position_mm: ArrayLike) -> NDArray[np.float64]:
        """``e_pitch`` at nominal positions [mm]."""
        u = np.asarray(position_mm, dtype=float)
        e = self.accumulated_lead_error_um_per_m * 1e-3 * u * 1e-3
        e = e + self.periodic_error_um * 1e-3 * np.sin(2 * np.pi * u / self.screw_lead_mm)
        if self.pitch_map_um:
            e = e + 1e-3 * np.interp(u, self.pitch_map_positions_mm, self.pitch_map_um)
        return e


def motion_direction(position_mm: ArrayLike) -> NDArray[np.float64]:
    """+1/-1 per sample from the position increments, held while at rest (start: +1)."""
    u = np.asarray(position_mm, dtype=float)
    step = np.sign(np.diff(u, prepend=u[:1]))
    idx = np.where(step != 0, np.arange(u.size), 0)
    np.maximum.accumulate(idx, out=idx)
    held = step[idx]
    return np.where(held == 0, 1.0, held)


def builtin_signals(
    params: AxisErrorParams, motor_angle_rev: ArrayLike, axial_force_N: ArrayLike = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The built-in sensors of the axis: encoder angle [rev] and scale position [mm].

    Parameters
    ----------
    params : AxisErrorParams
    motor_angle_rev : array_like, shape (n,)
        Motor angle ``theta_en`` [rev].
    axial_force_N : array_like, shape (n,) or scalar
        Axial force on the table [N].

    Returns
    -------
    theta_en_rev, d_st_mm : ndarray, shape (n,)
    """
    theta = np.asarray(motor_angle_rev, dtype=float)
    u = params.travel_per_rev_mm * theta
    f = np.broadcast_to(np.asarray(axial_force_N, float), u.shape)
    d = (u + params.pitch_error_mm(u) - 0.5e-3 * params.backlash_um * motion_direction(u)
         + 1e-3 * f / params.axial_stiffness_N_um)
    return theta, d


def table_error_mm(
    params: AxisErrorParams, command_mm: ArrayLike, axial_force_N: ArrayLike = 0.0,
    mode: str = "semi_closed", compensation_mm: ArrayLike = 0.0,
) -> NDArray[np.float64]:
    """Static table error against the command for semi- or full-closed feedback [mm].

    Semi-closed: ``u = x_cmd + c(x_cmd)`` is held, the table error is
    ``d_st(u) - x_cmd``; full-closed: the scale is held at the command, error 0 (the servo's
    dynamic error comes from the axis model).
    """
    if mode not in FEEDBACK_MODES:
        raise ValueError(f"mode must be one of {FEEDBACK_MODES}, got {mode!r}")
    x = np.asarray(command_mm, dtype=float)
    if mode == "full_closed":
        return np.zeros_like(x)
    u = x + np.broadcast_to(np.asarray(compensation_mm, float), x.shape)
    _, d = builtin_signals(params, u / params.travel_per_rev_mm, axial_force_N)
    return d - x


__all__ = [
    "FEEDBACK_MODES",
    "AxisErrorParams",
    "builtin_signals",
    "motion_direction",
    "table_error_mm",
]
