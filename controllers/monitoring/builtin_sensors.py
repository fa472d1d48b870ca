"""Monitoring from a CNC's built-in sensors (Xu et al. 2015, seed 003; spec A3-1, A3-3).

**Dual feedback** (Eq. 1-3): the deviation between the linear scale and the motor encoder,
``e = d_st - (p / i) theta_en`` (``theta_en`` in revolutions; with radians divide by
``2 pi``).  :func:`identify_axis_errors` traces its sources by least squares on the
regressors [ASSUMED concrete form of the paper's "source tracing"]:

* the pitch map: piecewise-linear hat functions on given knots over the nominal position
  ``u = (p/i) theta_en`` (an accumulated lead error is linear, so it is in this span);
* optionally the periodic error with the screw lead as period (sin and cos);
* backlash: ``-sign(v)/2`` (coefficient = ``b``);
* elastic deflection: the axial force ``F`` (coefficient = compliance ``1/k``).

Without noise, an error that lies in this span is recovered exactly; each source's share of
the variance of ``e`` is reported.

**Lead error of a thread** (Sec. 4, [RECON] in the spec): the helix ``Z = Z_0 + L C/(2 pi)``
evaluated at the measured ``C`` gives ``e_L = Z_real - (Z_0 + L C_real/(2 pi))``; the
accumulated lead error is the slope of the best-fit line over the evaluated range times its
length, the "max lead-error fluctuation" the peak-to-peak after removing that line
(``"detrended_ptp"``, default) or of ``e_L`` itself (``"raw_ptp"``).  The Z feed of a thread is
``v_z = L n_C`` (Table 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Definitions of the lead-error fluctuation.
FLUCTUATION_DEFINITIONS = ("detrended_ptp", "raw_ptp")


def dual_feedback_deviation_mm(
    scale_mm: ArrayLike, encoder_angle: ArrayLike, screw_lead_mm: float,
    reduction_ratio: float = 1.0, angle_unit: str = "rev",
) -> NDArray[np.float64]:
    """``e = d_st - (p / i) theta_en`` (Eq. 2) [mm].

    Parameters
    ----------
    scale_mm : array_like, shape (n,)
        Linear-scale position ``d_st`` [mm].
    encoder_angle : array_like, shape (n,)
        Motor encoder angle, in revolutions or radians (``angle_unit``).
    screw_lead_mm, reduction_ratio : float
        ``p`` [mm] and ``i`` [-].
    angle_unit : {"rev", "rad"}
    """
    if angle_unit not in ("rev", "rad"):
        raise ValueError(f"angle_unit must be 'rev' or 'rad', got {angle_unit!r}")
    theta = np.asarray(encoder_angle, dtype=float)
    turns = theta if angle_unit == "rev" else theta / (2.0 * math.pi)
    return np.asarray(scale_mm, dtype=float) - screw_lead_mm / reduction_ratio * turns


def hat_basis(position_mm: ArrayLike, knots_mm: ArrayLike) -> NDArray[np.float64]:
    """Piecewise-linear hat functions on the knots at the positions, shape (n, n_knots)
    (clamped outside the knots)."""
    u = np.asarray(position_mm, dtype=float)
    k = np.asarray(knots_mm, dtype=float)
    eye = np.eye(k.size)
    return np.column_stack([np.interp(u, k, eye[j]) for j in range(k.size)])


@dataclass(frozen=True, eq=False)
class AxisErrorIdentification:
    """Sources of the dual-feedback deviation.

    Attributes
    ----------
    knots_mm : ndarray, shape (n_knots,)
    pitch_map_mm : ndarray, shape (n_knots,)
        Pitch-error map at the knots [mm].
    periodic_amplitude_mm : float
        Amplitude of the lead-periodic error [mm] (0 if not fitted).
    periodic_phase_rad : float
        Its phase: ``A sin(2 pi u / p + phase)``.
    backlash_mm : float
        ``b`` [mm].
    compliance_mm_N : float
        ``1/k`` [mm/N].
    residual_mm : ndarray, shape (n,)
    shares : dict
        Variance of each fitted component over the variance of ``e`` [-].
    """

    knots_mm: NDArray[np.float64]
    pitch_map_mm: NDArray[np.float64]
    periodic_amplitude_mm: float
    periodic_phase_rad: float
    backlash_mm: float
    compliance_mm_N: float
    residual_mm: NDArray[np.float64]
    shares: dict[str, float]


def identify_axis_errors(
    deviation_mm: ArrayLike, position_mm: ArrayLike, direction: ArrayLike,
    axial_force_N: ArrayLike | None, knots_mm: ArrayLike,
    screw_lead_mm: float | None = None,
) -> AxisErrorIdentification:
    """Least-squares source tracing of the dual-feedback deviation (module docstring).

    Parameters
    ----------
    deviation_mm : array_like, shape (n,)
        ``e`` [mm].
    position_mm : array_like, shape (n,)
        Nominal position ``u = (p/i) theta_en`` [mm].
    direction : array_like, shape (n,)
        Direction of motion +1/-1 (held at rest).
    axial_force_N : array_like, shape (n,), optional
        Axial force [N] (None: no elastic term).
    knots_mm : array_like, shape (n_knots,)
        Knots of the pitch map [mm], increasing.
    screw_lead_mm : float, optional
        Fit the lead-periodic error with this period [mm].

    Returns
    -------
    AxisErrorIdentification
    """
    e = np.asarray(deviation_mm, dtype=float)
    u = np.asarray(position_mm, dtype=float)
    cols = {"pitch": hat_basis(u, knots_mm)}
    if screw_lead_mm is not None:
        w = 2.0 * np.pi * u / screw_lead_mm
        cols["periodic"] = np.column_stack([np.sin(w), np.cos(w)])
    cols["backlash"] = (-0.5 * np.asarray(direction, dtype=float))[:, None]
    if axial_force_N is not None:
        cols["elastic"] = np.broadcast_to(np.asarray(axial_force_N, float), e.shape)[:, None]
    names = list(cols)
    x = np.column_stack([cols[n] for n in names])
    theta, *_ = np.linalg.lstsq(x, e, rcond=None)
    parts: dict[str, NDArray[np.float64]] = {}
    coef: dict[str, NDArray[np.float64]] = {}
    i = 0
    for n in names:
        w = cols[n].shape[1]
        coef[n] = theta[i : i + w]
        parts[n] = cols[n] @ coef[n]
        i += w
    var = float(np.var(e))
    shares = {n: (float(np.var(parts[n])) / var if var > 0 else 0.0) for n in names}
    per = coef.get("periodic", np.zeros(2))
    return AxisErrorIdentification(
        knots_mm=np.asarray(knots_mm, float), pitch_map_mm=coef["pitch"],
        periodic_amplitude_mm=float(np.hypot(*per)), periodic_phase_rad=float(
            np.arctan2(per[1], per[0])),
        backlash_mm=float(coef["backlash"][0]),
        compliance_mm_N=float(coef["elastic"][0]) if "elastic" in coef else 0.0,
        residual_mm=e - x @ theta, shares=shares,
    )


def lead_error_mm(z_mm: ArrayLike, c_rad: ArrayLike, lead_mm: float, z0_mm: float = 0.0
                  ) -> NDArray[np.float64]:
    """``e_L = Z - (Z_0 + L C / (2 pi))`` [mm]: the z component of the machining error
    against the helix at the measured ``C``."""
    return np.asarray(z_mm, float) - (z0_mm + lead_mm * np.asarray(c_rad, float) / (2 * np.pi))


@dataclass(frozen=True)
class LeadErrorMetrics:
    """Accumulated lead error [mm] over the range and max fluctuation [mm]."""

    accumulated_mm: float
    slope_mm_per_mm: float
    fluctuation_mm: float


def lead_error_metrics(
    z_mm: ArrayLike, lead_error: ArrayLike, z_range_mm: tuple[float, float] | None = None,
    fluctuation_definition: str = "detrended_ptp",
) -> LeadErrorMetrics:
    """Accumulated error (best-fit slope x length) and max fluctuation of ``e_L`` vs Z.

    Parameters
    ----------
    z_mm, lead_error : array_like, shape (n,)
        Z [mm] and ``e_L`` [mm].
    z_range_mm : (float, float), optional
        Evaluated Z range (default: all).
    fluctuation_definition : {"detrended_ptp", "raw_ptp"}
    """
    if fluctuation_definition not in FLUCTUATION_DEFINITIONS:
        raise ValueError(f"fluctuation_definition must be one of {FLUCTUATION_DEFINITIONS}")
    z = np.asarray(z_mm, float)
    e = np.asarray(lead_error, float)
    if z_range_mm is not None:
        keep = (z >= z_range_mm[0]) & (z <= z_range_mm[1])
        z, e = z[keep], e[keep]
    a = np.column_stack([z - z.mean(), np.ones_like(z)])
    (slope, offset), *_ = np.linalg.lstsq(a, e, rcond=None)
    resid = e - a @ np.array([slope, offset])
    fl = np.ptp(resid) if fluctuation_definition == "detrended_ptp" else np.ptp(e)
    return LeadErrorMetrics(float(slope * (z.max() - z.min())), float(slope), float(fl))


def thread_z_feed_mm_min(lead_mm: ArrayLike, c_speed_rpm: ArrayLike) -> NDArray[np.float64]:
    """Z feed of a thread ``v_z = L n_C`` [mm/min]."""
    return np.asarray(lead_mm, float) * np.asarray(c_speed_rpm, float)


__all__ = [
    "FLUCTUATION_DEFINITIONS",
    "AxisErrorIdentification",
    "LeadErrorMetrics",
    "dual_feedback_deviation_mm",
    "hat_basis",
    "identify_axis_errors",
    "lead_error_metrics",
    "lead_error_mm",
    "thread_z_feed_mm_min",
]
