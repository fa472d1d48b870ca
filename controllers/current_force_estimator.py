"""Cutting force from motor currents (Kim & Chung 2.2, Eq. 5).

Air-cut identification
----------------------
Without cutting (``T_d = 0``) Eq. 5, ``K_t I = J dw/dt + B w + T_f sign(w)``, is linear in
``(J, B, T_f)``.  Sampled with the current held over each step (as the drive applies it),
its exact discrete form is::

    K_t I[k] = J_e (w[k+1] - w[k]) / dt + B w[k] + T_f sign(w[k]) + T_d[k]
    J_e = B dt / (1 - exp(-B dt / J))        (-> J as dt -> 0)

so ``(J_e, B, T_f)`` follow from one linear least-squares fit (``numpy.linalg.lstsq``) over
all samples of one or more air cuts, with the current -- the noisy measurement -- alone
on the left side (no errors-in-variables bias).  ``J`` follows from ``J_e``.  The speed is
taken as measured exactly (encoder); ``K_t`` is the motor's nameplate value.  Air cuts
must include at least two speeds (``B`` against ``T_f``) and should include both
directions of motion.

Force estimation
----------------
While cutting, the same relation gives the load torque ``T_d[k]`` one sample late
(it needs ``w[k+1]``, as Peng's estimator, UBC thesis Eq. 3.40).  The feed force is
``T_d 2 pi eta / p`` (ball screw) and the tangential force ``T_s / R`` with the spindle
torque ``T_s = i eta T_d`` (transmission).  Averaging over whole tooth periods
(:func:`tooth_period_average`) removes the tooth-passing ripple and most current noise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, record, register_element, step_runs
from plants.end_mill_geometry import EndMill
from plants.motor_drive import BallScrew, SpindleTransmission


@dataclass(frozen=True)
class IdentifiedDrive:
    """Drive parameters identified from air cuts.

    Attributes
    ----------
    torque_constant_Nm_A : float
        ``K_t`` used [N m/A] (given, not identified).
    effective_inertia_kg_m2 : float
        ``J_e`` of the exact discrete relation [kg m^2].
    viscous_friction_Nm_s_rad : float
        ``B`` [N m s/rad].
    coulomb_friction_Nm : float
        ``T_f`` [N m].
    plant_step_s : float
        Sample period ``dt`` the data were taken at [s].
    """

    torque_constant_Nm_A: float
    effective_inertia_kg_m2: float
    viscous_friction_Nm_s_rad: float
    coulomb_friction_Nm: float
    plant_step_s: float

    @property
    def inertia_kg_m2(self) -> float:
        """Motor-side inertia ``J`` [kg m^2] from ``J_e`` and ``B``."""
        b, je, dt = self.viscous_friction_Nm_s_rad, self.effective_inertia_kg_m2, self.plant_step_s
        if b * dt / je < 1e-12:
            return je
        return -b * dt / math.log1p(-b * dt / je)


def _regressors(
    speed_rad_s: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    w = speed_rad_s
    return (w[..., 1:] - w[..., :-1]) / dt, w[..., :-1], np.sign(w[..., :-1])


def identify_drive_from_air_cuts(
    current_A: ArrayLike,
    speed_rad_s: ArrayLike,
    torque_constant_Nm_A: float,
    plant_step_s: float,
) -> IdentifiedDrive:
    """Least-squares identification of ``J``, ``B`` and ``T_f`` from no-load runs.

    Parameters
    ----------
    current_A : array_like, shape (runs, n) or (n,)
        Measured motor current held over each sample period [A].
    speed_rad_s : array_like, same shape
        Motor speed at the start of each sample period [rad/s].
    torque_constant_Nm_A : float
        ``K_t`` [N m/A], > 0.
    plant_step_s : float
        Sample period ``dt`` [s], > 0.

    Returns
    -------
    IdentifiedDrive
    """
    current = np.atleast_2d(np.asarray(current_A, dtype=float))
    speed = np.atleast_2d(np.asarray(speed_rad_s, dtype=float))
    if current.shape != speed.shape or current.shape[1] < 3:
        raise ValueError("current_A and speed_rad_s must have equal shape with >= 3 samples")
    if not torque_constant_Nm_A > 0:
        raise ValueError(f"torque_constant_Nm_A must be > 0, got {torque_constant_Nm_A}")
    if not plant_step_s > 0:
        raise ValueError(f"plant_step_s must be > 0, got {plant_step_s}")
    accel, w, sgn = _regressors(speed, plant_step_s)
    design = np.column_stack([accel.ravel(), w.ravel(), sgn.ravel()])
    if np.unique(np.round(w.ravel(), 9)).size < 2:
        raise ValueError("speed_rad_s: air cuts need at least two distinct speeds")
    torque = torque_constant_Nm_A * current[:, :-1].ravel()
    (je, b, tf), *_ = np.linalg.lstsq(design, torque, rcond=None)
    return IdentifiedDrive(torque_constant_Nm_A, float(je), float(b), float(tf), plant_step_s)


@jit
def load_torque(
    drive_torque_constant: float,
    effective_inertia: float,
    viscous_friction: float,
    coulomb_friction: float,
    plant_step_s: float,
    current_A: float,
    speed_rad_s: float,
    next_speed_rad_s: float,
) -> float:
    """Eq. 5 inverted for one sample period: ``T_d = K_t I - J_e (w' - w) / dt - B w -
    T_f sign(w)`` [N m], from the current held over the period and the speeds at its ends."""
    sign = 1.0 if speed_rad_s > 0 else (-1.0 if speed_rad_s < 0 else 0.0)
    return (
        drive_torque_constant * current_A
        - effective_inertia * ((next_speed_rad_s - speed_rad_s) / plant_step_s)
        - viscous_friction * speed_rad_s
        - coulomb_friction * sign
    )


@jit(python_entry=True)
def _load_torques(kt, je, b, tf, dt, current, speed, out) -> None:  # noqa: ANN001
    for r in range(out.shape[0]):
        for k in range(out.shape[1]):
            out[r, k] = load_torque(
                kt, je, b, tf, dt, current[r, k], speed[r, k], speed[r, k + 1]
            )


def load_torque_from_current(
    drive: IdentifiedDrive, current_A: ArrayLike, speed_rad_s: ArrayLike
) -> NDArray[np.float64]:
    """Load torque ``T_d[k]`` on the motor from currents and speeds (Eq. 5 inverted).

    Parameters
    ----------
    drive : IdentifiedDrive
    current_A, speed_rad_s : array_like, shape (runs, n) or (n,)
        As in :func:`identify_drive_from_air_cuts`.

    Returns
    -------
    ndarray, shape (runs, n - 1) or (n - 1,)
        Load torque over sample periods ``0 .. n-2`` [N m].
    """
    current = np.asarray(current_A, dtype=float)
    speed = np.asarray(speed_rad_s, dtype=float)
    shape = np.broadcast_shapes(current.shape, speed.shape)
    cur2 = np.ascontiguousarray(np.broadcast_to(current, shape)).reshape(-1, shape[-1])
    spd2 = np.ascontiguousarray(np.broadcast_to(speed, shape)).reshape(-1, shape[-1])
    out = np.empty((cur2.shape[0], shape[-1] - 1))
    _load_torques(
        drive.torque_constant_Nm_A, drive.effective_inertia_kg_m2,
        drive.viscous_friction_Nm_s_rad, drive.coulomb_friction_Nm, drive.plant_step_s,
        cur2, spd2, out,
    )
    return out.reshape(*shape[:-1], shape[-1] - 1)


def feed_force_from_current(
    drive: IdentifiedDrive, screw: BallScrew, current_A: ArrayLike, speed_rad_s: ArrayLike
) -> NDArray[np.float64]:
    """Feed force [N] (> 0 opposing the feed) from feed-motor current and speed.

    Shapes as :func:`load_torque_from_current`.
    """
    return screw.force_N(load_torque_from_current(drive, current_A, speed_rad_s))


def tangential_force_from_current(
    drive: IdentifiedDrive,
    transmission: SpindleTransmission,
    tool: EndMill,
    current_A: ArrayLike,
    speed_rad_s: ArrayLike,
) -> NDArray[np.float64]:
    """Tangential cutting force ``T_s / R`` [N] from spindle-motor current and speed.

    Shapes as :func:`load_torque_from_current`.
    """
    torque = transmission.spindle_torque_Nm(load_torque_from_current(drive, current_A,
                                                                     speed_rad_s))
    return torque / (tool.radius_mm * 1e-3)


def tooth_period_average(signal: ArrayLike, samples_per_period: int) -> NDArray[np.float64]:
    """Average over consecutive whole periods along the last axis.

    Parameters
    ----------
    signal : array_like, shape (..., n)
    samples_per_period : int
        Samples per tooth period (>= 1); a trailing partial period is dropped.

    Returns
    -------
    ndarray, shape (..., n // samples_per_period)
    """
    x = np.asarray(signal, dtype=float)
    m = int(samples_per_period)
    if m < 1 or m != samples_per_period:
        raise ValueError(f"samples_per_period must be a whole number >= 1, got {m}")
    blocks = x.shape[-1] // m
    return x[..., : blocks * m].reshape(*x.shape[:-1], blocks, m).mean(axis=-1)


def _dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "estimator.current_load",
        [
            ("torque_constant_Nm_A", "f8"),
            ("effective_inertia_kg_m2", "f8"),
            ("viscous_friction_Nm_s_rad", "f8"),
            ("coulomb_friction_Nm", "f8"),
            ("plant_step_s", "f8"),
        ],
    )
    state = record("estimator.current_load", [("current_A", "f8"), ("speed_rad_s", "f8")])
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """Before the first sample: no previous sample (NaN)."""
    s.current_A = np.nan
    s.speed_rad_s = np.nan


@jit
def step(p, s, current_A: float, speed_rad_s: float) -> float:  # noqa: ANN001
    """Take the samples ``(I[k], w[k])``; return ``T_d[k-1]`` [N m] (0 at the first)."""
    torque = load_torque(
        p.torque_constant_Nm_A, p.effective_inertia_kg_m2, p.viscous_friction_Nm_s_rad,
        p.coulomb_friction_Nm, p.plant_step_s, s.current_A, s.speed_rad_s, speed_rad_s,
    )
    s.current_A = current_A
    s.speed_rad_s = speed_rad_s
    return 0.0 if np.isnan(torque) else torque


CURRENT_LOAD = register_element(
    "estimator.current_load",
    _dtypes,
    init,
    step,
    "load torque from motor current and speed (Eq. 5 inverted), one sample late",
)


def current_load_records(identified: Sequence[IdentifiedDrive]) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of load estimators, one per identified drive."""
    params, state = CURRENT_LOAD.records(len(identified))
    for name in (
        "torque_constant_Nm_A", "effective_inertia_kg_m2", "viscous_friction_Nm_s_rad",
        "coulomb_friction_Nm", "plant_step_s",
    ):
        params[name] = [getattr(d, name) for d in identified]
    return params, init_states(params, state)


class CurrentLoadEstimator:
    """Step form of :func:`load_torque_from_current` for a closed loop (batch of runs).

    ``step`` takes the samples ``(I[k], w[k])`` and returns ``T_d[k-1]`` (one sample late);
    the first output (no previous sample) is 0.  The law is the compiled element
    :data:`CURRENT_LOAD`; this class runs it from Python.
    """

    def __init__(self, drive: IdentifiedDrive, runs: int) -> None:
        self.drive = drive
        self.runs = int(runs)
        self.params, self._initial = current_load_records([drive] * self.runs)

    def init(self) -> NDArray:
        """State records before the first sample, shape (runs,)."""
        return self._initial.copy()

    def step(
        self, state: NDArray, current_A: NDArray[np.float64], speed_rad_s: NDArray[np.float64]
    ) -> tuple[NDArray, NDArray[np.float64]]:
        """Advance one sample; returns the new state (input unchanged) and the load torque
        of the previous period [N m], shape (runs,)."""
        new = state.copy()
        torque = step_runs(self.params, new, current_A, speed_rad_s)
        return new, torque
