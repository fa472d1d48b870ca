"""Feed-screw and spindle motor drives: motor current from the cutting load (Kim & Chung Eq. 5).

Each drive is a motor with a speed loop.  On the motor shaft (Eq. 5)::

    K_t I = J dw/dt + B w + T_f sign(w) + T_d

with ``T_d`` the cutting load reflected to the motor.  A ball screw of lead ``p`` and
efficiency ``eta`` reflects a feed force ``F`` as ``T_d = F p / (2 pi eta)`` (Peng, UBC
thesis, Eq. 3.34); a spindle transmission of ratio ``i`` (motor turns per spindle turn) and
efficiency ``eta`` reflects a spindle torque ``T_s`` as ``T_d = T_s / (i eta)``.  The
current ``I`` is set by a PI speed controller with an ideal (much faster) current loop.

Discretisation: the current, the Coulomb term (sign of the speed at the start of the step)
and the load are held over each plant step; the remaining first-order system is then
solved exactly::

    w[k+1] = phi w[k] + (1 - phi) / B (K_t I[k] - T_f sign(w[k]) - T_d[k]),
    phi = exp(-B dt / J)

(the zero-order-hold equivalent; only a sign change of the speed inside a step is
approximated).  Current saturation and back-driving efficiency are not modelled.

Defaults: the feed motor and screw are Peng's UBC milling machine (Appendix A: ``K_t`` =
0.3 N m/A, ``J`` = 0.0036 kg m^2, ``B`` = 0.09 N m s/rad, lead 5.08 mm, nut efficiency
0.89; Coulomb friction 0.75 N m from Sec. 3.4.2).  The spindle values are plausible for a
5 kW spindle motor and are not taken from a source.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, record, register_element, step_runs


@dataclass(frozen=True)
class ServoMotor:
    """Motor with its load inertia and friction reflected to the motor shaft.

    Attributes
    ----------
    torque_constant_Nm_A : float
        ``K_t`` [N m/A], > 0.
    inertia_kg_m2 : float
        ``J`` [kg m^2], > 0.
    viscous_friction_Nm_s_rad : float
        ``B`` [N m s/rad], >= 0.
    coulomb_friction_Nm : float
        ``T_f`` [N m], >= 0.
    """

    torque_constant_Nm_A: float = 0.3
    inertia_kg_m2: float = 0.0036
    viscous_friction_Nm_s_rad: float = 0.09
    coulomb_friction_Nm: float = 0.75

    def __post_init__(self) -> None:
        for name in ("torque_constant_Nm_A", "inertia_kg_m2"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in ("viscous_friction_Nm_s_rad", "coulomb_friction_Nm"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")

    @property
    def mechanical_time_constant_s(self) -> float:
        """``J / B`` [s] (infinite without viscous friction)."""
        if self.viscous_friction_Nm_s_rad == 0:
            return math.inf
        return self.inertia_kg_m2 / self.viscous_friction_Nm_s_rad


#: Plausible spindle motor (not from a source): 1.2 N m/A, 0.02 kg m^2, light friction.
DEFAULT_SPINDLE_MOTOR = ServoMotor(
    torque_constant_Nm_A=1.2,
    inertia_kg_m2=0.02,
    viscous_friction_Nm_s_rad=0.004,
    coulomb_friction_Nm=0.3,
)


@dataclass(frozen=True)
class BallScrew:
    """Ball-screw feed transmission.

    Attributes
    ----------
    lead_mm : float
        Travel per screw turn ``p`` [mm], > 0 (the "pitch" of a single-start screw).
    efficiency : float
        Nut efficiency ``eta`` [-], in (0, 1].
    """

    lead_mm: float = 5.08
    efficiency: float = 0.89

    def __post_init__(self) -> None:
        if not self.lead_mm > 0:
            raise ValueError(f"lead_mm must be > 0, got {self.lead_mm}")
        if not 0 < self.efficiency <= 1:
            raise ValueError(f"efficiency must be in (0, 1], got {self.efficiency}")

    @property
    def torque_per_force_m(self) -> float:
        """Motor torque per unit feed force ``p / (2 pi eta)`` [N m / N]."""
        return self.lead_mm * 1e-3 / (2.0 * math.pi * self.efficiency)

    def motor_torque_Nm(self, force_N: ArrayLike) -> NDArray[np.float64]:
        """Load torque on the motor [N m] from a feed force [N] opposing the motion."""
        return np.asarray(force_N, dtype=float) * self.torque_per_force_m

    def force_N(self, motor_torque_Nm: ArrayLike) -> NDArray[np.float64]:
        """Feed force [N] from the load torque on the motor [N m]."""
        return np.asarray(motor_torque_Nm, dtype=float) / self.torque_per_force_m

    def motor_speed_rad_s(self, feedrate_mm_min: ArrayLike) -> NDArray[np.float64]:
        """Motor speed [rad/s] for a feedrate [mm/min]."""
        return np.asarray(feedrate_mm_min, dtype=float) * 2.0 * math.pi / (60.0 * self.lead_mm)

    def feedrate_mm_min(self, motor_speed_rad_s: ArrayLike) -> NDArray[np.float64]:
        """Feedrate [mm/min] for a motor speed [rad/s]."""
        return np.asarray(motor_speed_rad_s, dtype=float) * 60.0 * self.lead_mm / (2.0 * math.pi)


@dataclass(frozen=True)
class SpindleTransmission:
    """Spindle transmission (belt or gear) between motor and spindle.

    Attributes
    ----------
    ratio : float
        Motor turns per spindle turn ``i`` [-], > 0.
    efficiency : float
        ``eta`` [-], in (0, 1].
    """

    ratio: float = 1.0
    efficiency: float = 1.0

    def __post_init__(self) -> None:
        if not self.ratio > 0:
            raise ValueError(f"ratio must be > 0, got {self.ratio}")
        if not 0 < self.efficiency <= 1:
            raise ValueError(f"efficiency must be in (0, 1], got {self.efficiency}")

    def motor_torque_Nm(self, spindle_torque_Nm: ArrayLike) -> NDArray[np.float64]:
        """Load torque on the motor [N m] from the cutting torque on the spindle [N m]."""
        return np.asarray(spindle_torque_Nm, dtype=float) / (self.ratio * self.efficiency)

    def spindle_torque_Nm(self, motor_torque_Nm: ArrayLike) -> NDArray[np.float64]:
        """Cutting torque on the spindle [N m] from the load torque on the motor [N m]."""
        return np.asarray(motor_torque_Nm, dtype=float) * self.ratio * self.efficiency

    def motor_speed_rad_s(self, spindle_speed_rpm: ArrayLike) -> NDArray[np.float64]:
        """Motor speed [rad/s] for a spindle speed [rev/min]."""
        return np.asarray(spindle_speed_rpm, dtype=float) * self.ratio * 2.0 * math.pi / 60.0


class DriveOutput(NamedTuple):
    """What a drive reports per step.

    Attributes
    ----------
    current_A : ndarray, shape (runs,) or (runs, n)
        Motor current held over the step [A].
    speed_rad_s : ndarray, shape (runs,) or (runs, n)
        Motor speed at the start of the step [rad/s].
    """

    current_A: NDArray[np.float64]
    speed_rad_s: NDArray[np.float64]


def _dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "motor.speed_controlled",
        [
            ("kp_A_s_rad", "f8"),
            ("ki_A_rad", "f8"),
            ("plant_step_s", "f8"),
            ("phi", "f8"),  # exp(-B dt / J)
            ("gain", "f8"),  # speed per unit torque held over a step [rad/s per N m]
            ("torque_constant_Nm_A", "f8"),
            ("coulomb_friction_Nm", "f8"),
            ("initial_speed_rad_s", "f8"),
            ("initial_integral_A", "f8"),
        ],
    )
    state = record("motor.speed_controlled", [("speed_rad_s", "f8"), ("integral_A", "f8")])
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """In steady state at the initial speed (the integrator holds friction and load)."""
    s.speed_rad_s = p.initial_speed_rad_s
    s.integral_A = p.initial_integral_A


@jit
def step(p, s, speed_reference_rad_s: float, load_torque_Nm: float) -> tuple[float, float]:  # noqa: ANN001
    """One plant step: speed command [rad/s] and load [N m] (> 0 opposes positive speed)
    held over it.  Returns the current [A] and the speed at the start of the step [rad/s]."""
    w = s.speed_rad_s
    error = speed_reference_rad_s - w
    current = p.kp_A_s_rad * error + s.integral_A
    sign = 1.0 if w > 0 else (-1.0 if w < 0 else 0.0)
    torque = p.torque_constant_Nm_A * current - p.coulomb_friction_Nm * sign - load_torque_Nm
    s.speed_rad_s = p.phi * w + p.gain * torque
    s.integral_A = s.integral_A + p.ki_A_rad * p.plant_step_s * error
    return current, w


SPEED_CONTROLLED = register_element(
    "motor.speed_controlled",
    _dtypes,
    init,
    step,
    "motor with PI speed loop and ideal current loop, Eq. (5), exact ZOH",
)


@jit(python_entry=True)
def _simulate(params, state, reference, load, current, speed) -> None:  # noqa: ANN001
    for r in range(params.shape[0]):
        for k in range(reference.shape[1]):
            current[r, k], speed[r, k] = step(params[r], state[r], reference[r, k], load[r, k])


class SpeedControlledDrive:
    """A batch of speed-controlled motor drives (Eq. 5), exact ZOH at the plant step.

    PI speed controller ``I = K_p e + K_i sum(e) dt`` with ``K_p = w_c J / K_t`` (crossover
    ``w_c`` of the loop ``K_t K_p / (J s)``) and the integral zero at ``w_c / 5``.  The
    step law is the compiled element :data:`SPEED_CONTROLLED`; this class holds its
    parameters and runs it from Python.

    Parameters
    ----------
    motor : ServoMotor
    speed_loop_bandwidth_rad_s : float
        Crossover ``w_c`` [rad/s], > 0, with ``w_c dt <= 0.5``.
    plant_step_s : float
        Plant step ``dt`` [s], > 0.
    runs : int
        Batch size.
    """

    def __init__(
        self,
        motor: ServoMotor,
        speed_loop_bandwidth_rad_s: float,
        plant_step_s: float,
        runs: int,
    ) -> None:
        if not plant_step_s > 0:
            raise ValueError(f"plant_step_s must be > 0, got {plant_step_s}")
        check_speed_loop(speed_loop_bandwidth_rad_s, plant_step_s)
        if runs < 1:
            raise ValueError(f"runs must be >= 1, got {runs}")
        self.motor = motor
        self.plant_step_s = float(plant_step_s)
        self.runs = int(runs)
        self.kp_A_s_rad = speed_loop_bandwidth_rad_s * motor.inertia_kg_m2 / (
            motor.torque_constant_Nm_A
        )
        self.ki_A_rad = self.kp_A_s_rad * speed_loop_bandwidth_rad_s / 5.0
        b, j = motor.viscous_friction_Nm_s_rad, motor.inertia_kg_m2
        self.phi = math.exp(-b * plant_step_s / j)
        #: response of the speed to a unit torque held over the step [rad/s per N m]
        self.gain = (-math.expm1(-b * plant_step_s / j) / b) if b > 0 else plant_step_s / j

    def records(
        self, speed_rad_s: ArrayLike = 0.0, load_torque_Nm: ArrayLike = 0.0
    ) -> tuple[NDArray, NDArray]:
        """Params and initial state records, shape (runs,), in steady state at a speed
        (see :meth:`init`)."""
        w = np.broadcast_to(np.asarray(speed_rad_s, dtype=float), (self.runs,))
        load = np.broadcast_to(np.asarray(load_torque_Nm, dtype=float), (self.runs,))
        m = self.motor
        torque = m.viscous_friction_Nm_s_rad * w + m.coulomb_friction_Nm * np.sign(w) + load
        params, state = SPEED_CONTROLLED.records(self.runs)
        params["kp_A_s_rad"] = self.kp_A_s_rad
        params["ki_A_rad"] = self.ki_A_rad
        params["plant_step_s"] = self.plant_step_s
        params["phi"] = self.phi
        params["gain"] = self.gain
        params["torque_constant_Nm_A"] = m.torque_constant_Nm_A
        params["coulomb_friction_Nm"] = m.coulomb_friction_Nm
        params["initial_speed_rad_s"] = w
        params["initial_integral_A"] = torque / m.torque_constant_Nm_A
        return params, init_states(params, state)

    def init(self, speed_rad_s: ArrayLike = 0.0, load_torque_Nm: ArrayLike = 0.0) -> NDArray:
        """State records, shape (runs,), in steady state at a speed [rad/s] with the
        integrator already balancing friction and a load torque [N m]."""
        return self.records(speed_rad_s, load_torque_Nm)[1]

    def step(
        self, state: NDArray, speed_reference_rad_s: ArrayLike, load_torque_Nm: ArrayLike
    ) -> tuple[NDArray, DriveOutput]:
        """Advance one plant step; returns the new state (the input is not modified) and
        the current and speed, each shape (runs,)."""
        params, _ = self.records()
        new = state.copy()
        current, speed = step_runs(params, new, speed_reference_rad_s, load_torque_Nm)
        return new, DriveOutput(current, speed)

    def simulate(
        self,
        speed_reference_rad_s: ArrayLike,
        load_torque_Nm: ArrayLike,
        state: NDArray | None = None,
    ) -> tuple[NDArray, DriveOutput]:
        """Run the drive over sample arrays of shape (runs, n).

        Returns
        -------
        state : ndarray of records, shape (runs,)
            Final state.
        output : DriveOutput
            ``current_A`` and ``speed_rad_s`` of shape (runs, n); the speed at sample
            ``k`` is the speed at the start of step ``k``.
        """
        shape = np.broadcast_shapes(
            np.shape(speed_reference_rad_s), np.shape(load_torque_Nm), (self.runs, 1)
        )
        ref = np.ascontiguousarray(
            np.broadcast_to(np.asarray(speed_reference_rad_s, dtype=float), shape)
        )
        load = np.ascontiguousarray(np.broadcast_to(np.asarray(load_torque_Nm, dtype=float), shape))
        params, initial = self.records(ref[:, 0], load[:, 0])
        state = initial if state is None else state.copy()
        current = np.empty(shape)
        speed = np.empty(shape)
        _simulate(params, state, ref, load, current, speed)
        return state, DriveOutput(current, speed)


def check_speed_loop(speed_loop_bandwidth_rad_s: float, plant_step_s: float) -> None:
    """Raise ValueError unless ``0 < w_c dt <= 0.5`` (the discrete speed loop's limit)."""
    if not 0 < speed_loop_bandwidth_rad_s * plant_step_s <= 0.5:
        raise ValueError(
            "speed_loop_bandwidth_rad_s * plant_step_s must be in (0, 0.5], got "
            f"{speed_loop_bandwidth_rad_s * plant_step_s:g}"
        )
