"""Restricted state control (RSC): a P position loop with acceleration (and optionally speed)
feedback, after Briquez, Sandoz & Zaquini (seed 004; spec M4-3, M4-4, A4-1, A4-2).

Per position-controller period ``T`` (A4-1), with the scale position ``x_m(k)`` [mm]::

    v_bar(k) = (x_m(k) - x_m(k-1)) / T                      mean speed the NC receives (L207)
    a_hat(k) from the selected source, optionally low-passed, then delayed by
             ``acceleration_delay_samples`` periods (1: "synchronized actions", A4-1)
    speed form      v_cmd = K_v (x_r - x_m) + FF1 v_r - K_2 v_fb - K_3 a_hat     (Eq. 2 form)
    position form   v_cmd = K_v (x_r - K_3p a_hat - x_m) + FF1 v_r - K_2 v_fb
    command = output_gain v_cmd, limited to +-output_limit (0: none)

``K_3`` [s] multiplies the acceleration in mm/s^2; ``K_3p`` [mm per m/s^2] offsets the
position reference (the 840D synchronized action, L205); the forms are equal when
``K_3 = K_v K_3p / 1000`` (spec M4-4).  ``v_fb`` is the observer's speed with the observer
source, else ``v_bar``; ``K_2`` is Table 1's speed feedback.

Acceleration sources (M4-3):

============================  =============================================================
``"observer"``                 :mod:`controllers.axis.acceleration_observer`, input the
                               speed command, measurement ``v_bar`` (or the measured speed)
``"accelerometer"``            the plant's relative acceleration plus white noise
                               ``accelerometer_noise_m_s2`` and an offset, through a
                               first-order low-pass of ``accelerometer_bandwidth_Hz`` (0:
                               none).  [ASSUMED] noise defaults 0: the paper gives no
                               numbers (L164-L176)
``"double_differentiation"``   Euler derivative of ``v_bar``: ``(x_m(k) - 2 x_m(k-1) +
                               x_m(k-2)) / T^2`` (L207-L209); its quantisation noise has
                               standard deviation ``q / (sqrt(2) T^2)`` (A4-3)
``"none"``                     a plain P position loop
============================  =============================================================

The output is a speed command [mm/s] times ``output_gain`` (1 for the oscillating axis,
whose command is a speed; for a servo axis, volts per mm/s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import delay_size, init_states, jit, record, register_element
from acc.engine.rng import NORMAL_STREAM, normal, seed_stream
from controllers.axis import acceleration_observer as obs_mod
from controllers.axis.acceleration_observer import (
    AccelerationObserverParams,
    design_observer,
    fill_observer,
)

#: Acceleration sources and their codes in compiled records.
ACCELERATION_SOURCES = {"none": 0, "observer": 1, "accelerometer": 2, "double_differentiation": 3}
#: Where the acceleration term enters.
INJECTIONS = {"speed_command": 0, "position_reference": 1}
#: Random stream of the accelerometer noise (the force loop's streams are 0-3).
STREAM_ACCELEROMETER = 8


@dataclass(frozen=True)
class StateControlParams:
    """P position loop with restricted state control (defaults: Huron KX10, plain P loop).

    Attributes
    ----------
    position_gain_1_s : float
        ``K_v`` [1/s] (Huron original 36.6, L209).
    velocity_feedforward : float
        ``FF1`` [-] on the reference velocity.
    source : {"none", "observer", "accelerometer", "double_differentiation"}
    injection : {"speed_command", "position_reference"}
    acceleration_gain_s : float
        ``K_3`` [s] (speed form).
    acceleration_offset_gain_mm_per_m_s2 : float
        ``K_3p`` [mm/(m/s^2)] (position form; Huron best 0.00584, L213).
    speed_feedback_gain : float
        ``K_2`` [-].
    acceleration_delay_samples : int
        Periods of delay on the acceleration estimate (1).
    acceleration_lowpass_Hz : float
        First-order low-pass on the estimate [Hz]; 0 = none.
    observer_frequency_Hz, observer_damping, observer_speed_factor : float
        Observer model and pole factor (:class:`AccelerationObserverParams`).
    observer_measurement : {"mean_speed", "velocity"}
    accelerometer_noise_m_s2 : float
        [ASSUMED] white noise per sample [m/s^2] (0).
    accelerometer_offset_m_s2 : float
        Offset [m/s^2] (0; a capacitive sensor has none, a piezo one drifts).
    accelerometer_bandwidth_Hz : float
        Sensor bandwidth [Hz]; 0 = ideal.
    output_gain : float
        Plant command per mm/s of speed command (1 for a speed-commanded axis).
    output_limit : float
        Limit on the command (plant units); 0 = none.
    """

    position_gain_1_s: float = 36.6
    velocity_feedforward: float = 0.0
    source: str = "double_differentiation"
    injection: str = "position_reference"
    acceleration_gain_s: float = 0.0
    acceleration_offset_gain_mm_per_m_s2: float = 0.0
    speed_feedback_gain: float = 0.0
    acceleration_delay_samples: int = 1
    acceleration_lowpass_Hz: float = 0.0
    observer_frequency_Hz: float = 42.0
    observer_damping: float = 0.2
    observer_speed_factor: float = 3.0
    observer_measurement: str = "mean_speed"
    accelerometer_noise_m_s2: float = 0.0
    accelerometer_offset_m_s2: float = 0.0
    accelerometer_bandwidth_Hz: float = 0.0
    output_gain: float = 1.0
    output_limit: float = 0.0

    def __post_init__(self) -> None:
        if self.source not in ACCELERATION_SOURCES:
            raise ValueError(
                f"source must be one of {', '.join(ACCELERATION_SOURCES)}, got {self.source!r}"
            )
        if self.injection not in INJECTIONS:
            raise ValueError(
                f"injection must be one of {', '.join(INJECTIONS)}, got {self.injection!r}"
            )
        for name in ("position_gain_1_s", "velocity_feedforward", "acceleration_gain_s",
                     "acceleration_offset_gain_mm_per_m_s2", "speed_feedback_gain",
                     "accelerometer_offset_m_s2", "output_gain"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"{name} must be a finite number, got {v!r}")
        for name in ("acceleration_lowpass_Hz", "accelerometer_noise_m_s2",
                     "accelerometer_bandwidth_Hz", "output_limit"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
        d = self.acceleration_delay_samples
        if not (isinstance(d, (int, np.integer)) and d >= 0):
            raise ValueError(f"acceleration_delay_samples must be a whole number >= 0, got {d!r}")
        self.observer  # noqa: B018  (validates the observer fields)

    @property
    def observer(self) -> AccelerationObserverParams:
        """The observer fields as :class:`AccelerationObserverParams`."""
        return AccelerationObserverParams(
            self.observer_frequency_Hz, self.observer_damping, self.observer_speed_factor,
            self.observer_measurement,
        )

    @property
    def equivalent_speed_gain_s(self) -> float:
        """``K_3`` [s] of the speed form equal to this controller's acceleration term
        (``K_v K_3p / 1000`` in the position form)."""
        if self.injection == "position_reference":
            return self.position_gain_1_s * self.acceleration_offset_gain_mm_per_m_s2 * 1e-3
        return self.acceleration_gain_s


def design_k3(
    target_damping: float, frequency_Hz: float, damping: float, speed_feedback_gain: float = 0.0
) -> float:
    """``K_3`` [s] for a target damping, the inverse of Table 1 (A4-2):
    ``K_3 = 2 (zeta_G sqrt(1 + K_2) - zeta) / w_0``."""
    w0 = 2.0 * math.pi * frequency_Hz
    return 2.0 * (target_damping * math.sqrt(1.0 + speed_feedback_gain) - damping) / w0


# --- compiled element ------------------------------------------------------------------
def _dtypes(ring: int = 8) -> tuple[np.dtype, np.dtype]:
    obs_p, obs_s = obs_mod.ACCELERATION_OBSERVER.dtypes()
    params = record(
        "position_controller.p_state_control",
        [
            ("period_s", "f8"),
            ("position_gain_1_s", "f8"),
            ("velocity_feedforward", "f8"),
            ("source", "i8"),
            ("injection", "i8"),
            ("acceleration_gain_s", "f8"),  # speed form: per mm/s^2
            ("offset_gain_s2", "f8"),  # position form: mm per mm/s^2 (K_3p / 1000)
            ("speed_feedback_gain", "f8"),
            ("delay_samples", "i8"),
            ("ring_mask", "i8"),
            ("lowpass_phi", "f8"),  # exp(-2 pi f T); 0 = none
            ("noise_mm_s2", "f8"),
            ("offset_mm_s2", "f8"),
            ("sensor_phi", "f8"),
            ("output_gain", "f8"),
            ("output_limit", "f8"),
            ("initial_position_mm", "f8"),
            ("observer_measured_velocity", "b1"),
            ("seed", "u8"),
            ("noise_id", "u8"),
            ("observer", obs_p),
        ],
    )
    state = record(
        "position_controller.p_state_control",
        [
            ("previous_position_mm", "f8"),
            ("position_before_mm", "f8"),  # x_m(k-2)
            ("sensor_mm_s2", "f8"),
            ("filtered_mm_s2", "f8"),
            ("head", "i8"),
            ("history_mm_s2", "f8", (ring,)),
            ("noise", NORMAL_STREAM),
            ("observer", obs_s),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At rest at the initial position."""
    s.previous_position_mm = p.initial_position_mm
    s.position_before_mm = p.initial_position_mm
    s.sensor_mm_s2 = 0.0
    s.filtered_mm_s2 = 0.0
    s.head = 0
    for i in range(s.history_mm_s2.shape[0]):
        s.history_mm_s2[i] = 0.0
    seed_stream(s.noise, p.seed, p.noise_id, STREAM_ACCELEROMETER)
    obs_mod.init(p.observer, s.observer)


@jit
def step(p, s, k, reference_mm, reference_velocity_mm_s, reference_acceleration_mm_s2,  # noqa: ANN001
         measured_position_mm, measured_velocity_mm_s, measured_acceleration_mm_s2) -> float:
    """Controller slot: one period of A4-1; the command (``output_gain x`` speed command)."""
    x = measured_position_mm
    mean_speed = (x - s.previous_position_mm) / p.period_s
    v_fb = mean_speed
    if p.source == 1:
        y = measured_velocity_mm_s if p.observer_measured_velocity else mean_speed
        v_fb, a_raw = obs_mod.update(p.observer, s.observer, y)
    elif p.source == 2:
        n = normal(s.noise) if p.noise_mm_s2 > 0.0 else 0.0
        raw = measured_acceleration_mm_s2 + p.offset_mm_s2 + p.noise_mm_s2 * n
        s.sensor_mm_s2 = p.sensor_phi * s.sensor_mm_s2 + (1.0 - p.sensor_phi) * raw
        a_raw = s.sensor_mm_s2
    elif p.source == 3:
        a_raw = (x - 2.0 * s.previous_position_mm + s.position_before_mm) / (
            p.period_s * p.period_s
        )
    else:
        a_raw = 0.0
    s.filtered_mm_s2 = p.lowpass_phi * s.filtered_mm_s2 + (1.0 - p.lowpass_phi) * a_raw
    s.history_mm_s2[s.head] = s.filtered_mm_s2
    a_hat = s.history_mm_s2[(s.head - p.delay_samples) & p.ring_mask]
    s.head = (s.head + 1) & p.ring_mask
    if p.injection == 1:
        target = reference_mm - p.offset_gain_s2 * a_hat
        v_cmd = p.position_gain_1_s * (target - x)
    else:
        v_cmd = p.position_gain_1_s * (reference_mm - x) - p.acceleration_gain_s * a_hat
    v_cmd += p.velocity_feedforward * reference_velocity_mm_s - p.speed_feedback_gain * v_fb
    if p.source == 1:
        obs_mod.set_input(s.observer, v_cmd)
    s.position_before_mm = s.previous_position_mm
    s.previous_position_mm = x
    out = p.output_gain * v_cmd
    if p.output_limit > 0.0:
        if out > p.output_limit:
            out = p.output_limit
        elif out < -p.output_limit:
            out = -p.output_limit
    return out


STATE_CONTROL = register_element(
    "position_controller.p_state_control",
    _dtypes,
    init,
    step,
    "Briquez restricted state control: P loop + acceleration feedback, 3 sources, 2 forms",
)


def state_control_records(
    controllers: StateControlParams | Sequence[StateControlParams],
    control_period_s: float,
    *,
    runs: int | None = None,
    seed: int = 0,
    noise_ids: ArrayLike | None = None,
    initial_position_mm: ArrayLike = 0.0,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of restricted state controllers.

    Parameters
    ----------
    controllers : StateControlParams or sequence of them, length runs
    control_period_s : float
        ``T_pC`` [s], > 0.
    runs : int, optional
        Batch size when ``controllers`` is one parameter set.
    seed : int
        Root seed of the accelerometer noise.
    noise_ids : array_like of int, shape (runs,), optional
        Noise key of each run (default ``0 .. runs-1``): equal keys, equal noise.
    initial_position_mm : array_like, shape (runs,) or scalar
        Scale position before the first period (so the first mean speed is 0).

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    if not control_period_s > 0:
        raise ValueError(f"control_period_s must be > 0, got {control_period_s}")
    if isinstance(controllers, StateControlParams):
        controllers = [controllers] * (1 if runs is None else int(runs))
    ctrls = list(controllers)
    n = len(ctrls)
    ids = np.arange(n) if noise_ids is None else np.asarray(noise_ids, dtype=np.int64)
    delay = max(c.acceleration_delay_samples for c in ctrls)
    params, state = STATE_CONTROL.records(n, ring=delay_size(delay + 1))
    designs: dict[AccelerationObserverParams, obs_mod.ObserverDesign] = {}
    t = control_period_s
    for r, c in enumerate(ctrls):
        row = params[r]
        row["period_s"] = t
        row["position_gain_1_s"] = c.position_gain_1_s
        row["velocity_feedforward"] = c.velocity_feedforward
        row["source"] = ACCELERATION_SOURCES[c.source]
        row["injection"] = INJECTIONS[c.injection]
        row["acceleration_gain_s"] = c.acceleration_gain_s
        row["offset_gain_s2"] = c.acceleration_offset_gain_mm_per_m_s2 * 1e-3
        row["speed_feedback_gain"] = c.speed_feedback_gain
        row["delay_samples"] = c.acceleration_delay_samples
        f = c.acceleration_lowpass_Hz
        row["lowpass_phi"] = math.exp(-2.0 * math.pi * f * t) if f > 0 else 0.0
        row["noise_mm_s2"] = c.accelerometer_noise_m_s2 * 1e3
        row["offset_mm_s2"] = c.accelerometer_offset_m_s2 * 1e3
        fs = c.accelerometer_bandwidth_Hz
        row["sensor_phi"] = math.exp(-2.0 * math.pi * fs * t) if fs > 0 else 0.0
        row["output_gain"] = c.output_gain
        row["output_limit"] = c.output_limit
        row["observer_measured_velocity"] = c.observer_measurement == "velocity"
        if c.source == "observer":
            o = c.observer
            if o not in designs:
                designs[o] = design_observer(o, t)
            fill_observer(row["observer"], designs[o])
    params["ring_mask"] = state.dtype["history_mm_s2"].shape[0] - 1
    params["initial_position_mm"] = np.broadcast_to(np.asarray(initial_position_mm, float), (n,))
    params["seed"] = np.uint64(seed)
    params["noise_id"] = ids.astype(np.uint64)
    return params, init_states(params, state)


__all__ = [
    "ACCELERATION_SOURCES",
    "INJECTIONS",
    "STATE_CONTROL",
    "STREAM_ACCELEROMETER",
    "StateControlParams",
    "design_k3",
    "state_control_records",
]
