"""Feed drive with dead time, Kim & Chung Eq. (6).

.. math:: \\frac{v(s)}{u(s)} = \\frac{a\\,e^{-L s}}{s + a}

with bandwidth ``a`` [rad/s] (29.33 in the paper) and dead time ``L`` [s] (0.1 s).
Input is the commanded feedrate ``u`` [mm/min], output the feed velocity ``v`` [mm/min].

Discretisation is exact for a command held over each plant step (zero-order hold):
``v[k+1] = phi v[k] + (1 - phi) u[k - N]`` with ``phi = exp(-a dt)`` and the dead time a
delay line of exactly ``N = L / dt`` whole plant steps (a ring buffer in the state
record).  The tool travel over a step is the exact integral of ``v`` over that step, so the
workpiece position carries no integration error either.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import delay_size, init_states, jit, per_run, record, register_element
from plants.linuxcnc_drive import LinuxCNCDrive, check_drive

#: Relative tolerance [-] for deciding that a dead time is a whole number of steps.
WHOLE_STEP_RTOL = 1e-9


class DeadTimeError(ValueError):
    """A dead time that is not a whole number of plant steps."""


def dead_time_steps(dead_time_s: float, plant_step_s: float, policy: str = "error") -> int:
    """Convert a dead time to a whole number of plant steps.

    Parameters
    ----------
    dead_time_s : float
        Dead time [s], >= 0.
    plant_step_s : float
        Plant step [s], > 0.
    policy : {"error", "round"}
        ``"error"`` raises :class:`DeadTimeError` unless ``dead_time_s / plant_step_s`` is a
        whole number (relative tolerance 1e-9); ``"round"`` rounds to the nearest whole
        number of steps and warns with the size of the change [s].

    Returns
    -------
    int
        Number of whole plant steps ``N``.
    """
    if plant_step_s <= 0:
        raise ValueError(f"plant step must be > 0 s, got {plant_step_s}")
    if dead_time_s < 0:
        raise DeadTimeError(f"dead time must be >= 0 s, got {dead_time_s}")
    ratio = dead_time_s / plant_step_s
    n = int(round(ratio))
    if abs(ratio - n) <= WHOLE_STEP_RTOL * max(1.0, ratio):
        return n
    if policy == "round":
        change = n * plant_step_s - dead_time_s
        warnings.warn(
            f"dead time {dead_time_s} s is {ratio:.6g} plant steps; rounded to {n} steps "
            f"({n * plant_step_s:.6g} s, a change of {change:+.3g} s)",
            stacklevel=2,
        )
        return n
    if policy != "error":
        raise ValueError(f"dead-time policy must be 'error' or 'round', got {policy!r}")
    raise DeadTimeError(
        f"dead time {dead_time_s} s is not a whole number of plant steps of {plant_step_s} s "
        f"({ratio:.6g} steps)"
    )


_LINUXCNC_DEFAULTS = LinuxCNCDrive()

#: Feed-drive models: Eq. (6), the servo axis beneath it, or LinuxCNC's trajectory planner.
FEED_DRIVE_KINDS = ("fopdt", "servo_axis", "linuxcnc")

#: The keys that only ``kind = "linuxcnc"`` reads (:class:`plants.linuxcnc_drive.LinuxCNCDrive`).
LINUXCNC_KEYS = (
    "servo_period_s",
    "max_acceleration_mm_s2",
    "blending",
    "feed_override",
    "max_feed_override",
    "axis_time_constant_s",
    "axis_dead_time_s",
)


@dataclass(frozen=True)
class FeedDriveParams:
    """Parameters of one feed drive (Eq. 6).

    Attributes
    ----------
    bandwidth_rad_s : float
        Pole magnitude ``a`` of the velocity loop [rad/s].
    dead_time_s : float
        Dead time ``L`` between override command and feed response [s].
    kind : {"fopdt", "servo_axis", "linuxcnc"}
        ``"fopdt"``: Eq. (6).  ``"servo_axis"``: Peng's servo axis under its 1 ms lead-lag
        position loop behind the dead time as the NC's override delay
        (:mod:`controllers.axis.servo_feed_drive`; ``bandwidth_rad_s`` then only sets the
        constant-feed reference time).  ``"linuxcnc"``: LinuxCNC's trajectory planner
        (:mod:`plants.linuxcnc_drive`, the keys below; ``bandwidth_rad_s`` and
        ``dead_time_s`` then only set the constant-feed reference time).
    servo_period_s : float
        ``kind = "linuxcnc"``: LinuxCNC's servo period [s] (``SERVO_PERIOD`` in its INI
        file's EMCMOT section); the plant step is a whole multiple of it, or it of the plant
        step.
    max_acceleration_mm_s2 : float
        ``kind = "linuxcnc"``: the move's acceleration limit [mm/s^2] (``MAX_ACCELERATION``
        of the INI file's AXIS_X section for a move along X).
    blending : {"G64", "G61"}
        ``kind = "linuxcnc"``: path mode; the planner ramps a feed change at half the
        acceleration under ``G64``, at all of it under ``G61``.
    feed_override : float
        ``kind = "linuxcnc"``: LinuxCNC's feed override [-], <= ``max_feed_override``; the
        adaptive feed is ``override / feed_override``, clipped to 0..1.
    max_feed_override : float
        ``kind = "linuxcnc"``: LinuxCNC's largest feed override [-] (``MAX_FEED_OVERRIDE``
        of the INI file's DISPLAY section); the speed is capped at ``F x max_feed_override``.
    axis_time_constant_s : float
        ``kind = "linuxcnc"``: lag of a real axis's drive behind the planner [s] (0: none, a
        simulated axis).
    axis_dead_time_s : float
        ``kind = "linuxcnc"``: dead time of a real axis's drive [s], whole plant steps.
    """

    bandwidth_rad_s: float = 29.33
    dead_time_s: float = 0.1
    kind: str = "fopdt"
    # the linuxcnc kind's keys: LinuxCNCDrive's defaults, stated once there
    servo_period_s: float = _LINUXCNC_DEFAULTS.servo_period_s
    max_acceleration_mm_s2: float = _LINUXCNC_DEFAULTS.max_acceleration_mm_s2
    blending: str = _LINUXCNC_DEFAULTS.blending
    feed_override: float = _LINUXCNC_DEFAULTS.feed_override
    max_feed_override: float = _LINUXCNC_DEFAULTS.max_feed_override
    axis_time_constant_s: float = _LINUXCNC_DEFAULTS.axis_time_constant_s
    axis_dead_time_s: float = _LINUXCNC_DEFAULTS.axis_dead_time_s

    def __post_init__(self) -> None:
        if self.kind not in FEED_DRIVE_KINDS:
            raise ValueError(
                f"kind must be one of {', '.join(FEED_DRIVE_KINDS)}, got {self.kind!r}"
            )
        if not self.bandwidth_rad_s > 0:
            raise ValueError(f"bandwidth_rad_s must be > 0, got {self.bandwidth_rad_s}")
        if not self.dead_time_s >= 0:
            raise ValueError(f"dead_time_s must be >= 0, got {self.dead_time_s}")
        problem = check_drive(self.linuxcnc)
        if problem is not None:
            raise ValueError(f"{problem[0]} {problem[1]}")

    @property
    def linuxcnc(self) -> LinuxCNCDrive:
        """The ``kind = "linuxcnc"`` keys as :class:`plants.linuxcnc_drive.LinuxCNCDrive`."""
        return LinuxCNCDrive(**{key: getattr(self, key) for key in LINUXCNC_KEYS})

    @property
    def time_constant_s(self) -> float:
        """Time constant ``1/a`` [s]."""
        return 1.0 / self.bandwidth_rad_s


def _dtypes(ring: int = 8) -> tuple[np.dtype, np.dtype]:
    params = record(
        "feed_drive.fopdt",
        [
            ("plant_step_s", "f8"),
            ("phi", "f8"),  # exp(-a dt)
            ("lag_integral_s", "f8"),  # integral of exp(-a t) over a step
            ("delay_steps", "i8"),
            ("ring_mask", "i8"),  # ring capacity - 1 (a power of two)
            ("initial_velocity_mm_min", "f8"),
        ],
    )
    state = record(
        "feed_drive.fopdt",
        [("velocity_mm_min", "f8"), ("head", "i8"), ("history_mm_min", "f8", (ring,))],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At rest (or at the initial velocity held for all of the past)."""
    s.velocity_mm_min = p.initial_velocity_mm_min
    s.head = 0
    for i in range(s.history_mm_min.shape[0]):
        s.history_mm_min[i] = p.initial_velocity_mm_min


@jit
def step(p, s, command_mm_min: float, load_force_N: float = 0.0) -> tuple[float, float, float]:  # noqa: ANN001
    """One plant step with the command ``u[k]`` [mm/min] held over it (Eq. 6 has no load
    input: ``load_force_N`` [N] is the slot's contract and is not used).

    Returns the velocity at the start of the step ``v[k]``, the delayed command
    ``u[k - N]`` reaching the lag over the step [mm/min], and the exact travel [mm].
    """
    s.history_mm_min[s.head] = command_mm_min
    delayed = s.history_mm_min[(s.head - p.delay_steps) & p.ring_mask]
    v = s.velocity_mm_min
    s.velocity_mm_min = p.phi * v + (1.0 - p.phi) * delayed
    # mm/min -> mm/s as a product with the folded constant: a division each plant step sat
    # on the path to the next step's position and cost about 7 % of the loop
    travel = (delayed * p.plant_step_s + (v - delayed) * p.lag_integral_s) * (1.0 / 60.0)
    s.head = (s.head + 1) & p.ring_mask
    return v, delayed, travel


@jit
def output(p, s) -> tuple[float, float, float]:  # noqa: ANN001
    """Feed velocity at the start of the step [mm/min]; Eq. (6) has no motor, so its
    armature current [A] and motor speed [rad/s] are NaN (the feed-drive slot's contract)."""
    return s.velocity_mm_min, np.nan, np.nan


FOPDT = register_element(
    "feed_drive.fopdt", _dtypes, init, step, "feed drive of Eq. (6): exact lag, delay line", output
)


def feed_drive_records(
    bandwidth_rad_s: ArrayLike,
    delay_steps: ArrayLike,
    plant_step_s: float,
    initial_velocity_mm_min: ArrayLike = 0.0,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of feed drives (Eq. 6), exact at the plant step.

    Parameters
    ----------
    bandwidth_rad_s : array_like, shape (runs,) or scalar
        Velocity-loop bandwidth ``a`` of each run [rad/s], > 0.
    delay_steps : array_like of int, shape (runs,) or scalar
        Dead time of each run in whole plant steps, >= 0.
    plant_step_s : float
        Plant step ``dt`` [s].
    initial_velocity_mm_min : array_like, shape (runs,) or scalar
        Velocity at start, also taken as every past command [mm/min].

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs, (a, n, v0) = per_run(bandwidth_rad_s, delay_steps, initial_velocity_mm_min, dtype=None)
    a, v0 = a.astype(float), v0.astype(float)
    if not np.issubdtype(n.dtype, np.integer):
        raise DeadTimeError("delay_steps must be whole numbers of plant steps")
    if np.any(n < 0):
        raise DeadTimeError("delay_steps must be >= 0")
    if np.any(~(a > 0)):
        raise ValueError("bandwidth_rad_s must be > 0")
    params, state = FOPDT.records(runs, ring=delay_size(int(n.max()) + 1))
    params["plant_step_s"] = plant_step_s
    params["phi"] = np.exp(-a * plant_step_s)
    params["lag_integral_s"] = -np.expm1(-a * plant_step_s) / a
    params["delay_steps"] = n
    params["ring_mask"] = state.dtype["history_mm_min"].shape[0] - 1
    params["initial_velocity_mm_min"] = v0
    return params, init_states(params, state)


def step_response(params: FeedDriveParams, time_s: ArrayLike) -> NDArray[np.float64]:
    """Continuous unit-step response of Eq. (6), ``1 - exp(-a (t - L))`` for ``t >= L``.

    Parameters
    ----------
    params : FeedDriveParams
    time_s : array_like, shape (n,)
        Times after the step [s].

    Returns
    -------
    ndarray, shape (n,)
        Velocity per unit command [-].
    """
    t = np.asarray(time_s, dtype=float) - params.dead_time_s
    return np.where(t > 0, -np.expm1(-params.bandwidth_rad_s * np.maximum(t, 0.0)), 0.0)


def time_to_63_percent_s(params: FeedDriveParams) -> float:
    """Time at which the step response reaches ``1 - 1/e`` (63.2 %), ``L + 1/a`` [s]."""
    return params.dead_time_s + 1.0 / params.bandwidth_rad_s


__all__ = [
    "FEED_DRIVE_KINDS",
    "FOPDT",
    "LINUXCNC_KEYS",
    "DeadTimeError",
    "FeedDriveParams",
    "dead_time_steps",
    "feed_drive_records",
    "step_response",
    "time_to_63_percent_s",
]
