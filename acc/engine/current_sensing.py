"""Force sensed through the feed motor's current (Kim & Chung Sec. 2.2, Eq. 5), wired.

The plant side is the feed motor and its speed loop (:mod:`plants.motor_drive`): the force
that loads the feed screw shows up in the current.  The CNC side is the load estimator
(:mod:`controllers.current_force_estimator`), which inverts Eq. 5 with the drive values
identified from noisy air cuts before cutting.  This module only connects them, as the
sensor slot of the force loop:

feed force -> screw torque -> motor (speed loop tracking the feed velocity) -> current
(+ white noise) -> load estimator -> screw force -> the ``[sensor]`` chain (noise, low-pass).

Before cutting, each run identifies ``J, B, T_f`` from air cuts at a few constant feeds,
with its own current noise (stream :data:`acc.engine.rng.STREAM_IDENTIFICATION` of its
noise key).  In table mode the loop's force is taken as acting along the feed; with the
geometric model the feed-direction component loads the screw.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import init, init_states, jit, record, register_element
from acc.engine.rng import (
    NORMAL_STREAM,
    STREAM_FEED_CURRENT,
    STREAM_IDENTIFICATION,
    normal,
    normals,
    seed_stream,
)
from controllers import current_force_estimator as cfe
from plants import force_sensor, motor_drive
from plants.motor_drive import BallScrew, ServoMotor, SpeedControlledDrive


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
        Crossover of the feed motor's speed loop [rad/s], > 0; with the plant step ``dt``,
        ``bandwidth * dt <= 0.5`` (checked with the scenario).
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
    seeds: Sequence[int],
    noise_ids: Sequence[int],
) -> list[cfe.IdentifiedDrive]:
    """Air-cut identification for each run, with the run's own current noise.

    Returns
    -------
    list of IdentifiedDrive, length runs
    """
    n = int(round(params.identification_time_s / plant_step_s))
    feeds = np.repeat(np.asarray(params.identification_feeds_mm_min, dtype=float), n)
    drive = SpeedControlledDrive(motor, params.speed_loop_bandwidth_rad_s, plant_step_s, 1)
    _, out = drive.simulate(screw.motor_speed_rad_s(feeds)[None, :], 0.0)
    identified = []
    for seed, nid in zip(seeds, noise_ids, strict=True):
        noise = normals(int(seed), int(nid), STREAM_IDENTIFICATION, feeds.size)
        noisy = out.current_A[0] + params.current_noise_std_A * noise
        identified.append(
            cfe.identify_drive_from_air_cuts(
                noisy, out.speed_rad_s[0], motor.torque_constant_Nm_A, plant_step_s
            )
        )
    return identified


def _dtypes() -> tuple[np.dtype, np.dtype]:
    motor_p, motor_s = motor_drive.SPEED_CONTROLLED.dtypes()
    est_p, est_s = cfe.CURRENT_LOAD.dtypes()
    filt_p, filt_s = force_sensor.DYNAMOMETER.dtypes()
    params = record(
        "sensor.feed_current",
        [
            ("motor", motor_p),
            ("estimator", est_p),
            ("filter", filt_p),
            ("current_noise_std_A", "f8"),
            ("lead_mm", "f8"),
            ("torque_per_force_m", "f8"),
            ("seed", "u8"),
            ("noise_id", "u8"),
        ],
    )
    state = record(
        "sensor.feed_current",
        [("motor", motor_s), ("estimator", est_s), ("filter", filt_s), ("noise", NORMAL_STREAM)],
    )
    return params, state


@jit
def sensing_init(p, s) -> None:  # noqa: ANN001
    """Motor at rest, no previous current sample, filter at rest, noise stream at its start."""
    init(p.motor, s.motor)
    init(p.estimator, s.estimator)
    init(p.filter, s.filter)
    seed_stream(s.noise, p.seed, p.noise_id, STREAM_FEED_CURRENT)


@jit
def sensing_step(p, s, force_N: float, feed_force_N: float, feed_velocity_mm_min: float,  # noqa: ANN001
                 drive_current_A: float, drive_speed_rad_s: float) -> tuple[float, float]:
    """One plant step: the feed force [N] loads the screw while the motor tracks the feed
    velocity [mm/min] (this sensor models its own motor: the feed drive's current and
    speed are not used).  Returns the force the controller sees [N] (the previous step's
    estimate through the sensor chain) and the measured current [A]."""
    speed_ref = feed_velocity_mm_min * 2.0 * math.pi / (60.0 * p.lead_mm)
    load = feed_force_N * p.torque_per_force_m
    current, speed = motor_drive.step(p.motor, s.motor, speed_ref, load)
    if p.current_noise_std_A > 0.0:
        current = current + p.current_noise_std_A * normal(s.noise)
    torque = cfe.step(p.estimator, s.estimator, current, speed)
    measured = force_sensor.measure(p.filter, s.filter, torque / p.torque_per_force_m)
    return measured, current


FEED_CURRENT = register_element(
    "sensor.feed_current",
    _dtypes,
    sensing_init,
    sensing_step,
    "force estimated from the feed-motor current (Eq. 5) after air-cut identification",
)


def feed_current_records(
    params: CurrentSensingParams,
    filter_records: tuple[NDArray, NDArray],
    plant_step_s: float,
    seeds: Sequence[int],
    noise_ids: Sequence[int],
    motor: ServoMotor | None = None,
    screw: BallScrew | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of feed-current force sensors.

    Parameters
    ----------
    params : CurrentSensingParams
        Shared by the batch.
    filter_records : (params, state)
        The ``[sensor]`` chain applied to the estimate
        (:func:`plants.force_sensor.force_sensor_records`).
    plant_step_s : float
    seeds, noise_ids : sequence of int, length runs
        Noise keys: current noise and the air-cut identification.
    motor, screw : optional
        Feed motor and ball screw (defaults: Peng's machine).

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    motor = motor or ServoMotor()
    screw = screw or BallScrew()
    runs = len(seeds)
    identified = identify_feed_drives(params, motor, screw, plant_step_s, seeds, noise_ids)
    drive = SpeedControlledDrive(motor, params.speed_loop_bandwidth_rad_s, plant_step_s, runs)
    motor_p, _ = drive.records(0.0)
    est_p, _ = cfe.current_load_records(identified)
    out, state = FEED_CURRENT.records(runs)
    out["motor"] = motor_p
    out["estimator"] = est_p
    out["filter"] = filter_records[0]
    out["current_noise_std_A"] = params.current_noise_std_A
    out["lead_mm"] = screw.lead_mm
    out["torque_per_force_m"] = screw.torque_per_force_m
    out["seed"] = np.asarray(seeds)
    out["noise_id"] = np.asarray(noise_ids)
    return out, init_states(out, state)


__all__ = ["FEED_CURRENT", "CurrentSensingParams", "feed_current_records", "identify_feed_drives"]
