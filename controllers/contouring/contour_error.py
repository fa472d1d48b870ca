"""Contour error: the exact distance to the path and its estimates, in one sign convention.

Sign convention (spec O-21), used by every function of this module
------------------------------------------------------------------
Axis errors are ``E_x = x_R - x_P`` and ``E_y = y_R - y_P`` [mm]: reference point ``R`` minus
actual tool point ``P`` (the following errors of the two axes).  ``alpha`` [rad] is the
angle of the path tangent at ``R`` from the +x axis in the direction of motion,
``alpha = atan2(v_y, v_x)`` of the reference velocity.  With the right-hand normal
``n = (sin alpha, -cos alpha)``, the **contour error is positive when the tool lies to the
right of the direction of motion** and negative when it lies to the left.  All lengths are
in mm (any one length unit works, as long as every argument uses it); angles in rad.

* Peng's linear estimate (4.78), ``e_c = E_y cos alpha - E_x sin alpha = (P - R).n``, has
  this sign as printed (:func:`linear_estimate`).
* Lacerda & Belo's Eq. (11), ``eps = E_x sin alpha - E_y cos alpha``, is its negative
  (positive to the left); :func:`lacerda_eq11` returns Eq. (11) as printed, so
  ``lacerda_eq11 == -linear_estimate`` exactly.  Everything else here is in Peng's sign.
* On a counter-clockwise circle the right of the motion is the outside, so the contour
  error equals the radial deviation ``|P - C| - r``; on a clockwise circle (Peng's
  (4.104)/(4.105) runs clockwise from (0, R)) it is minus the radial deviation.

Estimates
---------
``linear``  (4.78): the offset of ``P`` from the tangent line at ``R``; exact on straight
            paths.
``Eq. 16``  [RECON] (spec M1-4; the paper's equation is an image missing from the text):
            ``e_16 = e_lin - s r (1 - cos gamma)`` where ``s = sign(n.(C - R))`` is +1 when
            the centre of curvature ``C`` lies to the right of the motion, ``r`` is the
            instantaneous radius and ``gamma`` the arc angle from ``R`` to the path point
            nearest ``P``: ``gamma = |E|/r`` (the paper's chord reading, default) or
            ``sin gamma = (E_x cos alpha + E_y sin alpha)/r`` (``tangent_lag``, exact for a
            tool that only lags on a circle).  In Lacerda's sign this is the printed form
            ``eps_16 = eps_11 + sigma r (1 - cos gamma)`` with ``sigma = s``.  On a straight
            path (``r = inf``) ``e_16 = e_lin``.
``exact``   the signed distance from ``P`` to the path: to a circle in closed form
            (:func:`exact_circle_error`), to a polyline by the nearest point
            (:func:`distance_to_polyline`).

For a tool lagging a circle by the angle ``phi`` (``P`` on the circle, so the exact error is
0), ``e_lin`` is off by ``r (1 - cos phi)`` and the chord ``e_16`` by
``r |cos(2 sin(phi/2)) - cos phi| ~ r phi^4/24``.

Every per-sample law is a scalar function compiled with :func:`acc.engine.element.jit`, so
a compiled loop (the cross-coupled controller) calls it directly; the vectorised functions
(names without the ``_at`` suffix are the array forms) run the same compiled laws over
traces.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import jit

#: Curvature-angle readings of Eq. 16 (codes passed to the compiled law).
CURVATURE_ANGLES = {"chord": 0, "tangent_lag": 1}
#: Default collinearity tolerance of :func:`circumcircle_at`: ``|d| < tol * (longest side)^2``.
COLLINEAR_TOLERANCE = 1e-9


# --- compiled scalar laws ---------------------------------------------------------------
@jit
def linear_estimate_at(error_x_mm: float, error_y_mm: float, tangent_angle_rad: float) -> float:
    """Peng's linear contour-error estimate (4.78) [mm], positive with the tool to the right.

    Parameters
    ----------
    error_x_mm, error_y_mm : float
        Axis errors ``E = R - P`` [mm].
    tangent_angle_rad : float
        Path tangent angle at ``R`` from +x in the direction of motion [rad].

    Returns
    -------
    float
        ``E_y cos(alpha) - E_x sin(alpha)`` [mm].
    """
    return error_y_mm * math.cos(tangent_angle_rad) - error_x_mm * math.sin(tangent_angle_rad)


@jit
def lacerda_eq11_at(error_x_mm: float, error_y_mm: float, tangent_angle_rad: float) -> float:
    """Lacerda & Belo's Eq. (11) as printed, ``E_x sin(alpha) - E_y cos(alpha)`` [mm]:
    positive with the tool to the **left**; equals ``-linear_estimate_at`` exactly."""
    return -linear_estimate_at(error_x_mm, error_y_mm, tangent_angle_rad)


@jit
def curvature_corrected_estimate_at(
    error_x_mm: float,
    error_y_mm: float,
    tangent_angle_rad: float,
    reference_x_mm: float,
    reference_y_mm: float,
    centre_x_mm: float,
    centre_y_mm: float,
    radius_mm: float,
    curvature_angle: int,
) -> float:
    """Curvature-corrected contour error, Eq. (16) [RECON], in Peng's sign [mm].

    Parameters
    ----------
    error_x_mm, error_y_mm : float
        Axis errors ``E = R - P`` [mm].
    tangent_angle_rad : float
        Path tangent angle at ``R`` [rad] (direction of motion).
    reference_x_mm, reference_y_mm : float
        The reference point ``R`` [mm].
    centre_x_mm, centre_y_mm : float
        Instantaneous centre of curvature ``C`` [mm]; NaN on a straight part.
    radius_mm : float
        Instantaneous radius ``r`` [mm], > 0; ``inf`` (or NaN) on a straight part.
    curvature_angle : int
        0: ``gamma = |E|/r`` (chord, the paper); 1: ``sin gamma = E.t/r`` (tangent lag).

    Returns
    -------
    float
        ``e_lin - s r (1 - cos gamma)``, ``s = +1`` when ``C`` lies to the right of the
        motion, -1 to the left [mm]; ``e_lin`` when the path is straight here.
    """
    e_lin = linear_estimate_at(error_x_mm, error_y_mm, tangent_angle_rad)
    r = radius_mm
    if not (r > 0.0 and r < math.inf) or centre_x_mm != centre_x_mm or centre_y_mm != centre_y_mm:
        return e_lin
    ca = math.cos(tangent_angle_rad)
    sa = math.sin(tangent_angle_rad)
    side = sa * (centre_x_mm - reference_x_mm) - ca * (centre_y_mm - reference_y_mm)
    s = 1.0 if side > 0.0 else (-1.0 if side < 0.0 else 0.0)
    if curvature_angle == 1:
        sg = (error_x_mm * ca + error_y_mm * sa) / r
        if sg > 1.0:
            sg = 1.0
        elif sg < -1.0:
            sg = -1.0
        one_minus_cos = sg * sg / (1.0 + math.sqrt(1.0 - sg * sg))  # 1 - cos(asin(sg))
    else:
        g = math.sqrt(error_x_mm * error_x_mm + error_y_mm * error_y_mm) / r
        h = math.sin(0.5 * g)
        one_minus_cos = 2.0 * h * h  # 1 - cos g without cancellation
    return e_lin - s * r * one_minus_cos


@jit
def exact_circle_error_at(
    x_mm: float, y_mm: float, centre_x_mm: float, centre_y_mm: float, radius_mm: float,
    turn: float,
) -> float:
    """Exact contour error of the tool ``(x, y)`` on a circle [mm], Peng's sign.

    Parameters
    ----------
    x_mm, y_mm : float
        Tool position ``P`` [mm].
    centre_x_mm, centre_y_mm, radius_mm : float
        The circle [mm].
    turn : float
        +1 for counter-clockwise motion (centre on the left), -1 for clockwise.

    Returns
    -------
    float
        ``turn (|P - C| - r)``: the radial deviation (Lacerda's Eq. 17, + outside) on a
        counter-clockwise circle, its negative on a clockwise one [mm].
    """
    return turn * (math.hypot(x_mm - centre_x_mm, y_mm - centre_y_mm) - radius_mm)


@jit
def circumcircle_at(
    x1: float, y1: float, x2: float, y2: float, x3: float, y3: float, collinear_tolerance: float
) -> tuple[float, float, float]:
    """Circle through three points (Lacerda & Belo 1997b, spec M1-4) [mm].

    Parameters
    ----------
    x1, y1, x2, y2, x3, y3 : float
        The points [mm] (the reference at ``k-1, k, k+1``).
    collinear_tolerance : float
        The points count as collinear when ``|d| < tol * (longest side)^2`` with
        ``d = 2[x1(y2 - y3) + x2(y3 - y1) + x3(y1 - y2)]`` (twice the signed doubled area).

    Returns
    -------
    centre_x_mm, centre_y_mm, radius_mm : float
        The centre and radius; ``(nan, nan, inf)`` for collinear (or coincident) points.
    """
    # relative to point 1 for accuracy on small arcs far from the origin;
    # dd = 2[x1(y2 - y3) + x2(y3 - y1) + x3(y1 - y2)] rearranged
    bx, by = x2 - x1, y2 - y1
    cx, cy = x3 - x1, y3 - y1
    dd = 2.0 * (bx * cy - by * cx)
    side2 = max(bx * bx + by * by, (x3 - x2) ** 2 + (y3 - y2) ** 2, cx * cx + cy * cy)
    if side2 == 0.0 or abs(dd) < collinear_tolerance * side2:
        return math.nan, math.nan, math.inf
    b2 = bx * bx + by * by
    c2 = cx * cx + cy * cy
    ux = (cy * b2 - by * c2) / dd
    uy = (bx * c2 - cx * b2) / dd
    return x1 + ux, y1 + uy, math.hypot(ux, uy)


@jit
def distance_to_polyline_at(
    x_mm: float, y_mm: float, path_x_mm: np.ndarray, path_y_mm: np.ndarray, first: int, last: int
) -> tuple[float, int, float]:
    """Signed distance from ``(x, y)`` to the polyline through ``path[first..last]`` [mm].

    Parameters
    ----------
    x_mm, y_mm : float
        Tool position ``P`` [mm].
    path_x_mm, path_y_mm : ndarray, shape (m,)
        Polyline vertices in the direction of motion [mm] (repeated vertices are skipped).
    first, last : int
        Vertex indices bounding the searched part (``0 <= first < last < m``).

    Returns
    -------
    distance_mm : float
        Distance to the nearest point of the polyline, positive when ``P`` lies to the right
        of the direction of motion (at a vertex, to the right of the bisector of the two
        segment normals, so the sign is that of the side of the path).
    segment : int
        Index ``i`` of the nearest segment ``[i, i+1]``.
    fraction : float
        Position of the nearest point on that segment, in [0, 1].
    """
    best = math.inf
    best_i = -1
    best_t = 0.0
    for i in range(first, last):
        ax, ay = path_x_mm[i], path_y_mm[i]
        dx, dy = path_x_mm[i + 1] - ax, path_y_mm[i + 1] - ay
        ll = dx * dx + dy * dy
        if ll == 0.0:
            continue
        t = ((x_mm - ax) * dx + (y_mm - ay) * dy) / ll
        t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        qx, qy = ax + t * dx - x_mm, ay + t * dy - y_mm
        d2 = qx * qx + qy * qy
        if d2 < best:
            best, best_i, best_t = d2, i, t
    if best_i < 0:
        return math.nan, -1, math.nan
    dist = math.sqrt(best)
    i = best_i
    ax, ay = path_x_mm[i], path_y_mm[i]
    dx, dy = path_x_mm[i + 1] - ax, path_y_mm[i + 1] - ay
    ln = math.sqrt(dx * dx + dy * dy)
    nx, ny = dy / ln, -dx / ln  # right-hand normal of segment i
    if best_t == 0.0 or best_t == 1.0:
        # nearest point is a vertex: use the sum of the adjacent segments' right normals
        j = i - 1 if best_t == 0.0 else i + 1
        v = i if best_t == 0.0 else i + 1
        if first <= j and j < last:
            bx, by = path_x_mm[j + 1] - path_x_mm[j], path_y_mm[j + 1] - path_y_mm[j]
            lb = math.sqrt(bx * bx + by * by)
            if lb > 0.0:
                nx, ny = nx + by / lb, ny - bx / lb
        px, py = x_mm - path_x_mm[v], y_mm - path_y_mm[v]
    else:
        px, py = x_mm - (ax + best_t * dx), y_mm - (ay + best_t * dy)
    side = px * nx + py * ny
    return (dist if side >= 0.0 else -dist), i, best_t


# --- compiled array loops (the same laws over traces) -------------------------------------
@jit(python_entry=True)
def _linear_many(ex, ey, a, out):  # noqa: ANN001, ANN202
    for i in range(out.shape[0]):
        out[i] = linear_estimate_at(ex[i], ey[i], a[i])


@jit(python_entry=True)
def _curvature_many(ex, ey, a, rx, ry, cx, cy, r, mode, out):  # noqa: ANN001, ANN202
    for i in range(out.shape[0]):
        out[i] = curvature_corrected_estimate_at(ex[i], ey[i], a[i], rx[i], ry[i], cx[i], cy[i],
                                                 r[i], mode)


@jit(python_entry=True)
def _circle_many(x, y, cx, cy, r, turn, out):  # noqa: ANN001, ANN202
    for i in range(out.shape[0]):
        out[i] = exact_circle_error_at(x[i], y[i], cx[i], cy[i], r[i], turn[i])


@jit(python_entry=True)
def _circumcircle_many(x1, y1, x2, y2, x3, y3, tol, cx, cy, r):  # noqa: ANN001, ANN202
    for i in range(cx.shape[0]):
        cx[i], cy[i], r[i] = circumcircle_at(x1[i], y1[i], x2[i], y2[i], x3[i], y3[i], tol)


@jit(python_entry=True)
def _polyline_many(x, y, px, py, out, seg, frac):  # noqa: ANN001, ANN202
    last = px.shape[0] - 1
    for i in range(out.shape[0]):
        out[i], seg[i], frac[i] = distance_to_polyline_at(x[i], y[i], px, py, 0, last)


def _arrays(*values: ArrayLike) -> list[NDArray[np.float64]]:
    arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in values))
    return [np.ascontiguousarray(a).ravel() for a in arrays]


def _shape(*values: ArrayLike) -> tuple[int, ...]:
    return np.broadcast_shapes(*(np.shape(v) for v in values))


# --- vectorised forms ------------------------------------------------------------------------
def linear_estimate(
    error_x_mm: ArrayLike, error_y_mm: ArrayLike, tangent_angle_rad: ArrayLike
) -> NDArray[np.float64]:
    """Peng's (4.78) over arrays (broadcast; e.g. shape (n,)) [mm]; see
    :func:`linear_estimate_at`.  Positive with the tool to the right of the motion."""
    shape = _shape(error_x_mm, error_y_mm, tangent_angle_rad)
    ex, ey, a = _arrays(error_x_mm, error_y_mm, tangent_angle_rad)
    out = np.empty(ex.size)
    _linear_many(ex, ey, a, out)
    return out.reshape(shape)


def lacerda_eq11(
    error_x_mm: ArrayLike, error_y_mm: ArrayLike, tangent_angle_rad: ArrayLike
) -> NDArray[np.float64]:
    """Lacerda & Belo's Eq. (11) as printed over arrays [mm]: positive to the **left**,
    ``-linear_estimate``."""
    return -linear_estimate(error_x_mm, error_y_mm, tangent_angle_rad)


def curvature_corrected_estimate(
    error_x_mm: ArrayLike,
    error_y_mm: ArrayLike,
    tangent_angle_rad: ArrayLike,
    reference_mm: ArrayLike,
    centre_mm: ArrayLike,
    radius_mm: ArrayLike,
    curvature_angle: str = "chord",
) -> NDArray[np.float64]:
    """Eq. (16) [RECON] over arrays, Peng's sign [mm]; see :func:`curvature_corrected_estimate_at`.

    Parameters
    ----------
    error_x_mm, error_y_mm, tangent_angle_rad : array_like, shape (n,)
        ``E = R - P`` [mm] and the tangent angle [rad].
    reference_mm, centre_mm : array_like, shape (n, 2)
        Reference point ``R`` and centre of curvature ``C`` (NaN on straight parts) [mm].
    radius_mm : array_like, shape (n,)
        Instantaneous radius [mm] (``inf`` on straight parts).
    curvature_angle : {"chord", "tangent_lag"}

    Returns
    -------
    ndarray, shape (n,)
    """
    if curvature_angle not in CURVATURE_ANGLES:
        raise ValueError(f"curvature_angle must be one of {', '.join(CURVATURE_ANGLES)}, got "
                         f"{curvature_angle!r}")
    ref = np.asarray(reference_mm, dtype=float)
    cen = np.asarray(centre_mm, dtype=float)
    shape = _shape(error_x_mm, error_y_mm, tangent_angle_rad, ref[..., 0], cen[..., 0], radius_mm)
    cols = _arrays(error_x_mm, error_y_mm, tangent_angle_rad, ref[..., 0], ref[..., 1],
                   cen[..., 0], cen[..., 1], radius_mm)
    out = np.empty(cols[0].size)
    _curvature_many(*cols, CURVATURE_ANGLES[curvature_angle], out)
    return out.reshape(shape)


def exact_circle_error(
    position_mm: ArrayLike, centre_mm: ArrayLike, radius_mm: ArrayLike, turn: ArrayLike
) -> NDArray[np.float64]:
    """Exact contour error on a circle over arrays [mm], Peng's sign.

    Parameters
    ----------
    position_mm : array_like, shape (n, 2)
        Tool positions [mm].
    centre_mm : array_like, shape (2,) or (n, 2)
    radius_mm : array_like, scalar or shape (n,)
    turn : array_like, scalar or shape (n,)
        +1 counter-clockwise, -1 clockwise.

    Returns
    -------
    ndarray, shape (n,)
        ``turn (|P - C| - r)``.
    """
    p = np.asarray(position_mm, dtype=float)
    c = np.asarray(centre_mm, dtype=float)
    shape = _shape(p[..., 0], c[..., 0], radius_mm, turn)
    cols = _arrays(p[..., 0], p[..., 1], c[..., 0], c[..., 1], radius_mm, turn)
    out = np.empty(cols[0].size)
    _circle_many(*cols, out)
    return out.reshape(shape)


def circumcircle(
    p1_mm: ArrayLike, p2_mm: ArrayLike, p3_mm: ArrayLike,
    collinear_tolerance: float = COLLINEAR_TOLERANCE,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Circle through three points (arrays of points, shape (..., 2)) [mm].

    Returns
    -------
    centre_mm : ndarray, shape (..., 2)
        NaN for collinear points.
    radius_mm : ndarray, shape (...)
        ``inf`` for collinear points.
    """
    a, b, c = (np.asarray(p, dtype=float) for p in (p1_mm, p2_mm, p3_mm))
    shape = _shape(a[..., 0], b[..., 0], c[..., 0])
    cols = _arrays(a[..., 0], a[..., 1], b[..., 0], b[..., 1], c[..., 0], c[..., 1])
    cx, cy, r = (np.empty(cols[0].size) for _ in range(3))
    _circumcircle_many(*cols, float(collinear_tolerance), cx, cy, r)
    return np.stack([cx, cy], axis=-1).reshape(*shape, 2), r.reshape(shape)


def path_circumcircles(
    path_mm: ArrayLike, lookahead: bool = False,
    collinear_tolerance: float = COLLINEAR_TOLERANCE,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Instantaneous centre and radius of a sampled reference from three consecutive points.

    Parameters
    ----------
    path_mm : array_like, shape (n, 2)
        Reference positions at ``t_k`` [mm].
    lookahead : bool
        False: points ``k-1, k, k+1`` (default [ASSUMED], spec M1-4); True: ``k, k+1, k+2``.
        Where a point is missing at the ends, the nearest complete triple is used.

    Returns
    -------
    centre_mm : ndarray, shape (n, 2)
    radius_mm : ndarray, shape (n,)
    """
    p = np.asarray(path_mm, dtype=float)
    n = p.shape[0]
    if n < 3:
        raise ValueError("path_mm needs at least 3 points")
    k = np.arange(n)
    first = np.clip(k if lookahead else k - 1, 0, n - 3)
    return circumcircle(p[first], p[first + 1], p[first + 2], collinear_tolerance)


def distance_to_polyline(
    position_mm: ArrayLike, path_mm: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Exact signed distance of tool points to a polyline path [mm], Peng's sign.

    Parameters
    ----------
    position_mm : array_like, shape (n, 2)
        Tool positions [mm].
    path_mm : array_like, shape (m, 2)
        Polyline vertices in the direction of motion [mm], m >= 2 (a densely sampled
        curve works as its chord polyline).

    Returns
    -------
    distance_mm : ndarray, shape (n,)
        Positive to the right of the motion (see :func:`distance_to_polyline_at`).
    segment : ndarray of int, shape (n,)
    fraction : ndarray, shape (n,)
    """
    p = np.atleast_2d(np.asarray(position_mm, dtype=float))
    path = np.asarray(path_mm, dtype=float)
    if path.ndim != 2 or path.shape[0] < 2 or path.shape[1] != 2:
        raise ValueError("path_mm must have shape (m, 2) with m >= 2")
    out = np.empty(p.shape[0])
    seg = np.empty(p.shape[0], dtype=np.int64)
    frac = np.empty(p.shape[0])
    _polyline_many(np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1]),
                   np.ascontiguousarray(path[:, 0]), np.ascontiguousarray(path[:, 1]),
                   out, seg, frac)
    return out, seg, frac


__all__ = [
    "COLLINEAR_TOLERANCE",
    "CURVATURE_ANGLES",
    "circumcircle",
    "circumcircle_at",
    "curvature_corrected_estimate",
    "curvature_corrected_estimate_at",
    "distance_to_polyline",
    "distance_to_polyline_at",
    "exact_circle_error",
    "exact_circle_error_at",
    "lacerda_eq11",
    "lacerda_eq11_at",
    "linear_estimate",
    "linear_estimate_at",
    "path_circumcircles",
]
