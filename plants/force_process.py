"""First-order milling force process, Kim & Chung Eq. (7) and Table 1.

.. math:: \\frac{f(s)}{v(s)} = \\frac{K_2}{s - p_2}

from feed velocity ``v`` [mm/min] to cutting force ``f`` [N].  ``K2`` [N/(mm/min)/s] and the
pole ``p2`` [rad/s] depend on the radial depth of cut; the default table is the paper's
Table 1 (16 mm, 4-tooth flat end mill at 600 rpm).

Realisation.  The process is realised as ``f = G(d) x`` with the static gain
``G = K2 / (-p2)`` [N/(mm/min)] and a unit-DC-gain chip-load state ``x`` [mm/min] that
follows the feed, ``dx/dt = p2 (x - v)``.  For a constant depth this is exactly Eq. (7).
When the depth changes, the force changes at once by the ratio of static gains, as the
chip area does, and then relaxes with the new pole.  In an air cut (depth 0) there is no
chip: the gain is zero and ``x`` equals the feed velocity, so the tool enters the material
with the chip load of the feed it arrives at, however long the approach was.

Discretisation.  Between plant steps the feed velocity follows the feed drive's
first-order lag towards the delayed command ``u_d``; the update of ``x`` integrates that
exactly (see :func:`cascade_coefficients`), so a constant-depth loop is the exact
zero-order-hold discretisation of Eq. (8).
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, record, register_element
from plants.workpiece import segment_size

OUT_OF_TABLE_POLICIES = ("error", "clamp", "extrapolate")


class OutOfTableError(ValueError):
    """A radial depth of cut outside the process table."""


@dataclass(frozen=True)
class ForceProcessTable:
    """Process gain and pole against radial depth of cut (Table 1 by default).

    Attributes
    ----------
    radial_depth_mm : tuple of float, shape (m,)
        Table radial depths [mm], strictly increasing, > 0.
    k2_N_min_per_mm_s : tuple of float, shape (m,)
        Process gain ``K2`` [N/(mm/min)/s].
    p2_rad_s : tuple of float, shape (m,)
        Process pole ``p2`` [rad/s], < 0.
    out_of_table : {"error", "clamp", "extrapolate"}
        What a depth outside the table does: an error, the nearest row, or linear
        extrapolation of ``K2`` and ``p2`` from the two nearest rows.
    gain_multiplier : float
        Factor on ``K2`` [-] (material harder or softer than the table's).
    reference_axial_depth_mm : float
        Axial depth of cut the table holds at [mm], > 0.  A segment cut at axial depth
        ``a`` has its static gain (and ``K2``) times ``a / reference``, as the geometric
        model's tooth-period average, which is exactly proportional to the axial depth
        (Eq. 2).  The paper does not state Table 1's axial depth; 10 mm (the shipped part's)
        is assumed.
    """

    radial_depth_mm: tuple[float, ...] = (2.0, 3.0, 4.0)
    k2_N_min_per_mm_s: tuple[float, ...] = (10.05, 12.57, 20.11)
    p2_rad_s: tuple[float, ...] = (-2.35, -3.75, -5.35)
    out_of_table: str = "error"
    gain_multiplier: float = 1.0
    reference_axial_depth_mm: float = 10.0

    def __post_init__(self) -> None:
        d = np.asarray(self.radial_depth_mm, dtype=float)
        if not (len(d) == len(self.k2_N_min_per_mm_s) == len(self.p2_rad_s)) or len(d) == 0:
            raise ValueError("radial_depth_mm, k2 and p2 tables must have the same length >= 1")
        if np.any(d <= 0) or np.any(np.diff(d) <= 0):
            raise ValueError("table radial_depth_mm must be > 0 and strictly increasing")
        if np.any(np.asarray(self.k2_N_min_per_mm_s) <= 0):
            raise ValueError("table k2 values must be > 0")
        if np.any(np.asarray(self.p2_rad_s) >= 0):
            raise ValueError("table p2 poles must be < 0 (a stable force process)")
        if self.out_of_table not in OUT_OF_TABLE_POLICIES:
            raise ValueError(f"out_of_table must be one of {OUT_OF_TABLE_POLICIES}")
        if not self.gain_multiplier > 0:
            raise ValueError("gain_multiplier must be > 0")
        if not self.reference_axial_depth_mm > 0:
            raise ValueError(
                f"reference_axial_depth_mm must be > 0, got {self.reference_axial_depth_mm}"
            )

    def check_depth(self, radial_depth_mm: float) -> None:
        """Raise :class:`OutOfTableError` if a cutting depth is outside a strict table."""
        lo, hi = self.radial_depth_mm[0], self.radial_depth_mm[-1]
        if radial_depth_mm < 0:
            raise OutOfTableError(f"radial depth {radial_depth_mm} mm is negative")
        if self.out_of_table == "error" and radial_depth_mm > 0:
            if not lo <= radial_depth_mm <= hi:
                raise OutOfTableError(
                    f"radial depth {radial_depth_mm} mm is outside the process table "
                    f"[{lo}, {hi}] mm (set out_of_table = 'clamp' or 'extrapolate' to allow)"
                )

    @cached_property
    def _table(self) -> tuple[NDArray, NDArray, NDArray]:
        """The table's depths, ``K2`` and ``p2`` as float arrays (built once per table)."""
        return (np.asarray(self.radial_depth_mm, dtype=float),
                np.asarray(self.k2_N_min_per_mm_s, dtype=float),
                np.asarray(self.p2_rad_s, dtype=float))

    def check_depths(self, radial_depth_mm: ArrayLike) -> None:
        """:meth:`check_depth` of every depth at once: the first one that fails (in C order)
        raises its error."""
        d = np.asarray(radial_depth_mm, dtype=float).ravel()
        fails = d < 0
        if self.out_of_table == "error":
            lo, hi = self.radial_depth_mm[0], self.radial_depth_mm[-1]
            fails |= (d > 0) & ((d < lo) | (d > hi))
        if fails.any():
            self.check_depth(float(d[fails.argmax()]))

    def parameters(self, radial_depth_mm: ArrayLike) -> tuple[NDArray, NDArray]:
        """Interpolated ``K2`` and ``p2`` at radial depths > 0.

        Parameters
        ----------
        radial_depth_mm : array_like, shape (n,)
            Radial depths [mm], > 0.

        Returns
        -------
        k2 : ndarray, shape (n,)
            ``K2`` times the gain multiplier [N/(mm/min)/s].
        p2 : ndarray, shape (n,)
            Pole [rad/s].
        """
        d = np.atleast_1d(np.asarray(radial_depth_mm, dtype=float))
        self.check_depths(d)
        xp, k2_table, p2_table = self._table
        k2 = _interp(d, xp, k2_table, self.out_of_table)
        p2 = _interp(d, xp, p2_table, self.out_of_table)
        if (k2 <= 0).any() or (p2 >= 0).any():
            raise OutOfTableError(
                "extrapolated process has K2 <= 0 or p2 >= 0 at radial depth(s) "
                f"{d[(k2 <= 0) | (p2 >= 0)].tolist()} mm"
            )
        return k2 * self.gain_multiplier, p2

    def static_gain_N_per_mm_min(self, radial_depth_mm: ArrayLike) -> NDArray[np.float64]:
        """Static force per feed ``G = K2 / (-p2)`` [N/(mm/min)]; zero at depth 0."""
        return self.segment_parameters(np.atleast_1d(np.asarray(radial_depth_mm, dtype=float)))[0]

    def largest_static_gain_N_per_mm_min(self, radial_depth_mm: Sequence[float]) -> float:
        """The largest static gain ``K2 / (-p2)`` over the depths > 0 of a part [N/(mm/min)]
        (NaN if none): :meth:`static_gain_N_per_mm_min`'s maximum, bit for bit.

        A loop over the part's few depths in Python floats (the same operations as
        ``numpy.interp`` and the extrapolation of :meth:`parameters`, in the same order)
        instead of the array path's twenty NumPy calls: a sweep's validation asks it of every
        run (2 against 19 us for a part of three segments).  The depths must have passed
        :meth:`check_depth` (and, extrapolating, :meth:`parameters`): no error is raised.
        """
        xp, k2_table, p2_table = self._rows
        largest = float("nan")
        for d in radial_depth_mm:
            if d > 0:
                k2 = _interp_one(d, xp, k2_table, self.out_of_table) * self.gain_multiplier
                gain = k2 / -_interp_one(d, xp, p2_table, self.out_of_table)
                if not gain <= largest:  # NaN at first
                    largest = gain
        return largest

    @cached_property
    def _rows(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
        """The table's depths, ``K2`` and ``p2`` as tuples of Python floats."""
        return tuple(self._table[0].tolist()), tuple(self._table[1].tolist()), tuple(
            self._table[2].tolist())

    def segment_parameters(
        self, radial_depth_mm: ArrayLike, axial_depth_mm: ArrayLike | None = None
    ) -> tuple[NDArray, NDArray]:
        """Static gain and pole of each segment of a part, air included.

        Parameters
        ----------
        radial_depth_mm : array_like, shape (segments,) or (parts, segments)
            Radial depth of each segment [mm]; 0 is air.
        axial_depth_mm : array_like, same shape, optional
            Axial depth of each segment [mm]; 0 is air; None: the reference axial depth.

        Returns
        -------
        static_gain_N_per_mm_min : ndarray, shape of ``radial_depth_mm``
            ``K2 / (-p2)`` times ``axial / reference_axial``; 0 in air.
        p2_rad_s : ndarray, shape of ``radial_depth_mm``
            Pole; in air the shallowest row's (unused there: the chip load equals the feed).
        """
        d = np.asarray(radial_depth_mm, dtype=float)
        gain = np.zeros(d.shape)
        p2 = np.full(d.shape, self.p2_rad_s[0])
        cut = d > 0
        if cut.any():
            k2_cut, p2_cut = self.parameters(d[cut])
            p2[cut] = p2_cut
            gain[cut] = k2_cut / (-p2_cut)
        if axial_depth_mm is not None:
            gain = gain * (np.asarray(axial_depth_mm, dtype=float) / self.reference_axial_depth_mm)
        return gain, np.where(gain > 0, p2, self.p2_rad_s[0])


def _interp(x: NDArray, xp: NDArray, fp: NDArray, policy: str) -> NDArray:
    if len(xp) == 1:
        return np.full_like(x, fp[0])
    y = np.interp(x, xp, fp)
    if policy == "extrapolate":
        lo, hi = x < xp[0], x > xp[-1]
        y[lo] = fp[0] + (x[lo] - xp[0]) * (fp[1] - fp[0]) / (xp[1] - xp[0])
        y[hi] = fp[-1] + (x[hi] - xp[-1]) * (fp[-1] - fp[-2]) / (xp[-1] - xp[-2])
    return y


def _interp_one(x: float, xp: Sequence[float], fp: Sequence[float], policy: str) -> float:
    """:func:`_interp` of one point > 0 in Python floats: ``numpy.interp``'s cases and formula
    (``slope * (x - xp[j]) + fp[j]``, an exact table point returned as it is), then the
    linear extrapolation of the ``"extrapolate"`` policy beyond either end."""
    n = len(xp)
    if n == 1:
        return fp[0]
    if x < xp[0]:
        if policy == "extrapolate":
            return fp[0] + (x - xp[0]) * (fp[1] - fp[0]) / (xp[1] - xp[0])
        return fp[0]
    if x > xp[-1]:
        if policy == "extrapolate":
            return fp[-1] + (x - xp[-1]) * (fp[-1] - fp[-2]) / (xp[-1] - xp[-2])
        return fp[-1]
    j = bisect.bisect_right(xp, x) - 1
    if j == n - 1 or xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]


def cascade_coefficients(
    p2_rad_s: ArrayLike, bandwidth_rad_s: ArrayLike, plant_step_s: float
) -> tuple[NDArray, NDArray, NDArray]:
    """Exact one-step coefficients of the chip-load state behind the feed drive.

    Over one step the feed velocity is ``v(t) = u_d + (v_k - u_d) exp(-a t)`` and
    ``dx/dt = p2 (x - v)``; integrating exactly,

    ``x[k+1] = phi x[k] + c_v v[k] + c_u u_d``, ``phi = exp(p2 dt)``,
    ``c_v = -p2 (phi - exp(-a dt)) / (p2 + a)``, ``c_u = 1 - phi - c_v``.

    For ``|z| = |p2 + a| dt < 1`` the ratio is evaluated with ``expm1`` so ``p2 = -a``
    needs no special case; beyond, directly (no overflow for very fast drives or poles).

    Parameters
    ----------
    p2_rad_s : array_like
        Process pole [rad/s] (any shape, broadcast with ``bandwidth_rad_s``).
    bandwidth_rad_s : array_like
        Feed-drive bandwidth ``a`` [rad/s].
    plant_step_s : float
        Plant step [s].

    Returns
    -------
    phi, c_v, c_u : ndarray
        Coefficients [-], broadcast shape of the inputs.
    """
    p = np.asarray(p2_rad_s, dtype=float)
    a = np.asarray(bandwidth_rad_s, dtype=float)
    dt = plant_step_s
    phi = np.exp(p * dt)
    ea = np.exp(-a * dt)
    z = (p + a) * dt
    small = np.abs(z) < 1.0
    safe = np.where(np.abs(z) < 1e-12, 1.0, np.where(small, z, 1.0))
    ratio = np.where(np.abs(z) < 1e-12, 1.0 + z / 2.0, np.expm1(safe) / safe)
    # (phi - exp(-a dt)) / (p + a) = exp(-a dt) * dt * expm1(z) / z
    c_v = np.where(small, -p * ea * dt * ratio, -p * (phi - ea) / np.where(small, 1.0, p + a))
    c_u = 1.0 - phi - c_v
    return phi, c_v, c_u


def _dtypes(segments: int = 8) -> tuple[np.dtype, np.dtype]:
    params = record(
        "force_process.table",
        [
            ("static_gain_N_per_mm_min", "f8", (segments,)),
            ("phi", "f8", (segments,)),
            ("c_v", "f8", (segments,)),
            ("c_u", "f8", (segments,)),
        ],
    )
    return params, record("force_process.table", [("chip_load_mm_min", "f8")])


@jit
def init(p, s) -> None:  # noqa: ANN001
    """No cut yet: zero chip load."""
    s.chip_load_mm_min = 0.0


@jit
def output(p, s, segment: int, k: int, position_mm: float) -> tuple[float, float, float]:  # noqa: ANN001
    """Force at the start of plant step ``k`` in ``segment`` at tool position
    ``position_mm`` [N]: ``(regulated, feed, cross-feed)``.

    The first two are ``G(segment) x`` (the table model's force acts along the feed), the
    cross-feed force is 0.
    """
    f = p.static_gain_N_per_mm_min[segment] * s.chip_load_mm_min
    return f, f, 0.0


@jit
def step(p, s, segment: int, velocity_mm_min: float, delayed_mm_min: float) -> None:  # noqa: ANN001
    """Advance the chip load over one plant step in ``segment`` (exact, see
    :func:`cascade_coefficients`), given the drive's velocity at the start of the step and
    the delayed command over it [mm/min].  Any force process with per-segment ``phi``,
    ``c_v``, ``c_u`` and a ``chip_load_mm_min`` state (the geometric one) uses this law."""
    s.chip_load_mm_min = (
        p.phi[segment] * s.chip_load_mm_min
        + p.c_v[segment] * velocity_mm_min
        + p.c_u[segment] * delayed_mm_min
    )


TABLE = register_element(
    "force_process.table",
    _dtypes,
    init,
    step,
    "milling force process of Eq. (7), Table 1 gain and pole per segment",
    output,
)


def chip_load_coefficients(
    static_gain_N_per_mm_min: NDArray, p2_rad_s: NDArray, bandwidth_rad_s: NDArray,
    plant_step_s: float,
) -> tuple[NDArray, NDArray, NDArray]:
    """``phi, c_v, c_u`` per run and segment, shape (runs, segments).

    :func:`cascade_coefficients` in the cut; in air (gain 0) the chip load is the feed
    velocity, ``x[k+1] = v[k+1]``, the drive's own exact update.
    """
    gain = np.asarray(static_gain_N_per_mm_min, dtype=float)
    pole = np.asarray(p2_rad_s, dtype=float)
    if np.any(pole >= 0):
        raise ValueError("process poles must be < 0")
    a = np.asarray(bandwidth_rad_s, dtype=float)[:, None]
    phi, c_v, c_u = cascade_coefficients(pole, a, plant_step_s)
    air = gain == 0
    phi_a = np.broadcast_to(np.exp(-a * plant_step_s), air.shape)
    return (
        np.where(air, 0.0, phi),
        np.where(air, phi_a, c_v),
        np.where(air, 1.0 - phi_a, c_u),
    )


def force_process_records(
    static_gain_N_per_mm_min: NDArray,
    p2_rad_s: NDArray,
    bandwidth_rad_s: NDArray,
    plant_step_s: float,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of force processes over stepped parts.

    Parameters
    ----------
    static_gain_N_per_mm_min : ndarray, shape (runs, segments)
        Static gain ``G`` per segment [N/(mm/min)], zero in air.
    p2_rad_s : ndarray, shape (runs, segments)
        Pole per segment [rad/s], < 0 (ignored in air, where ``x`` equals the feed).
    bandwidth_rad_s : ndarray, shape (runs,)
        Feed-drive bandwidth ``a`` of each run [rad/s].
    plant_step_s : float

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    gain = np.atleast_2d(np.asarray(static_gain_N_per_mm_min, dtype=float))
    runs, nseg = gain.shape
    phi, c_v, c_u = chip_load_coefficients(gain, p2_rad_s, bandwidth_rad_s, plant_step_s)
    params, state = TABLE.records(runs, segments=segment_size(nseg))
    for name, value in (
        ("static_gain_N_per_mm_min", gain), ("phi", phi), ("c_v", c_v), ("c_u", c_u)
    ):
        params[name][:, :nseg] = value
    return params, init_states(params, state)


__all__ = [
    "TABLE",
    "ForceProcessTable",
    "OutOfTableError",
    "cascade_coefficients",
    "chip_load_coefficients",
    "force_process_records",
]
