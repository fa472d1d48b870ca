"""Homogeneous transforms and kinematic chains: tool in workpiece coordinates (Xu et al. Eq. 4-12).

Convention (spec M3-3, made explicit because the printed product order is ambiguous, X-2):
``T_{k-1<-k}`` is the pose of body ``k`` in body ``k-1``, the product of a fixed offset, the
joint motion (``trans(axis q)`` or ``rot(axis, q)``) and an optional small error HTM.  The
bed is body 0; ``T_bed<-tool = T_{0<-1} ... T_{m-1<-m}``, likewise ``T_bed<-wp``, and::

    T_wp<-tool = (T_bed<-wp)^-1 T_bed<-tool                       (Eq. 4)
    m_w = T_wp<-tool m_t,   m_t = (t_x, t_y, t_z, 1)               (Eq. 8, points: w = 1)
    v_w = T_wp<-tool v_t,   v_t = (v_x, v_y, v_z, 0)               (Eq. 9, directions: w = 0)
    E_m = m_w^real - m_w^ideal,   E_v = v_w^real - v_w^ideal       (Eq. 10-11)

*Real* transforms use the measured axis positions (built-in sensors) and error motions, the
*ideal* ones the commanded positions.  Everything is vectorised over samples: a joint value
array of shape ``(n,)`` gives transforms of shape ``(n, 4, 4)``.

CKG6800 thread grinder (Sec. 3, Eq. 12): Z on the bed carries X which carries the wheel; the
workpiece turns with C on the bed.  :func:`ckg6800_chain` is the consistent chain (the
workpiece rotated by C), whose cutter point is ``R_z(-C) (X + W_x, 0, Z + W_z)``;
:func:`xu_eq12_as_printed` is the printed matrix, kept as a fixture: its rotation does not act
on the translation (spec X-5), and its ``z`` row equals the consistent chain's.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

JOINTS = ("fixed", "prismatic", "revolute")


def translation(v: ArrayLike) -> NDArray[np.float64]:
    """HTM of a translation ``v`` [mm]; ``v`` shape (..., 3) gives (..., 4, 4)."""
    v = np.asarray(v, dtype=float)
    out = np.broadcast_to(np.eye(4), (*v.shape[:-1], 4, 4)).copy()
    out[..., :3, 3] = v
    return out


def rotation(axis: ArrayLike, angle_rad: ArrayLike) -> NDArray[np.float64]:
    """HTM of a rotation by ``angle_rad`` about the unit ``axis`` (Rodrigues); angle shape
    (...,) gives (..., 4, 4)."""
    u = np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    a = np.asarray(angle_rad, dtype=float)
    c, s = np.cos(a)[..., None, None], np.sin(a)[..., None, None]
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    r = np.eye(3) + s * k + (1 - c) * (k @ k)
    out = np.broadcast_to(np.eye(4), (*a.shape, 4, 4)).copy()
    out[..., :3, :3] = r
    return out


def small_error_htm(dx: float, dy: float, dz: float, ex: float, ey: float, ez: float
                    ) -> NDArray[np.float64]:
    """First-order HTM of the six error motions: translations [mm], rotations [rad]."""
    return np.array([[1, -ez, ey, dx], [ez, 1, -ex, dy], [-ey, ex, 1, dz], [0, 0, 0, 1.0]])


def inverse(t: ArrayLike) -> NDArray[np.float64]:
    """Inverse of rigid HTMs ``[[R, p], [0, 1]]`` in closed form ``[[R^T, -R^T p], [0, 1]]``
    (shape (..., 4, 4))."""
    t = np.asarray(t, dtype=float)
    rt = np.swapaxes(t[..., :3, :3], -1, -2)
    out = np.zeros_like(t)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -(rt @ t[..., :3, 3:4])[..., 0]
    out[..., 3, 3] = 1.0
    return out


@dataclass(frozen=True)
class Body:
    """One body of a chain, moving relative to the previous one.

    Attributes
    ----------
    name : str
        Name of its joint value in the ``q`` mapping (e.g. ``"X"``).
    joint : {"fixed", "prismatic", "revolute"}
    axis : tuple of float
        Joint axis in the previous body's frame (unit vector).
    offset_mm : tuple of float
        Fixed translation before the joint [mm].
    error : tuple of float
        Six small error motions ``(dx, dy, dz [mm], ex, ey, ez [rad])`` after the joint
        (real chain only).
    """

    name: str
    joint: str = "prismatic"
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    error: tuple[float, ...] = field(default=(0.0,) * 6)

    def __post_init__(self) -> None:
        if self.joint not in JOINTS:
            raise ValueError(f"joint must be one of {JOINTS}, got {self.joint!r}")
        if len(self.error) != 6:
            raise ValueError("error needs six values (dx, dy, dz, ex, ey, ez)")

    def transform(self, q: ArrayLike, with_error: bool = False) -> NDArray[np.float64]:
        """``T_{k-1<-k}`` at joint values ``q`` (mm or rad), shape (n, 4, 4)."""
        q = np.atleast_1d(np.asarray(q, dtype=float))
        t = translation(np.broadcast_to(np.asarray(self.offset_mm, float), (*q.shape, 3)))
        if self.joint == "prismatic":
            t = t @ translation(q[..., None] * np.asarray(self.axis, float))
        elif self.joint == "revolute":
            t = t @ rotation(self.axis, q)
        if with_error:
            t = t @ small_error_htm(*self.error)
        return t


@dataclass(frozen=True)
class KinematicChain:
    """Tool and workpiece chains from the bed (body 0)."""

    tool_bodies: tuple[Body, ...]
    workpiece_bodies: tuple[Body, ...]

    @staticmethod
    def _product(bodies: Sequence[Body], q: Mapping[str, ArrayLike], n: int,
                 with_error: bool) -> NDArray[np.float64]:
        t = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
        for b in bodies:
            value = q.get(b.name, 0.0) if b.joint != "fixed" else 0.0
            t = t @ np.broadcast_to(b.transform(value, with_error), (n, 4, 4))
        return t

    def tool_in_workpiece(self, q: Mapping[str, ArrayLike], with_error: bool = False
                          ) -> NDArray[np.float64]:
        """``T_wp<-tool`` (Eq. 4) at joint values ``q`` (name -> array (n,)), (n, 4, 4)."""
        n = max((np.size(v) for v in q.values()), default=1)
        tool = self._product(self.tool_bodies, q, n, with_error)
        wp = self._product(self.workpiece_bodies, q, n, with_error)
        return inverse(wp) @ tool


def machining_error(
    chain: KinematicChain, q_real: Mapping[str, ArrayLike], q_ideal: Mapping[str, ArrayLike],
    tool_point_mm: ArrayLike = (0.0, 0.0, 0.0), tool_direction: ArrayLike = (0.0, 0.0, 1.0),
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Machining-error vectors ``E_m`` [mm] and ``E_v`` [-] (Eq. 10-11) and the real path.

    Parameters
    ----------
    chain : KinematicChain
    q_real, q_ideal : mapping name -> array (n,)
        Measured and commanded joint values; the real chain includes the error motions.
    tool_point_mm, tool_direction : array_like, shape (3,)
        Cutter location ``m_t`` and orientation ``v_t`` in tool coordinates.

    Returns
    -------
    E_m : ndarray, shape (n, 3)
    E_v : ndarray, shape (n, 3)
    m_real : ndarray, shape (n, 3)
        The cutter path in workpiece coordinates.
    """
    m_t = np.r_[np.asarray(tool_point_mm, float), 1.0]
    v_t = np.r_[np.asarray(tool_direction, float), 0.0]
    t_real = chain.tool_in_workpiece(q_real, with_error=True)
    t_ideal = chain.tool_in_workpiece(q_ideal)
    m_r, m_i = t_real @ m_t, t_ideal @ m_t
    return (m_r - m_i)[:, :3], ((t_real - t_ideal) @ v_t)[:, :3], m_r[:, :3]


def ckg6800_chain(wcs_x_mm: float = 0.0, wcs_z_mm: float = 0.0, wcs_offset_sign: float = 1.0,
                  chain: str = "consistent") -> KinematicChain:
    """The CKG6800 chain: tool side bed -> Z -> X (-> wheel at the WCS offset).

    ``chain = "consistent"`` (default): the workpiece turns with C on the bed, so the cutter
    point in workpiece coordinates is ``R_z(-C) (X + W_x, 0, Z + W_z)``.  ``"as_printed"``:
    the chain whose transform is Eq. 12 as printed, i.e. the rotation by C applied on the
    tool side after the translations (an empty workpiece chain).  ``wcs_offset_sign`` +1
    keeps Eq. 12's ``+W`` (spec X-9).
    """
    s = wcs_offset_sign
    tool = (
        Body("Z", "prismatic", (0.0, 0.0, 1.0)),
        Body("X", "prismatic", (1.0, 0.0, 0.0)),
        Body("wheel", "fixed", offset_mm=(s * wcs_x_mm, 0.0, s * wcs_z_mm)),
    )
    c_body = Body("C", "revolute", (0.0, 0.0, 1.0))
    if chain == "consistent":
        return KinematicChain(tool, (c_body,))
    if chain == "as_printed":
        return KinematicChain((*tool, c_body), ())
    raise ValueError(f"chain must be 'consistent' or 'as_printed', got {chain!r}")


def xu_eq12_as_printed(c_rad: ArrayLike, x_mm: ArrayLike, z_mm: ArrayLike, wcs_x_mm: float = 0.0,
                       wcs_z_mm: float = 0.0) -> NDArray[np.float64]:
    """Eq. 12 as printed: ``[[cos C, -sin C, 0, X + W_x], [sin C, cos C, 0, 0], [0, 0, 1,
    Z + W_z], [0, 0, 0, 1]]``, shape (n, 4, 4) (a fixture; see the module docstring)."""
    c, x, z = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float))
                                    for v in (c_rad, x_mm, z_mm)))
    t = rotation((0.0, 0.0, 1.0), c)
    t[..., 0, 3] = x + wcs_x_mm
    t[..., 2, 3] = z + wcs_z_mm
    return t


__all__ = [
    "JOINTS",
    "Body",
    "KinematicChain",
    "ckg6800_chain",
    "inverse",
    "machining_error",
    "rotation",
    "small_error_htm",
    "translation",
    "xu_eq12_as_printed",
]
