"""Peng's force estimators on the servo axis's current as the force loop's sensor, wired.

With ``feed_drive.kind = "servo_axis"`` the feed drive is Peng's DC servo under its lead-lag
position loop (:mod:`controllers.axis.servo_feed_drive`), loaded by the feed force.  Its
armature current ``I_a`` and motor speed ``W`` carry that load, so the drive itself is the
force sensor (seed 000, Ch. 3).  ``sensor.kind`` selects the estimator
(:mod:`controllers.monitoring.servo_force_sensing`):

``"peng_inverse_model"``  (3.39)-(3.40): the exact ZOH velocity loop inverted one sample late;
                          noise-free it returns the feed force of the previous plant step,
                          exactly (the drive is linear, the load held over each step)
``"peng_steady_state"``   (3.36)/(3.60): ``K_t I_a - B W``; its error is the inertia torque
                          ``J_e dW/dt`` and the current's lag (bandwidth 118.8 Hz)

Per plant step ``k`` (sensor slot of :mod:`acc.engine.force_loop`): the drive shows
``I_a[k], W[k]``; the measured current is ``I_a[k] + sigma_i n[k]`` (white, the run's
stream :data:`acc.engine.rng.STREAM_FEED_CURRENT`; the tacho speed is taken noise-free);
the estimator turns it into a feed force, and the ``[sensor]`` chain (its noise and
first-order low-pass, e.g. Peng's 50 Hz) gives the force the controller sees.  The
estimator's coefficients come from the same axis parameters as the drive.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import (
    Element,
    init,
    init_states,
    jit,
    record,
    register_element,
    step,
)
from acc.engine.rng import NORMAL_STREAM, STREAM_FEED_CURRENT, normal, seed_stream
from controllers.monitoring import servo_force_sensing as sfs
from plants import force_sensor
from plants.axis.servo_axis import ServoAxisParams

#: ``sensor.kind`` values served here, and the estimator element of each.
ESTIMATOR_KINDS = ("peng_inverse_model", "peng_steady_state")


def _dtypes_for(name: str, estimator: Element) -> tuple[np.dtype, np.dtype]:
    est_p, est_s = estimator.dtypes()
    filt_p, filt_s = force_sensor.DYNAMOMETER.dtypes()
    params = record(
        name,
        [
            ("estimator", est_p),
            ("filter", filt_p),
            ("current_noise_std_A", "f8"),
            ("seed", "u8"),
            ("noise_id", "u8"),
        ],
    )
    state = record(name, [("estimator", est_s), ("filter", filt_s), ("noise", NORMAL_STREAM)])
    return params, state


def _inverse_dtypes() -> tuple[np.dtype, np.dtype]:
    return _dtypes_for("sensor.peng_inverse_model", sfs.INVERSE_MODEL)


def _steady_dtypes() -> tuple[np.dtype, np.dtype]:
    return _dtypes_for("sensor.peng_steady_state", sfs.STEADY_STATE)


@jit
def sensing_init(p, s) -> None:  # noqa: ANN001
    """Estimator with no previous sample, filter at rest, current noise at its start."""
    init(p.estimator, s.estimator)
    init(p.filter, s.filter)
    seed_stream(s.noise, p.seed, p.noise_id, STREAM_FEED_CURRENT)


@jit
def sensing_step(p, s, force_N: float, feed_force_N: float, feed_velocity_mm_min: float,  # noqa: ANN001
                 drive_current_A: float, drive_speed_rad_s: float) -> tuple[float, float]:
    """One plant step: the drive's current [A] (plus noise) and speed [rad/s] through the
    estimator and the ``[sensor]`` chain.  Returns the force the controller sees [N] and
    the measured current [A]; the true forces and the velocity are not used."""
    current = drive_current_A
    if p.current_noise_std_A > 0.0:
        current = current + p.current_noise_std_A * normal(s.noise)
    _, estimate_N = step(p.estimator, s.estimator, current, drive_speed_rad_s)
    return force_sensor.measure(p.filter, s.filter, estimate_N), current


PENG_INVERSE_MODEL = register_element(
    "sensor.peng_inverse_model",
    _inverse_dtypes,
    sensing_init,
    sensing_step,
    "feed force from the servo axis's current and speed by Peng's inverted velocity loop "
    "(3.39-3.40), one plant step late",
)
PENG_STEADY_STATE = register_element(
    "sensor.peng_steady_state",
    _steady_dtypes,
    sensing_init,
    sensing_step,
    "feed force from the servo axis's steady current, K_t I_a - B W (Peng 3.36, 3.60)",
)


def servo_current_sensor_records(
    kind: str,
    filter_records: tuple[NDArray, NDArray],
    current_noise_std_A: Sequence[float] | NDArray,
    plant_step_s: float,
    seeds: Sequence[int],
    noise_ids: Sequence[int],
    axis: ServoAxisParams | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of servo-current force sensors.

    Parameters
    ----------
    kind : {"peng_inverse_model", "peng_steady_state"}
    filter_records : (params, state)
        The ``[sensor]`` chain applied to the estimate
        (:func:`plants.force_sensor.force_sensor_records`), shape (runs,) each.
    current_noise_std_A : array_like, shape (runs,)
        White noise on the measured current [A].
    plant_step_s : float
        ``dt`` [s]: the estimator's sample period.
    seeds, noise_ids : sequence of int, length runs
        Noise keys.
    axis : ServoAxisParams, optional
        The drive's axis (Peng's Appendix A by default, as
        :func:`controllers.axis.servo_feed_drive.servo_feed_drive_records`); the
        inverse model's coefficients and the steady-state tare come from it.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    axis = ServoAxisParams() if axis is None else axis
    runs = len(seeds)
    if kind == "peng_inverse_model":
        est_p, _ = sfs.inverse_model_records([axis], plant_step_s)
        element = PENG_INVERSE_MODEL
    elif kind == "peng_steady_state":
        est_p, _ = sfs.steady_state_records(
            [axis], plant_step_s, sfs.ServoForceEstimatorParams(tare_model="viscous")
        )
        element = PENG_STEADY_STATE
    else:
        raise ValueError(f"kind must be one of {', '.join(ESTIMATOR_KINDS)}, got {kind!r}")
    out, state = element.records(runs)
    out["estimator"] = est_p[0]
    out["filter"] = filter_records[0]
    out["current_noise_std_A"] = np.broadcast_to(np.asarray(current_noise_std_A, float), (runs,))
    out["seed"] = np.asarray(seeds)
    out["noise_id"] = np.asarray(noise_ids)
    return out, init_states(out, state)


__all__ = [
    "ESTIMATOR_KINDS",
    "PENG_INVERSE_MODEL",
    "PENG_STEADY_STATE",
    "servo_current_sensor_records",
]
