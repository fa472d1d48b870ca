"""Cutting force measured through the feed motor's current (Kim & Chung Sec. 2.2, Eq. 5).

The force the loop regulates loads the feed screw: the feed motor (speed loop tracking the
feed velocity of Eq. 6) draws the current ``K_t I = J dw/dt + B w + T_f sign(w) + T_d`` with
``T_d = F p / (2 pi eta)``.  The measured current carries white noise.  Before cutting, each
run identifies ``J, B, T_f`` from air cuts at a few constant feeds (least squares,
:func:`controllers.current_force_estimator.identify_drive_from_air_cuts`) with its own noise;
while cutting, Eq. 5 inverted with the identified values gives ``T_d`` one plant step late,
and the screw turns it back into a force.  The force estimate then goes through the
``[sensor]`` chain (optional extra noise, low-pass), whose low-pass also smooths the
differentiated speed.

In table mode the loop's force is taken as acting along the feed; with the geometric model
the feed-direction component loads the screw.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from controllers.current_force_estimator import (
    CurrentLoadEstimator,
    EstimatorState,
    IdentifiedDrive,
    identify_drive_from_air_cuts,
)
from plants.motor_drive import BallScrew, DriveState, ServoMotor, SpeedControlledDrive


@dataclass(frozen=True)
class CurrentSensingParams:
    """The ``[current_sensing]`` scenario section.

    Attributes
    ----------
    enabled : bool
        The controller sees the force estimated from the feed current (True) or the force
        sensor (False).
    current_noise_std_A : float
        White noise on the measured current per plant step [A], >= 0.
    speed_loop_bandwidth_rad_s : float
        Crossover of the feed motor's speed loop [rad/s], > 0.
    identification_feeds_mm_min : tuple of float
        Constant feeds of the air cuts used to identify ``J, B, T_f`` [mm/min]; at least
        two distinct values (both directions advised).
    identification_time_s : float
        Duration of each air cut [s], > 0.
    """

    enabled: bool = False
    current_noise_std_A: float = 0.05
    speed_loop_bandwidth_rad_s: float = 200.0
    identification_feeds_mm_min: tuple[float, ...] = (60.0, 150.0, 300.0, -60.0, -150.0, -300.0)
    identification_time_s: float = 0.5

    def __post_init__(self) -> None:
        if not self.current_noise_std_A >= 0:
            raise ValueError("current_noise_std_A must be >= 0")
        if not self.speed_loop_bandwidth_rad_s > 0:
            raise ValueError("speed_loop_bandwidth_rad_s must be > 0")
        if len(set(self.identification_feeds_mm_min)) < 2:
            raise ValueError("identification_feeds_mm_min needs at least two distinct feeds")
        if not self.identification_time_s > 0:
            raise ValueError("identification_time_s must be > 0")


def identify_feed_drives(
    params: CurrentSensingParams,
    motor: ServoMotor,
    screw: BallScrew,
    plant_step_s: float,
    generators: list[np.random.Generator],
) -> list[IdentifiedDrive]:
    """Air-cut identification for each run, with the run's own current noise.

    Returns
    -------
    list of IdentifiedDrive, length runs
    """
    runs = len(generators)
    n = int(round(params.identification_time_s / plant_step_s))
    feeds = np.repeat(np.asarray(params.identification_feeds_mm_min, dtype=float), n)
    reference = np.broadcast_to(screw.motor_speed_rad_s(feeds), (runs, feeds.size))
    drive = SpeedControlledDrive(motor, params.speed_loop_bandwidth_rad_s, plant_step_s, runs)
    _, out = drive.simulate(reference, 0.0, drive.init(0.0))
    identified = []
    for i, gen in enumerate(generators):
        noisy = out.current_A[i] + params.current_noise_std_A * gen.standard_normal(feeds.size)
        identified.append(
            identify_drive_from_air_cuts(
                noisy, out.speed_rad_s[i], motor.torque_constant_Nm_A, plant_step_s
            )
        )
    return identified


class CurrentSensorState(NamedTuple):
    """Feed motor drive and estimator states."""

    drive: DriveState
    estimator: EstimatorState


class FeedCurrentForceSensor:
    """A batch of feed-current force estimators (see module docstring).

    Parameters
    ----------
    params : CurrentSensingParams
    identified : list of IdentifiedDrive, length runs
        Each run's air-cut identification.
    plant_step_s : float
    motor : ServoMotor
    screw : BallScrew
    """

    def __init__(
        self,
        params: CurrentSensingParams,
        identified: list[IdentifiedDrive],
        plant_step_s: float,
        motor: ServoMotor | None = None,
        screw: BallScrew | None = None,
    ) -> None:
        self.runs = len(identified)
        self.motor = motor or ServoMotor()
        self.screw = screw or BallScrew()
        self.noise_std_A = params.current_noise_std_A
        self.drive = SpeedControlledDrive(
            self.motor, params.speed_loop_bandwidth_rad_s, plant_step_s, self.runs
        )

        def column(name: str) -> NDArray[np.float64]:
            return np.array([getattr(d, name) for d in identified])[:, None]

        # one IdentifiedDrive whose fields are (runs, 1) columns: the estimator broadcasts
        batch = IdentifiedDrive(
            self.motor.torque_constant_Nm_A,
            column("effective_inertia_kg_m2"),
            column("viscous_friction_Nm_s_rad"),
            column("coulomb_friction_Nm"),
            plant_step_s,
        )
        self.identified = identified
        self.estimator = CurrentLoadEstimator(batch, self.runs)

    def init(self) -> CurrentSensorState:
        """Motor at rest, no previous current sample."""
        return CurrentSensorState(self.drive.init(0.0), self.estimator.init())

    def step(
        self,
        state: CurrentSensorState,
        feed_force_N: NDArray[np.float64],
        feed_velocity_mm_min: NDArray[np.float64],
        standard_normal: NDArray[np.float64] | None,
    ) -> tuple[CurrentSensorState, NDArray[np.float64], NDArray[np.float64]]:
        """One plant step.

        Parameters
        ----------
        feed_force_N : ndarray, shape (runs,)
            Force loading the feed screw [N].
        feed_velocity_mm_min : ndarray, shape (runs,)
            Feed velocity the speed loop tracks [mm/min].
        standard_normal : ndarray, shape (runs,), or None
            Current-noise samples (None: no noise).

        Returns
        -------
        state : CurrentSensorState
        estimated_force_N : ndarray, shape (runs,)
            Force estimate of the previous step [N] (0 at the first step).
        current_A : ndarray, shape (runs,)
            Measured current [A].
        """
        speed_ref = self.screw.motor_speed_rad_s(feed_velocity_mm_min)
        load = self.screw.motor_torque_Nm(feed_force_N)
        drive_state, out = self.drive.step(state.drive, speed_ref, load)
        current = out.current_A
        if standard_normal is not None:
            current = current + self.noise_std_A * standard_normal
        est_state, torque = self.estimator.step(state.estimator, current, out.speed_rad_s)
        force = self.screw.force_N(torque)
        return CurrentSensorState(drive_state, est_state), force, current


__all__ = [
    "CurrentSensingParams",
    "CurrentSensorState",
    "FeedCurrentForceSensor",
    "identify_feed_drives",
]
