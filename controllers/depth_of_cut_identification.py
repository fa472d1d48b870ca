"""Identification of the radial and axial depth of cut from average forces (Kim & Chung 2.3).

The paper identifies the radial immersion ``R_r = a_e / R`` from "the force ratio of
average feed force to average tangential force" and the axial depth from the force
magnitude (Fig. 5).  Average forces (:mod:`plants.end_mill_geometry`) have the form
``mean F = a * g(theta, c)``: the axial depth ``a`` only scales them, so a ratio of two
components depends on the engagement angle ``theta`` (and the known feed per tooth ``c``)
alone, and once ``theta`` is known ``a`` follows from the magnitude by least squares.

Choice of the immersion quantity
--------------------------------
A plain ratio is a poor choice.  In down-milling the average feed force changes sign as
the immersion grows (it pushes the workpiece along the feed at small immersion and against
it near a slot), so any ratio with ``F_x`` in the denominator has a pole, and ``F_y``
changes sign in up-milling.  ``F_x / F_t`` has no pole, but in up-milling it *rises* before
it falls (for ``r_t = 0.3`` it peaks at ``a_e`` near 0.6 mm on a 16 mm tool), so small
immersions cannot be told apart by it.

This module uses the force rotated by the force angle ``atan(r_t)``, ``r_t = K_rc / K_tc``::

    q = (F_x + r_t F_y) / ((1 + r_t^2) F_t)

For the paper's element law (Eq. 1, ``dF_r = r_t dF_t``) the rotation turns each element
force into ``dF_t (cos phi, sin phi)``, so ``q`` is the ``dF_t``-weighted mean of
``cos phi`` over the engaged arc.  ``F_t > 0`` (no pole), and as the arc grows it only adds
angles whose cosine is below (up-milling) or above (down-milling) every cosine already in
the arc, so ``q`` is strictly monotonic over the whole immersion range for any positive
tangential element force, including a chip-thickness-dependent ``K_s`` and edge forces with
``K_re / K_te = r_t``.  For constant ``K_s`` and no edge force it is linear in the radial
depth: ``q = +-(1 - a_e / (2R))`` (+ up, - down).

With edge coefficients of another ratio, ``q`` is monotonic only above a small radial
depth (about 0.5 mm for the default Al7075 coefficients at 0.05 mm/tooth, up-milling);
:func:`identify_depth_of_cut` inverts the model on the monotonic branch that reaches the
slot, reports the smallest identifiable depth and flags samples below it.  Only ``F_x`` and
``F_t`` are available from the feed and spindle motor currents; for that case
``method="feed_tangential"`` inverts the paper's ratio ``F_x / F_t`` on its monotonic branch
(again with the smallest identifiable depth reported).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize.elementwise import find_root

from plants.cutting_coefficients import CuttingCoefficients
from plants.end_mill_geometry import (
    CuttingForces,
    EndMill,
    MillingCut,
    average_forces,
    radial_depth_from_engagement,
)

IDENTIFICATION_METHODS = ("rotated", "feed_tangential")
#: Engagement grid [rad] used to find the monotonic branch (uniform in angle).
_GRID_POINTS = 1025


def immersion_quantity(
    feed_N: ArrayLike, normal_N: ArrayLike, tangential_N: ArrayLike, radial_ratio: float
) -> NDArray[np.float64]:
    """Rotated-force immersion quantity ``q = (F_x + r F_y) / ((1 + r^2) F_t)`` [-].

    Parameters
    ----------
    feed_N, normal_N, tangential_N : array_like, broadcast together
        Average feed, normal and tangential forces [N] (frame of
        :mod:`plants.end_mill_geometry`), ``F_t > 0``.
    radial_ratio : float
        ``r_t = K_rc / K_tc`` [-].

    Returns
    -------
    ndarray
        ``q`` in [0, 1] in up- and [-1, 0] in down-milling for the paper's force law.
    """
    ft = np.asarray(tangential_N, dtype=float)
    r = float(radial_ratio)
    return (np.asarray(feed_N, dtype=float) + r * np.asarray(normal_N, dtype=float)) / (
        (1.0 + r * r) * ft
    )


@dataclass(frozen=True, eq=False)
class DepthOfCutEstimate:
    """Identified depths of cut.

    Attributes
    ----------
    radial_depth_mm : ndarray, shape (n,)
        Radial depth ``a_e`` [mm].
    axial_depth_mm : ndarray, shape (n,)
        Axial depth ``a`` [mm].
    identifiable : ndarray of bool, shape (n,)
        False where the measured quantity lies outside the monotonic branch of the model
        (the estimate is then clipped to the branch end).
    min_identifiable_radial_depth_mm : ndarray, shape (n,)
        Smallest radial depth the quantity identifies uniquely at each sample's feed [mm].
    """

    radial_depth_mm: NDArray[np.float64]
    axial_depth_mm: NDArray[np.float64]
    identifiable: NDArray[np.bool_]
    min_identifiable_radial_depth_mm: NDArray[np.float64]



def _unit_forces(
    tool: EndMill,
    coefficients: CuttingCoefficients,
    theta: NDArray[np.float64],
    c: NDArray[np.float64],
    mode: str,
) -> CuttingForces:
    """Average forces per mm of axial depth at engagement ``theta`` [rad] and feed ``c``."""
    ae = np.clip(radial_depth_from_engagement(tool, theta), 0.0, tool.diameter_mm)
    cut = MillingCut(radial_depth_mm=ae, axial_depth_mm=1.0, feed_per_tooth_mm=c, mode=mode)
    return average_forces(tool, cut, coefficients)


def _quantity(forces: CuttingForces, method: str, radial_ratio: float) -> NDArray[np.float64]:
    if method == "rotated":
        return immersion_quantity(forces.feed_N, forces.normal_N, forces.tangential_N,
                                  radial_ratio)
    return np.asarray(forces.feed_N) / np.asarray(forces.tangential_N)


def identify_depth_of_cut(
    tool: EndMill,
    coefficients: CuttingCoefficients,
    feed_per_tooth_mm: ArrayLike,
    mode: str,
    feed_force_N: ArrayLike,
    tangential_force_N: ArrayLike,
    normal_force_N: ArrayLike | None = None,
    method: str = "rotated",
) -> DepthOfCutEstimate:
    """Radial and axial depth of cut from average forces over a tooth period.

    The engagement angle solves ``quantity_model(theta, c) = quantity_measured`` by a
    bracketed root search (``scipy.optimize.elementwise.find_root``) on the monotonic
    branch of the model that ends at a slot; the axial depth is then the least-squares
    scale of the model forces per mm of axial depth onto the measured forces.

    Parameters
    ----------
    tool : EndMill
    coefficients : CuttingCoefficients
        Model of the tool-material pair (as used to predict the forces).
    feed_per_tooth_mm : array_like, shape (n,) or scalar
        Feed per tooth at each sample [mm], > 0 (from the commanded feedrate).
    mode : {"up", "down"}
        Milling mode (known from the tool path).
    feed_force_N, tangential_force_N : array_like, shape (n,)
        Average feed force and tangential force [N].
    normal_force_N : array_like, shape (n,), optional
        Average normal force [N]; required by ``method="rotated"``.
    method : {"rotated", "feed_tangential"}
        ``"rotated"``: the monotonic quantity ``q`` of :func:`immersion_quantity`, with
        ``F_x, F_y, F_t``.  ``"feed_tangential"``: the paper's ratio ``F_x / F_t``.

    Returns
    -------
    DepthOfCutEstimate
    """
    if method not in IDENTIFICATION_METHODS:
        raise ValueError(f"method must be one of {IDENTIFICATION_METHODS}, got {method!r}")
    if mode not in ("up", "down"):
        raise ValueError(f"mode must be 'up' or 'down', got {mode!r}")
    fx = np.atleast_1d(np.asarray(feed_force_N, dtype=float))
    ft = np.atleast_1d(np.asarray(tangential_force_N, dtype=float))
    if fx.ndim != 1 or fx.shape != ft.shape:
        raise ValueError("feed_force_N and tangential_force_N must be 1-D of equal length")
    n = fx.size
    c = np.broadcast_to(np.asarray(feed_per_tooth_mm, dtype=float), (n,))
    if np.any(~np.isfinite(c)) or np.any(c <= 0):
        raise ValueError("feed_per_tooth_mm must be finite and > 0")
    if np.any(ft <= 0):
        raise ValueError("tangential_force_N must be > 0 (the tool must be cutting)")
    if method == "rotated":
        if normal_force_N is None:
            raise ValueError("normal_force_N is required by method='rotated'")
        fy = np.atleast_1d(np.asarray(normal_force_N, dtype=float))
        if fy.shape != fx.shape:
            raise ValueError("normal_force_N must have the shape of feed_force_N")
        measured = CuttingForces(fx, fy, ft, np.zeros(n))
    else:
        fy = None
        measured = CuttingForces(fx, np.zeros(n), ft, np.zeros(n))
    r = coefficients.radial_ratio
    target = _quantity(measured, method, r)

    # monotonic branch of the model that ends at the slot, per sample
    grid = np.linspace(0.0, np.pi, _GRID_POINTS)[1:]
    q_grid = _quantity(_unit_forces(tool, coefficients, grid[None, :], c[:, None], mode),
                       method, r)
    direction = np.sign(q_grid[:, -1] - q_grid[:, 0])[:, None]
    wrong = np.diff(q_grid, axis=1) * direction <= 0
    last_wrong = np.where(wrong.any(axis=1),
                          wrong.shape[1] - np.argmax(wrong[:, ::-1], axis=1), 0)
    theta_lo = grid[last_wrong]
    q_lo = q_grid[np.arange(n), last_wrong]
    q_hi = q_grid[:, -1]
    lo_bound, hi_bound = np.minimum(q_lo, q_hi), np.maximum(q_lo, q_hi)
    slack = 1e-12 * np.maximum(np.abs(lo_bound), np.abs(hi_bound))  # round-off at the ends
    inside = (target >= lo_bound - slack) & (target <= hi_bound + slack)
    clipped = np.clip(target, lo_bound, hi_bound)

    def residual(theta: NDArray[np.float64], goal: NDArray[np.float64],
                 feed: NDArray[np.float64]) -> NDArray[np.float64]:
        return _quantity(_unit_forces(tool, coefficients, theta, feed, mode), method, r) - goal

    result = find_root(residual, (theta_lo, np.full(n, np.pi)), args=(clipped, c),
                       tolerances={"xatol": 1e-13, "xrtol": 1e-13})
    theta = np.where(clipped == q_lo, theta_lo, np.where(clipped == q_hi, np.pi, result.x))
    ae = np.clip(radial_depth_from_engagement(tool, theta), 0.0, tool.diameter_mm)

    unit = _unit_forces(tool, coefficients, theta, c, mode)
    model = [np.asarray(unit.feed_N), np.asarray(unit.tangential_N)]
    data = [fx, ft]
    if fy is not None:
        model.append(np.asarray(unit.normal_N))
        data.append(fy)
    numerator = sum(m * d for m, d in zip(model, data, strict=True))
    denominator = sum(m * m for m in model)
    axial = np.maximum(numerator / denominator, 0.0)
    return DepthOfCutEstimate(
        radial_depth_mm=ae,
        axial_depth_mm=axial,
        identifiable=inside,
        min_identifiable_radial_depth_mm=radial_depth_from_engagement(tool, theta_lo)
        * (last_wrong > 0),
    )


def radial_immersion_ratio(tool: EndMill, estimate: DepthOfCutEstimate) -> NDArray[np.float64]:
    """Radial immersion ratio ``R_r = a_e / R`` [-] (the paper's Fig. 5 abscissa)."""
    return estimate.radial_depth_mm / tool.radius_mm


def axial_immersion_ratio(tool: EndMill, estimate: DepthOfCutEstimate) -> NDArray[np.float64]:
    """Axial immersion ratio ``R_a = a / R`` [-] as defined in the paper."""
    return estimate.axial_depth_mm / tool.radius_mm

