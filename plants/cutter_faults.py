"""Cutter faults in the geometric end-milling model: per-tooth runout, missing and broken teeth.

Extends :mod:`plants.end_mill_geometry` (same frame, same closed-form edge integrals).  Tooth
``j`` sits at spindle angle ``phi + j 2 pi / N``, so as the spindle turns the teeth reach a
given immersion angle in the order ``0, N-1, N-2, ..., 1``: the tooth that cut just before
tooth ``j`` is tooth ``j + 1 (mod N)``.

Chip of a present tooth ``j`` (spec A0-4, seed 000 Sec. 3.5): if the ``m - 1`` teeth before
it are missing (``m`` pitches since the last present tooth ``l = j + m (mod N)``), it removes
their chips as well, and a radial runout ``r`` [mm] (edge radius ``R + r``) adds the radius
difference::

    h_j(phi) = (c m + r_j - r_l) sin(phi),     c = feed per tooth [mm]

This is the spec's form: the runout difference is scaled by ``sin(phi)`` like the feed, so
the per-tooth chip keeps the shape of the nominal one and the edge integrals stay in closed
form [ASSUMED simplification of the exact trochoidal chip; it keeps the tooth-average
proportions exact].  A tooth whose chip scale ``c m + r_j - r_l`` is <= 0 cuts nothing (no
edge force either); the chip it leaves is then not carried over to the next tooth (valid
when runout differences are below the feed per tooth, the usual case).  A missing tooth
has no force at all.  The chip-thickness pressure factor is that of the nominal cut at
the sample's feed per tooth (as :func:`~plants.end_mill_geometry.forces_vs_time`).

A fault switches on at a time or at a path position: :class:`CutterFaults` holds the teeth
that are missing from the start and the teeth that break at ``break_time_s`` or when the
feed travel reaches ``break_path_mm`` (whichever comes first).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import jit
from plants.cutting_coefficients import CuttingCoefficients
from plants.end_mill_geometry import (
    CuttingForces,
    EndMill,
    MillingCut,
    _coefficient_tuple,
    antiderivatives,
    entry_exit_angles_rad,
    feed_per_tooth_from_feedrate,
    mean_chip_thickness_mm,
)


@dataclass(frozen=True)
class CutterFaults:
    """Per-tooth runout and missing or broken teeth of a cutter.

    Attributes
    ----------
    runout_mm : tuple of float
        Radial runout ``r_j`` of each tooth [mm] (edge radius ``R + r_j``); empty = none,
        else one value per tooth.
    missing_teeth : tuple of int
        Teeth absent from the start (0-based indices).
    broken_teeth : tuple of int
        Teeth that break (become absent) at the switch below.
    break_time_s : float
        Time of breakage [s] (``inf``: never by time).
    break_path_mm : float
        Feed travel at breakage [mm] (``inf``: never by path).
    """

    runout_mm: tuple[float, ...] = ()
    missing_teeth: tuple[int, ...] = ()
    broken_teeth: tuple[int, ...] = ()
    break_time_s: float = math.inf
    break_path_mm: float = math.inf

    def __post_init__(self) -> None:
        if any(not math.isfinite(r) for r in self.runout_mm):
            raise ValueError(f"runout_mm must be finite, got {self.runout_mm}")
        for name in ("break_time_s", "break_path_mm"):
            if math.isnan(getattr(self, name)):
                raise ValueError(f"{name} must be a number, got NaN")

    def check(self, tool: EndMill) -> None:
        """Raise ValueError if the fault does not fit the tool."""
        if self.runout_mm and len(self.runout_mm) != tool.teeth:
            raise ValueError(
                f"runout_mm needs one value per tooth ({tool.teeth}), got {len(self.runout_mm)}"
            )
        for t in (*self.missing_teeth, *self.broken_teeth):
            if not (isinstance(t, (int, np.integer)) and 0 <= t < tool.teeth):
                raise ValueError(f"tooth index {t!r} out of range 0..{tool.teeth - 1}")

    def runout_array_mm(self, teeth: int) -> NDArray[np.float64]:
        """Runout per tooth [mm], shape (teeth,) (zeros when none is given)."""
        return np.zeros(teeth) if not self.runout_mm else np.asarray(self.runout_mm, float)

    def present(
        self, teeth: int, time_s: ArrayLike, path_mm: ArrayLike | None = None
    ) -> NDArray[np.bool_]:
        """Which teeth are present at each sample.

        Parameters
        ----------
        teeth : int
            Number of teeth ``N``.
        time_s : array_like, shape (n,)
            Sample times [s].
        path_mm : array_like, shape (n,), optional
            Feed travel at each sample [mm] (needed only for a path switch).

        Returns
        -------
        ndarray of bool, shape (n, teeth)
        """
        t = np.atleast_1d(np.asarray(time_s, dtype=float))
        broken = t >= self.break_time_s
        if path_mm is not None:
            broken = broken | (np.broadcast_to(np.asarray(path_mm, float), t.shape)
                               >= self.break_path_mm)
        elif math.isfinite(self.break_path_mm):
            raise ValueError("break_path_mm is set: give path_mm")
        out = np.ones((t.size, teeth), dtype=bool)
        out[:, list(self.missing_teeth)] = False
        for j in self.broken_teeth:
            out[:, j] &= ~broken
        return out


@jit
def chip_scales_at(present, feed_per_tooth_mm: float, runout_mm, out) -> None:  # noqa: ANN001
    """Chip scale ``max(0, c m + r_j - r_l)`` of each tooth at one sample [mm] into ``out``
    (0 where the tooth is absent or cuts nothing).

    ``present`` (bool), ``runout_mm`` and ``out`` have at least ``N = present.shape[0]``
    entries; ``l = j + m (mod N)`` is the last present tooth before ``j``."""
    teeth = present.shape[0]
    for j in range(teeth):
        out[j] = 0.0
        if not present[j]:
            continue
        for m in range(1, teeth + 1):
            last = (j + m) % teeth
            if present[last]:
                out[j] = max(feed_per_tooth_mm * m + runout_mm[j] - runout_mm[last], 0.0)
                break


@jit(python_entry=True)
def _chip_scales_each(present, c, runout, out) -> None:  # noqa: ANN001
    for i in range(present.shape[0]):
        chip_scales_at(present[i], c[i], runout, out[i])


def tooth_chip_scales_mm(
    present: ArrayLike, feed_per_tooth_mm: ArrayLike, runout_mm: ArrayLike
) -> NDArray[np.float64]:
    """Chip scale ``max(0, c m + r_j - r_l)`` of each tooth at each sample [mm] (0 if absent).

    Parameters
    ----------
    present : array_like of bool, shape (n, N)
    feed_per_tooth_mm : array_like, shape (n,) or scalar
        ``c`` [mm].
    runout_mm : array_like, shape (N,)
        ``r_j`` [mm].

    Returns
    -------
    ndarray, shape (n, N)
        Zero where the tooth is absent or cuts nothing; with every tooth absent, all zero.
        (:func:`chip_scales_at` at each sample, the law the force loop uses.)
    """
    pres = np.ascontiguousarray(np.atleast_2d(np.asarray(present, dtype=bool)))
    n, teeth = pres.shape
    c = np.ascontiguousarray(np.broadcast_to(np.asarray(feed_per_tooth_mm, float), (n,)))
    out = np.zeros((n, teeth))
    _chip_scales_each(pres, c, np.ascontiguousarray(np.asarray(runout_mm, float)), out)
    return out


@jit
def faulted_forces_at(phi: float, st: float, ex: float, a: float, cs, teeth: int,  # noqa: ANN001
                      pitch: float, lag: float, k) -> tuple[float, float, float, float]:  # noqa: ANN001
    """Instantaneous ``(F_x, F_y, F_t, F_a)`` [N] at spindle angle ``phi`` [rad] with a chip
    scale per tooth ``cs[j]`` [mm] (pressure factor included); ``k`` = ``(K_tc, K_rc, K_ac,
    K_te, K_re, K_ae)``; ``lag = tan(helix) / R`` [rad/mm], 0 for a straight flute."""
    two_pi = 2.0 * math.pi
    fx = 0.0
    fy = 0.0
    ft = 0.0
    fa = 0.0
    for j in range(teeth):
        c = cs[j]
        if c <= 0.0:
            continue
        if lag == 0.0:
            tip = (phi + j * pitch) % two_pi
            if tip >= st and tip < ex:
                s = math.sin(tip)
                co = math.cos(tip)
                et = k[0] * c * s + k[3]
                er = k[1] * c * s + k[4]
                ea = k[2] * c * s + k[5]
                fx += a * (et * co + er * s)
                fy += a * (-et * s + er * co)
                ft += a * et
                fa += a * ea
            continue
        hi = phi + j * pitch
        lo = hi - lag * a
        m_min = math.floor((lo - ex) / two_pi)
        m_max = math.ceil((hi - st) / two_pi)
        for m in range(m_min, m_max + 1):
            lower = max(lo, st + two_pi * m)
            upper = min(hi, ex + two_pi * m)
            if upper > lower:
                ux, uy, ut, ua = antiderivatives(upper, c, k[0], k[1], k[2], k[3], k[4], k[5])
                lx, ly, lt, la = antiderivatives(lower, c, k[0], k[1], k[2], k[3], k[4], k[5])
                fx += (ux - lx) / lag
                fy += (uy - ly) / lag
                ft += (ut - lt) / lag
                fa += (ua - la) / lag
    return fx, fy, ft, fa


@jit(python_entry=True)
def _faulted_each(phi, st, ex, a, cs, teeth, pitch, lag, k, out) -> None:  # noqa: ANN001
    """:func:`faulted_forces_at` at each sample."""
    for i in range(phi.shape[0]):
        fx, fy, ft, fa = faulted_forces_at(phi[i], st, ex, a, cs[i], teeth, pitch, lag, k)
        out[0, i] = fx
        out[1, i] = fy
        out[2, i] = ft
        out[3, i] = fa


def faulted_forces_vs_time(
    tool: EndMill,
    cut: MillingCut,
    coefficients: CuttingCoefficients,
    time_s: ArrayLike,
    faults: CutterFaults,
    feedrate_mm_min: ArrayLike | None = None,
    start_angle_rad: float = 0.0,
) -> CuttingForces:
    """Instantaneous cutting forces of a faulty cutter versus time.

    With no fault this equals :func:`plants.end_mill_geometry.forces_vs_time`.

    Parameters
    ----------
    tool : EndMill
    cut : MillingCut
        Scalar fields; ``feed_per_tooth_mm`` is replaced by ``f / (N n)`` when a feedrate is
        given.
    coefficients : CuttingCoefficients
    time_s : array_like, shape (n,)
        Sample times [s], from an integer clock ``k dt``.
    faults : CutterFaults
    feedrate_mm_min : array_like, shape (n,) or scalar, optional
        Feedrate [mm/min]; the feed travel for a path switch is its integral (rectangle
        rule at the sample times, travel 0 at the first sample).
    start_angle_rad : float
        Spindle angle of tooth 0 at ``t = 0`` [rad].

    Returns
    -------
    CuttingForces
        Each component shape (n,) [N].
    """
    faults.check(tool)
    t = np.atleast_1d(np.asarray(time_s, dtype=float))
    if feedrate_mm_min is None:
        c = np.full(t.shape, float(cut.feed_per_tooth_mm))
        f = c * tool.teeth * cut.spindle_speed_rpm
    else:
        f = np.broadcast_to(np.asarray(feedrate_mm_min, float), t.shape)
        c = np.asarray(feed_per_tooth_from_feedrate(tool, f, cut.spindle_speed_rpm), float)
    path = np.concatenate([[0.0], np.cumsum(f[:-1] / 60.0 * np.diff(t))])
    per_sample = replace(cut, feed_per_tooth_mm=c)
    factor = np.broadcast_to(
        np.asarray(coefficients.pressure_factor(mean_chip_thickness_mm(tool, per_sample)), float),
        t.shape,
    )
    present = faults.present(tool.teeth, t, path)
    cs = factor[:, None] * tooth_chip_scales_mm(present, c, faults.runout_array_mm(tool.teeth))
    st, ex = (float(v) for v in entry_exit_angles_rad(tool, cut))
    phi = start_angle_rad + 2.0 * math.pi * cut.spindle_speed_rpm / 60.0 * t
    lag = 0.0 if tool.helix_angle_deg == 0 else tool.helix_lag_rad_per_mm
    out = np.empty((4, t.size))
    _faulted_each(
        np.ascontiguousarray(phi), st, ex, float(cut.axial_depth_mm), np.ascontiguousarray(cs),
        tool.teeth, tool.pitch_angle_rad, lag, np.array(_coefficient_tuple(coefficients)), out,
    )
    return CuttingForces(*out)


__all__ = [
    "CutterFaults",
    "chip_scales_at",
    "faulted_forces_at",
    "faulted_forces_vs_time",
    "tooth_chip_scales_mm",
]
