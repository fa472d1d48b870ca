"""Geometric (mechanistic) cutting-force model of a flat helical end mill, Kim & Chung Eqs. 1-4.

Frame and sign convention
-------------------------
The tool turns clockwise seen from the spindle (right-hand cutter) and feeds along ``+x``
relative to the workpiece; ``y`` is ``x`` turned by +90 deg.  The immersion angle ``phi``
of a point of a cutting edge is measured clockwise from ``+y``; the chip thickness there is
``h = c sin(phi)`` (``c`` feed per tooth).  A cut of radial depth ``a_e`` on a tool of
radius ``R`` engages

* up-milling (conventional):  ``phi_st = 0``,                 ``phi_ex = arccos(1 - a_e/R)``
* down-milling (climb):       ``phi_st = pi - arccos(1 - a_e/R)``, ``phi_ex = pi``

(a slot, ``a_e = 2R``, is ``[0, pi]`` in both).  Forces are those the tool exerts on the
workpiece, i.e. what a table dynamometer reads, as in the paper's Eq. 2::

    dF_x =  dF_t cos(phi) + dF_r sin(phi)     feed direction   (> 0 opposes the feed)
    dF_y = -dF_t sin(phi) + dF_r cos(phi)     normal direction
    dF_t = (K_tc h + K_te) dz,  dF_r = (K_rc h + K_re) dz,  dF_a = (K_ac h + K_ae) dz

``tangential_N`` is the sum over all edges in cut of the tangential components, so the
spindle torque is ``R * tangential_N``.  A point at height ``z`` on tooth ``j`` lags the
tooth's tip by the helix: ``phi_j(z) = phi + j 2 pi / N - z tan(beta) / R``
(``dz = R / tan(beta) dphi``, Eq. 1).

Instantaneous forces (Eqs. 3-4) integrate the element forces in closed form over the part
of each helical edge that is inside the engagement arc.  (The paper's printed ``B`` term is
garbled by OCR; the integral of ``sin^2`` is ``(phi_p - phi_q)/2 - (sin 2phi_p -
sin 2phi_q)/4``.)  Averaged over a tooth period, the helix drops out and every component
is exactly proportional to the axial depth::

    mean F = N a / (2 pi) * integral_{phi_st}^{phi_ex} dF/dz (phi) dphi

with closed forms in :func:`average_forces`.  :func:`average_forces_numerical` computes the
same averages by brute force (axial slices, adaptive quadrature over the spindle angle) as
an independent check.

The closed forms are compiled scalar functions (:func:`antiderivatives`,
:func:`average_forces_at`, :func:`instantaneous_forces_at`) that the force loop calls per
step; the array functions below run them over broadcast arrays.

All functions broadcast their array arguments (the fields of :class:`MillingCut`, angles,
times, feedrates) together in the usual numpy way; give a leading run axis as shape
``(runs, 1)`` against a time or angle axis of shape ``(n,)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import jit
from plants.cutting_coefficients import CuttingCoefficients

MILLING_MODES = ("up", "down")
FORCE_COMPONENTS = ("feed", "normal", "tangential", "axial", "resultant_xy")


#: Most teeth of an end mill (a limit: the tooth-passing force loops over the teeth every
#: plant step; real end mills have a few, face mills a few dozen).
MAX_TEETH = 100


@dataclass(frozen=True)
class EndMill:
    """A flat helical end mill.

    Defaults are the paper's Table 1 tool (16 mm diameter, 4 teeth); the 30 deg helix is
    a common value for a general-purpose end mill and is not given in the paper.

    Attributes
    ----------
    diameter_mm : float
        Tool diameter ``D`` [mm], > 0.
    teeth : int
        Number of teeth ``N``, 1..:data:`MAX_TEETH`, evenly spaced (the instantaneous force
        sums over the teeth at every plant step).
    helix_angle_deg : float
        Helix angle ``beta`` [deg], in [0, 90); 0 is a straight-fluted tool.
    """

    diameter_mm: float = 16.0
    teeth: int = 4
    helix_angle_deg: float = 30.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.diameter_mm) and self.diameter_mm > 0):
            raise ValueError(f"diameter_mm must be > 0, got {self.diameter_mm}")
        if isinstance(self.teeth, bool) or int(self.teeth) != self.teeth or self.teeth < 1:
            raise ValueError(f"teeth must be a whole number >= 1, got {self.teeth}")
        if self.teeth > MAX_TEETH:
            raise ValueError(f"teeth must be at most {MAX_TEETH} (limit), got {self.teeth}")
        if not 0 <= self.helix_angle_deg < 90:
            raise ValueError(f"helix_angle_deg must be in [0, 90), got {self.helix_angle_deg}")

    @property
    def radius_mm(self) -> float:
        """Tool radius ``R`` [mm]."""
        return 0.5 * self.diameter_mm

    @property
    def helix_angle_rad(self) -> float:
        """Helix angle ``beta`` [rad]."""
        return math.radians(self.helix_angle_deg)

    @property
    def pitch_angle_rad(self) -> float:
        """Angle between neighbouring teeth ``2 pi / N`` [rad]."""
        return 2.0 * math.pi / self.teeth

    @property
    def helix_lag_rad_per_mm(self) -> float:
        """Angular lag of an edge per mm of height, ``tan(beta) / R`` [rad/mm]."""
        return math.tan(self.helix_angle_rad) / self.radius_mm


@dataclass(frozen=True, eq=False)
class MillingCut:
    """Cutting conditions.  Array-valued fields broadcast together (a batch of cuts).

    Attributes
    ----------
    radial_depth_mm : float or ndarray
        Radial depth (width) of cut ``a_e`` [mm], in [0, D] (checked against the tool).
    axial_depth_mm : float or ndarray
        Axial depth of cut ``a`` [mm], >= 0.
    feed_per_tooth_mm : float or ndarray
        Feed per tooth ``c`` [mm], >= 0.
    mode : {"up", "down"}
        Up- (conventional) or down- (climb) milling.
    spindle_speed_rpm : float
        Spindle speed [rev/min], > 0 (600 in the paper's Table 1).
    """

    radial_depth_mm: float | NDArray[np.float64] = 3.0
    axial_depth_mm: float | NDArray[np.float64] = 10.0
    feed_per_tooth_mm: float | NDArray[np.float64] = 0.05
    mode: str = "up"
    spindle_speed_rpm: float = 600.0

    def __post_init__(self) -> None:
        for name in ("radial_depth_mm", "axial_depth_mm", "feed_per_tooth_mm"):
            value = np.asarray(getattr(self, name), dtype=float)
            if np.any(~np.isfinite(value)) or np.any(value < 0):
                raise ValueError(f"{name} must be finite and >= 0, got {getattr(self, name)}")
        if self.mode not in MILLING_MODES:
            raise ValueError(f"mode must be 'up' or 'down', got {self.mode!r}")
        if not (math.isfinite(self.spindle_speed_rpm) and self.spindle_speed_rpm > 0):
            raise ValueError(f"spindle_speed_rpm must be > 0, got {self.spindle_speed_rpm}")


@dataclass(frozen=True, eq=False)
class CuttingForces:
    """Cutting-force components on the workpiece (frame: module docstring).

    Attributes
    ----------
    feed_N : ndarray
        Force along the feed direction ``F_x`` [N]; > 0 opposes the feed motion.
    normal_N : ndarray
        Force normal to the feed ``F_y`` [N].
    tangential_N : ndarray
        Sum of the tangential edge forces ``F_t`` [N]; spindle torque is ``R F_t``.
    axial_N : ndarray
        Axial force ``F_z`` [N].
    """

    feed_N: NDArray[np.float64]
    normal_N: NDArray[np.float64]
    tangential_N: NDArray[np.float64]
    axial_N: NDArray[np.float64]

    @property
    def resultant_xy_N(self) -> NDArray[np.float64]:
        """Magnitude of the force in the feed plane ``hypot(F_x, F_y)`` [N]."""
        return np.hypot(self.feed_N, self.normal_N)

    def component(self, name: str) -> NDArray[np.float64]:
        """One component by name: one of :data:`FORCE_COMPONENTS`."""
        if name not in FORCE_COMPONENTS:
            raise ValueError(f"component must be one of {FORCE_COMPONENTS}, got {name!r}")
        if name == "resultant_xy":
            return self.resultant_xy_N
        return getattr(self, f"{name}_N")

    def spindle_torque_Nm(self, tool: EndMill) -> NDArray[np.float64]:
        """Cutting torque on the spindle ``R F_t`` [N m]."""
        return self.tangential_N * tool.radius_mm * 1e-3


def feed_per_tooth_from_feedrate(
    tool: EndMill, feedrate_mm_min: ArrayLike, spindle_speed_rpm: float
) -> NDArray[np.float64]:
    """Feed per tooth ``c = f / (N n)`` [mm] from the feedrate ``f`` [mm/min].

    Parameters
    ----------
    tool : EndMill
    feedrate_mm_min : array_like, any shape
        Feedrate [mm/min], >= 0.
    spindle_speed_rpm : float
        Spindle speed ``n`` [rev/min], > 0.
    """
    f = np.asarray(feedrate_mm_min, dtype=float)
    if np.any(f < 0):
        raise ValueError("feedrate_mm_min must be >= 0")
    if not spindle_speed_rpm > 0:
        raise ValueError(f"spindle_speed_rpm must be > 0, got {spindle_speed_rpm}")
    return f / (tool.teeth * spindle_speed_rpm)


def tooth_period_s(tool: EndMill, spindle_speed_rpm: float) -> float:
    """Tooth-passing period ``60 / (N n)`` [s]."""
    if not spindle_speed_rpm > 0:
        raise ValueError(f"spindle_speed_rpm must be > 0, got {spindle_speed_rpm}")
    return 60.0 / (tool.teeth * spindle_speed_rpm)


def engagement_angle_rad(tool: EndMill, radial_depth_mm: ArrayLike) -> NDArray[np.float64]:
    """Engagement (swept) angle ``theta = arccos(1 - a_e / R)`` [rad], in [0, pi].

    Raises ValueError if the radial depth is negative or exceeds the tool diameter.
    """
    ae = np.asarray(radial_depth_mm, dtype=float)
    if np.any(ae < 0):
        raise ValueError(f"radial_depth_mm must be >= 0, got {radial_depth_mm!s}")
    if np.any(ae > tool.diameter_mm * (1 + 1e-12)):
        raise ValueError(
            f"radial_depth_mm {np.max(ae):g} exceeds the tool diameter {tool.diameter_mm:g} mm"
        )
    return np.arccos(np.clip(1.0 - ae / tool.radius_mm, -1.0, 1.0))


def radial_depth_from_engagement(tool: EndMill, engagement_rad: ArrayLike) -> NDArray[np.float64]:
    """Radial depth ``a_e = R (1 - cos theta)`` [mm] from the engagement angle [rad]."""
    return tool.radius_mm * (1.0 - np.cos(np.asarray(engagement_rad, dtype=float)))


def entry_exit_angles_rad(
    tool: EndMill, cut: MillingCut
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Entry and exit immersion angles ``(phi_st, phi_ex)`` [rad] of the cut."""
    theta = engagement_angle_rad(tool, cut.radial_depth_mm)
    if cut.mode == "up":
        return np.zeros_like(theta), theta
    return math.pi - theta, np.full_like(theta, math.pi)


def mean_chip_thickness_mm(tool: EndMill, cut: MillingCut) -> NDArray[np.float64]:
    """Mean chip thickness over the engagement arc ``c (cos phi_st - cos phi_ex) / theta``.

    Returns
    -------
    ndarray
        [mm], broadcast shape of the cut fields; 0 where the engagement is 0.
    """
    st, ex = entry_exit_angles_rad(tool, cut)
    c = np.asarray(cut.feed_per_tooth_mm, dtype=float)
    theta = ex - st
    ratio = np.divide(
        np.cos(st) - np.cos(ex), theta, out=np.zeros_like(theta), where=theta > 0
    )
    return c * ratio


def _cutting_scale(
    tool: EndMill, cut: MillingCut, coefficients: CuttingCoefficients
) -> NDArray[np.float64]:
    """Feed per tooth times the chip-thickness pressure factor ``c (h_m/h_ref)^-x`` [mm]."""
    factor = coefficients.pressure_factor(mean_chip_thickness_mm(tool, cut))
    return np.asarray(cut.feed_per_tooth_mm, dtype=float) * factor


def _element_forces(
    angle: NDArray[np.float64], cs: NDArray[np.float64], k: CuttingCoefficients
) -> tuple[NDArray[np.float64], ...]:
    """Element forces per unit edge height (Eq. 1-2) at immersion ``angle`` [N/mm]."""
    s, co = np.sin(angle), np.cos(angle)
    ft = k.tangential_cutting_N_mm2 * cs * s + k.tangential_edge_N_mm
    fr = k.radial_cutting_N_mm2 * cs * s + k.radial_edge_N_mm
    fa = k.axial_cutting_N_mm2 * cs * s + k.axial_edge_N_mm
    return ft * co + fr * s, -ft * s + fr * co, ft, fa


@jit
def antiderivatives(
    tau: float, cs: float, ktc: float, krc: float, kac: float, kte: float, kre: float,
    kae: float,
) -> tuple[float, float, float, float]:
    """Antiderivatives over the immersion angle ``tau`` [rad] of the element forces per
    unit edge height, ``(g_x, g_y, g_t, g_a)`` [N rad/mm], for the cutting scale ``cs``
    [mm] and the six coefficients [N/mm^2, N/mm]."""
    s = math.sin(tau)
    co = math.cos(tau)
    half_s2 = 0.5 * s * s  # integral of sin cos
    sin2 = 0.5 * tau - 0.25 * math.sin(2.0 * tau)  # integral of sin^2
    gx = ktc * cs * half_s2 + krc * cs * sin2 + kte * s - kre * co
    gy = -ktc * cs * sin2 + krc * cs * half_s2 + kte * co + kre * s
    gt = -ktc * cs * co + kte * tau
    ga = -kac * cs * co + kae * tau
    return gx, gy, gt, ga


@jit
def average_forces_at(
    st: float, ex: float, a: float, cs: float, teeth: int, ktc: float, krc: float,
    kac: float, kte: float, kre: float, kae: float,
) -> tuple[float, float, float, float]:
    """Tooth-period averages ``(F_x, F_y, F_t, F_a)`` [N] of one cut: entry and exit
    angles [rad], axial depth [mm], cutting scale [mm] (see :func:`average_forces`)."""
    scale = teeth * a / (2.0 * math.pi)
    ex_x, ex_y, ex_t, ex_a = antiderivatives(ex, cs, ktc, krc, kac, kte, kre, kae)
    st_x, st_y, st_t, st_a = antiderivatives(st, cs, ktc, krc, kac, kte, kre, kae)
    return scale * (ex_x - st_x), scale * (ex_y - st_y), scale * (ex_t - st_t), scale * (
        ex_a - st_a
    )


@jit
def instantaneous_forces_at(
    phi: float, st: float, ex: float, a: float, cs: float, teeth: int, pitch: float,
    lag: float, ktc: float, krc: float, kac: float, kte: float, kre: float, kae: float,
) -> tuple[float, float, float, float]:
    """Instantaneous ``(F_x, F_y, F_t, F_a)`` [N] of all teeth at spindle angle ``phi``
    [rad] (see :func:`instantaneous_forces`); ``lag = tan(helix) / R`` [rad/mm], 0 for a
    straight-fluted tool."""
    two_pi = 2.0 * math.pi
    fx = 0.0
    fy = 0.0
    ft = 0.0
    fa = 0.0
    if lag == 0.0:
        for j in range(teeth):
            tip = (phi + j * pitch) % two_pi
            if tip >= st and tip < ex:
                s = math.sin(tip)
                co = math.cos(tip)
                et = ktc * cs * s + kte
                er = krc * cs * s + kre
                ea = kac * cs * s + kae
                fx += a * (et * co + er * s)
                fy += a * (-et * s + er * co)
                ft += a * et
                fa += a * ea
        return fx, fy, ft, fa
    for j in range(teeth):
        hi = phi + j * pitch  # tip of the edge
        lo = hi - lag * a  # top of the engaged edge
        m_min = math.floor((lo - ex) / two_pi)
        m_max = math.ceil((hi - st) / two_pi)
        for m in range(m_min, m_max + 1):
            lower = max(lo, st + two_pi * m)
            upper = min(hi, ex + two_pi * m)
            if upper > lower:
                ux, uy, ut, ua = antiderivatives(upper, cs, ktc, krc, kac, kte, kre, kae)
                lx, ly, lt, la = antiderivatives(lower, cs, ktc, krc, kac, kte, kre, kae)
                fx += (ux - lx) / lag
                fy += (uy - ly) / lag
                ft += (ut - lt) / lag
                fa += (ua - la) / lag
    return fx, fy, ft, fa


@jit
def pressure_factor_at(mean_chip_thickness_mm: float, exponent: float, reference_mm: float
                       ) -> float:
    """``(h_m / h_ref)^(-x)`` [-]; 1 for ``x = 0`` or ``h_m = 0``
    (:meth:`plants.cutting_coefficients.CuttingCoefficients.pressure_factor`)."""
    if exponent == 0.0:
        return 1.0
    h = mean_chip_thickness_mm if mean_chip_thickness_mm > 0 else reference_mm
    return (h / reference_mm) ** (-exponent)


@jit
def mean_chip_thickness_at(st: float, ex: float, feed_per_tooth_mm: float) -> float:
    """``c (cos phi_st - cos phi_ex) / (phi_ex - phi_st)`` [mm]; 0 without engagement."""
    theta = ex - st
    if not theta > 0:
        return 0.0
    return feed_per_tooth_mm * ((math.cos(st) - math.cos(ex)) / theta)


def _coefficient_tuple(k: CuttingCoefficients) -> tuple[float, ...]:
    return (
        k.tangential_cutting_N_mm2, k.radial_cutting_N_mm2, k.axial_cutting_N_mm2,
        k.tangential_edge_N_mm, k.radial_edge_N_mm, k.axial_edge_N_mm,
    )


@jit(python_entry=True)
def _antiderivatives_each(tau, cs, k, out) -> None:  # noqa: ANN001
    for i in range(tau.shape[0]):
        out[0, i], out[1, i], out[2, i], out[3, i] = antiderivatives(
            tau[i], cs[i], k[0], k[1], k[2], k[3], k[4], k[5]
        )


@jit(python_entry=True)
def _instantaneous_each(phi, st, ex, a, cs, teeth, pitch, lag, k, out) -> None:  # noqa: ANN001
    for i in range(phi.shape[0]):
        out[0, i], out[1, i], out[2, i], out[3, i] = instantaneous_forces_at(
            phi[i], st[i], ex[i], a[i], cs[i], teeth, pitch, lag,
            k[0], k[1], k[2], k[3], k[4], k[5],
        )


def _flat(*arrays: ArrayLike) -> tuple[tuple[int, ...], list[NDArray]]:
    """Broadcast shape and the arrays broadcast and flattened (contiguous float)."""
    b = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in arrays))
    return b[0].shape, [np.array(x, dtype=float, order="C").ravel() for x in b]  # writeable copies


def _element_antiderivatives(
    tau: NDArray[np.float64], cs: NDArray[np.float64], k: CuttingCoefficients
) -> tuple[NDArray[np.float64], ...]:
    """:func:`antiderivatives` over broadcast arrays [N rad/mm]."""
    shape, (t, c) = _flat(tau, cs)
    out = np.empty((4, t.size))
    _antiderivatives_each(t, c, np.array(_coefficient_tuple(k)), out)
    return tuple(row.reshape(shape) for row in out)


def instantaneous_forces(
    tool: EndMill,
    cut: MillingCut,
    coefficients: CuttingCoefficients,
    spindle_angle_rad: ArrayLike,
) -> CuttingForces:
    """Instantaneous forces of all teeth versus spindle angle, closed form (Eqs. 3-4).

    Parameters
    ----------
    tool : EndMill
    cut : MillingCut
        Fields broadcast with ``spindle_angle_rad``.
    coefficients : CuttingCoefficients
    spindle_angle_rad : array_like
        Immersion angle of the tip (``z = 0``) of tooth 0 [rad]; tooth ``j`` is at
        ``+ j 2 pi / N``.

    Returns
    -------
    CuttingForces
        Each component has the broadcast shape of the angles and the cut fields [N].
    """
    st, ex = entry_exit_angles_rad(tool, cut)
    cs = _cutting_scale(tool, cut, coefficients)
    shape, (phi, st, ex, a, cs) = _flat(spindle_angle_rad, st, ex, cut.axial_depth_mm, cs)
    out = np.empty((4, phi.size))
    lag = 0.0 if tool.helix_angle_deg == 0 else tool.helix_lag_rad_per_mm
    _instantaneous_each(
        phi, st, ex, a, cs, tool.teeth, tool.pitch_angle_rad, lag,
        np.array(_coefficient_tuple(coefficients)), out,
    )
    return CuttingForces(*(row.reshape(shape) for row in out))


def instantaneous_forces_sliced(
    tool: EndMill,
    cut: MillingCut,
    coefficients: CuttingCoefficients,
    spindle_angle_rad: ArrayLike,
    n_slices: int = 200,
) -> CuttingForces:
    """Instantaneous forces by summing Eq. 2 over axial slices (midpoint rule).

    A numerical reference for :func:`instantaneous_forces`: each slice of height
    ``a / n_slices`` is a straight edge element at its mid-height.  Error is at most
    ``2 N (a / n_slices) max|dF/dz|`` per component (partly engaged slices) plus a
    second-order term.  Same shapes as :func:`instantaneous_forces`.
    """
    if n_slices < 1:
        raise ValueError(f"n_slices must be >= 1, got {n_slices}")
    phi = np.asarray(spindle_angle_rad, dtype=float)
    st, ex = entry_exit_angles_rad(tool, cut)
    a = np.asarray(cut.axial_depth_mm, dtype=float)
    cs = _cutting_scale(tool, cut, coefficients)
    phi, st, ex, a, cs = (x[..., None] for x in np.broadcast_arrays(phi, st, ex, a, cs))
    dz = a / n_slices
    z = (np.arange(n_slices) + 0.5) * dz
    lag = math.tan(tool.helix_angle_rad) / tool.radius_mm
    totals = [np.zeros(phi.shape[:-1]) for _ in range(4)]
    for j in range(tool.teeth):
        angle = np.mod(phi + j * tool.pitch_angle_rad - lag * z, 2.0 * math.pi)
        inside = (angle >= st) & (angle < ex)
        for total, f in zip(totals, _element_forces(angle, cs, coefficients), strict=True):
            total += np.sum(np.where(inside, f * dz, 0.0), axis=-1)
    return CuttingForces(*totals)


def average_forces(
    tool: EndMill, cut: MillingCut, coefficients: CuttingCoefficients
) -> CuttingForces:
    """Average forces over a tooth period, closed form.

    ``mean F = N a / (2 pi) [G(phi_ex) - G(phi_st)]`` with ``G`` the antiderivative of the
    element force per unit height over the immersion angle; independent of the helix.

    Parameters
    ----------
    tool : EndMill
    cut : MillingCut
    coefficients : CuttingCoefficients

    Returns
    -------
    CuttingForces
        Components with the broadcast shape of the cut fields [N].
    """
    st, ex = entry_exit_angles_rad(tool, cut)
    a = np.asarray(cut.axial_depth_mm, dtype=float)
    cs = _cutting_scale(tool, cut, coefficients)
    scale = tool.teeth * a / (2.0 * math.pi)
    g_ex = _element_antiderivatives(ex, cs, coefficients)
    g_st = _element_antiderivatives(st, cs, coefficients)
    return CuttingForces(*(scale * (ge - gs) for ge, gs in zip(g_ex, g_st, strict=True)))


def average_forces_numerical(
    tool: EndMill,
    cut: MillingCut,
    coefficients: CuttingCoefficients,
    n_slices: int = 32,
    rtol: float = 1e-12,
) -> CuttingForces:
    """Average forces over a tooth period by brute-force integration (one scalar cut).

    The instantaneous force is the sum of Eq. 2 over ``n_slices`` axial slices and all
    teeth; it is integrated over one tooth period of spindle angle with
    ``scipy.integrate.quad_vec``, with every angle at which a slice enters or leaves the cut
    given as a break point, so each piece is a smooth trigonometric polynomial.  Because a
    tooth period of ``N`` teeth covers every slice over a whole revolution, the slicing
    itself adds no error to the average: the result agrees with :func:`average_forces` to
    the quadrature tolerance.

    Returns
    -------
    CuttingForces
        Scalar components [N].
    """
    for name in ("radial_depth_mm", "axial_depth_mm", "feed_per_tooth_mm"):
        if np.ndim(getattr(cut, name)) != 0:
            raise ValueError(f"{name} must be a scalar for average_forces_numerical")
    st, ex = (float(v) for v in entry_exit_angles_rad(tool, cut))
    a = float(cut.axial_depth_mm)
    cs = float(_cutting_scale(tool, cut, coefficients))
    pitch = tool.pitch_angle_rad
    z = (np.arange(n_slices) + 0.5) * a / n_slices
    lag = math.tan(tool.helix_angle_rad) / tool.radius_mm
    teeth_offsets = np.arange(tool.teeth)[:, None] * pitch

    def integrand(phi: float) -> NDArray[np.float64]:
        angle = np.mod(phi + teeth_offsets - lag * z, 2.0 * math.pi)
        inside = (angle >= st) & (angle < ex)
        parts = _element_forces(angle, np.float64(cs), coefficients)
        return np.array([np.sum(np.where(inside, f, 0.0)) * a / n_slices for f in parts])

    breaks = np.mod(np.concatenate([st + lag * z, ex + lag * z]), pitch)
    breaks = np.unique(breaks[(breaks > 0) & (breaks < pitch)])
    from scipy.integrate import quad_vec

    value, _ = quad_vec(integrand, 0.0, pitch, epsabs=0.0, epsrel=rtol, points=list(breaks))
    return CuttingForces(*(np.float64(v / pitch) for v in value))


def forces_vs_time(
    tool: EndMill,
    cut: MillingCut,
    coefficients: CuttingCoefficients,
    time_s: ArrayLike,
    feedrate_mm_min: ArrayLike | None = None,
    start_angle_rad: float = 0.0,
) -> CuttingForces:
    """Instantaneous forces versus time with tooth passing, for a given feedrate.

    The spindle turns at ``cut.spindle_speed_rpm``, ``phi(t) = start + 2 pi n t / 60``.
    The chip follows the feedrate quasi-statically, ``c(t) = f(t) / (N n)``.

    Parameters
    ----------
    tool, cut, coefficients
        As :func:`instantaneous_forces`; ``cut.feed_per_tooth_mm`` is replaced by
        ``c(t)`` when a feedrate is given.
    time_s : array_like, shape (n,) or (runs, n)
        Times [s] (e.g. ``k * dt`` from an integer clock).
    feedrate_mm_min : array_like, optional
        Feedrate [mm/min], broadcast with ``time_s``.
    start_angle_rad : float
        Spindle angle at ``t = 0`` [rad].

    Returns
    -------
    CuttingForces
        Broadcast shape of time, feedrate and cut fields [N].
    """
    t = np.asarray(time_s, dtype=float)
    if feedrate_mm_min is not None:
        c = feed_per_tooth_from_feedrate(tool, feedrate_mm_min, cut.spindle_speed_rpm)
        cut = replace(cut, feed_per_tooth_mm=c)
    phi = start_angle_rad + 2.0 * math.pi * cut.spindle_speed_rpm / 60.0 * t
    return instantaneous_forces(tool, cut, coefficients, phi)


def force_process_static_gain_N_per_mm_min(
    tool: EndMill,
    cut: MillingCut,
    coefficients: CuttingCoefficients,
    component: str = "resultant_xy",
) -> NDArray[np.float64]:
    """Static gain of the force process, ``d(mean F) / d(feedrate)`` [N per mm/min].

    The small-signal gain of the average force with respect to the feedrate at the
    operating point ``cut`` (its feed per tooth and spindle speed), derived analytically
    from :func:`average_forces`.  This is the DC gain ``K_2 / (-p_2)`` of the paper's
    first-order process ``f/v = K_2 / (s - p_2)`` (Eq. 7) for any tool, material, radial
    and axial depth.  With zero edge coefficients, a constant cutting pressure and a
    single component it equals ``mean F / feedrate`` (the force is then proportional to
    the feed).

    Parameters
    ----------
    tool, cut, coefficients
        Operating point; with ``chip_thickness_exponent > 0`` the feed per tooth must be
        > 0.
    component : {"feed", "normal", "tangential", "axial", "resultant_xy"}
        Which average force.

    Returns
    -------
    ndarray
        Gain [N/(mm/min)], broadcast shape of the cut fields.
    """
    if component not in FORCE_COMPONENTS:
        raise ValueError(f"component must be one of {FORCE_COMPONENTS}, got {component!r}")
    c = np.asarray(cut.feed_per_tooth_mm, dtype=float)
    x = coefficients.chip_thickness_exponent
    if x > 0 and np.any(c <= 0):
        raise ValueError("feed_per_tooth_mm must be > 0 when chip_thickness_exponent > 0")
    st, ex = entry_exit_angles_rad(tool, cut)
    scale = tool.teeth * np.asarray(cut.axial_depth_mm, dtype=float) / (2.0 * math.pi)
    factor = coefficients.pressure_factor(mean_chip_thickness_mm(tool, cut))
    # the antiderivatives are affine in the cutting scale cs = c * factor(h_m), h_m ~ c,
    # so d(cs)/dc = (1 - x) * factor
    one, zero = np.float64(1.0), np.float64(0.0)
    per_cs = [
        (g1e - g1s) - (g0e - g0s)
        for g1e, g1s, g0e, g0s in zip(
            _element_antiderivatives(ex, one, coefficients),
            _element_antiderivatives(st, one, coefficients),
            _element_antiderivatives(ex, zero, coefficients),
            _element_antiderivatives(st, zero, coefficients),
            strict=True,
        )
    ]
    dc_dv = 1.0 / (tool.teeth * cut.spindle_speed_rpm)
    grads = [scale * g * (1.0 - x) * factor * dc_dv for g in per_cs]
    if component == "resultant_xy":
        total = average_forces(tool, cut, coefficients)
        fx, fy = np.broadcast_arrays(total.feed_N, total.normal_N)
        gx, gy = np.broadcast_arrays(grads[0], grads[1])
        mag = np.hypot(fx, fy)
        out = np.array(np.hypot(gx, gy), dtype=float)  # an ndarray even for scalar cuts
        return np.divide(fx * gx + fy * gy, mag, out=out, where=mag > 0)
    index = ("feed", "normal", "tangential", "axial").index(component)
    return np.asarray(grads[index])
