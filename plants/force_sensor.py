"""Cutting-force measurement: additive white noise and a first-order low-pass filter.

The raw signal at plant step ``k`` is ``s[k] = f[k] + sigma n[k]`` with ``n`` standard normal
samples of the run's own noise stream (:mod:`acc.engine.rng`, stream 0).  The filter
``H(s) = 1 / (s / w_c + 1)`` is discretised as ``y[k] = phi y[k-1] + (1 - phi) s[k]`` with
``phi = exp(-w_c dt)``: exact for a signal held over ``(t[k-1], t[k]]``.  A cut-off of 0
means no filter (``y = s``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, per_run, record, register_element
from acc.engine.rng import NORMAL_STREAM, STREAM_FORCE_SENSOR, normal, seed_stream

#: What the controller's force comes from (the ``[sensor]`` section's ``kind``): a
#: dynamometer, or Peng's estimators on the servo axis's armature current and speed
#: (:mod:`acc.engine.servo_current_sensing`; they need ``feed_drive.kind = "servo_axis"``).
SENSOR_KINDS = ("dynamometer", "peng_inverse_model", "peng_steady_state")


@dataclass(frozen=True)
class ForceSensorParams:
    """Measurement chain of one run (the ``[sensor]`` section).

    Attributes
    ----------
    kind : {"dynamometer", "peng_inverse_model", "peng_steady_state"}
        The force measured by a dynamometer, or estimated from the servo axis's current
        (Peng 3.39-3.40, one sample late, or 3.60 with the tare ``B W``); the noise and
        low-pass below then act on the estimate.
    noise_std_N : float
        Standard deviation of the additive white noise per plant step [N], >= 0.
    lowpass_cutoff_hz : float
        Cut-off of the first-order low-pass [Hz]; 0 disables the filter.
    current_noise_std_A : float
        White noise on the measured armature current per plant step [A], >= 0 (Peng's
        estimators only).
    """

    kind: str = "dynamometer"
    noise_std_N: float = 0.0
    lowpass_cutoff_hz: float = 0.0
    current_noise_std_A: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in SENSOR_KINDS:
            raise ValueError(f"kind must be one of {', '.join(SENSOR_KINDS)}, got {self.kind!r}")
        if not self.current_noise_std_A >= 0:
            raise ValueError(f"current_noise_std_A must be >= 0, got {self.current_noise_std_A}")
        if not self.noise_std_N >= 0:
            raise ValueError(f"noise_std_N must be >= 0, got {self.noise_std_N}")
        if not self.lowpass_cutoff_hz >= 0:
            raise ValueError(f"lowpass_cutoff_hz must be >= 0, got {self.lowpass_cutoff_hz}")


def _dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "sensor.dynamometer",
        [
            ("noise_std_N", "f8"),
            ("phi", "f8"),  # exp(-w_c dt); 0 without a filter
            ("seed", "u8"),
            ("noise_id", "u8"),
            ("stream", "u8"),
        ],
    )
    state = record(
        "sensor.dynamometer",
        [
            ("filtered_N", "f8"),
            ("next_normal", "f8"),  # the stream's next normal, drawn a step ahead
            ("noise", NORMAL_STREAM),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """Filter at rest at zero force; the noise stream at its start, its first normal drawn."""
    s.filtered_N = 0.0
    seed_stream(s.noise, p.seed, p.noise_id, p.stream)
    s.next_normal = normal(s.noise) if p.noise_std_N > 0.0 else 0.0


@jit
def measure(p, s, force_N: float) -> float:  # noqa: ANN001
    """Measure the force of one plant step [N]; returns the measured (filtered) force."""
    raw = force_N
    if p.noise_std_N > 0.0:
        # the normals in the stream's order, each drawn a step before it is used: the draw
        # (about 25 cycles from the stream's word to the number) then overlaps the step
        # before instead of delaying this measurement
        raw = force_N + p.noise_std_N * s.next_normal
        s.next_normal = normal(s.noise)
    s.filtered_N = p.phi * s.filtered_N + (1.0 - p.phi) * raw
    return s.filtered_N


@jit
def step(p, s, force_N: float, feed_force_N: float, feed_velocity_mm_min: float,  # noqa: ANN001
         drive_current_A: float, drive_speed_rad_s: float) -> tuple[float, float]:
    """The sensor slot's step: the regulated force [N] measured by :func:`measure`; the
    feed force and velocity and the drive's current and speed are not used.  Returns
    ``(measured_N, nan)`` (no current)."""
    return measure(p, s, force_N), np.nan


DYNAMOMETER = register_element(
    "sensor.dynamometer", _dtypes, init, step, "force measurement: noise, first-order low-pass"
)


def force_sensor_records(
    noise_std_N: ArrayLike,
    lowpass_cutoff_hz: ArrayLike,
    plant_step_s: float,
    seed: ArrayLike = 0,
    noise_id: ArrayLike = 0,
    stream: int = STREAM_FORCE_SENSOR,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of force sensors.

    Parameters
    ----------
    noise_std_N : array_like, shape (runs,) or scalar
        Noise standard deviation per plant step [N], >= 0.
    lowpass_cutoff_hz : array_like, shape (runs,) or scalar
        Filter cut-off [Hz], 0 = none.
    plant_step_s : float
        Plant step [s].
    seed, noise_id : array_like of int, shape (runs,) or scalar
        Key of each run's noise streams (:mod:`acc.engine.rng`).
    stream : int
        Stream number of the sensor noise.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs, (sigma, cutoff) = per_run(noise_std_N, lowpass_cutoff_hz)
    runs, (sigma, cutoff, seeds, ids) = per_run(sigma, cutoff, seed, noise_id, dtype=None)
    params, state = DYNAMOMETER.records(runs)
    wc = 2.0 * math.pi * cutoff.astype(float)
    params["noise_std_N"] = sigma
    params["phi"] = np.where(wc > 0, np.exp(-wc * plant_step_s), 0.0)
    params["seed"] = seeds
    params["noise_id"] = ids
    params["stream"] = stream
    return params, init_states(params, state)


__all__ = ["DYNAMOMETER", "SENSOR_KINDS", "ForceSensorParams", "force_sensor_records", "measure"]
