"""Feed drive with dead time, Kim & Chung Eq. (6).

.. math:: \\frac{v(s)}{u(s)} = \\frac{a\\,e^{-L s}}{s + a}

with bandwidth ``a`` [rad/s] (29.33 in the paper) and dead time ``L`` [s] (0.1 s).
Input is the commanded feedrate ``u`` [mm/min], output the feed velocity ``v`` [mm/min].

Discretisation is exact for a command held over each plant step (zero-order hold):
``v[k+1] = phi v[k] + (1 - phi) u[k - N]`` with ``phi = exp(-a dt)`` and the dead time a
delay line of exactly ``N = L / dt`` whole plant steps.  The tool travel over a step is the
exact integral of ``v`` over that step, so the workpiece position carries no integration
error either.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

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


@dataclass(frozen=True)
class FeedDriveParams:
    """Parameters of one feed drive (Eq. 6).

    Attributes
    ----------
    bandwidth_rad_s : float
        Pole magnitude ``a`` of the velocity loop [rad/s].
    dead_time_s : float
        Dead time ``L`` between override command and feed response [s].
    """

    bandwidth_rad_s: float = 29.33
    dead_time_s: float = 0.1

    def __post_init__(self) -> None:
        if not self.bandwidth_rad_s > 0:
            raise ValueError(f"bandwidth_rad_s must be > 0, got {self.bandwidth_rad_s}")
        if not self.dead_time_s >= 0:
            raise ValueError(f"dead_time_s must be >= 0, got {self.dead_time_s}")

    @property
    def time_constant_s(self) -> float:
        """Time constant ``1/a`` [s]."""
        return 1.0 / self.bandwidth_rad_s


class FeedDriveState(NamedTuple):
    """State of a batch of feed drives.

    Attributes
    ----------
    velocity_mm_min : ndarray, shape (runs,)
        Feed velocity at the start of the step [mm/min].
    history_mm_min : ndarray, shape (runs, max_delay + 1)
        Ring buffer of past commands [mm/min].
    head : int
        Ring-buffer slot the next command is written to.
    """

    velocity_mm_min: NDArray[np.float64]
    history_mm_min: NDArray[np.float64]
    head: int


class FeedDriveOutput(NamedTuple):
    """What a feed-drive step reports.

    Attributes
    ----------
    velocity_mm_min : ndarray, shape (runs,)
        Feed velocity at the start of the step [mm/min].
    delayed_command_mm_min : ndarray, shape (runs,)
        Command that reaches the velocity loop over this step, ``u[k - N]`` [mm/min].
    travel_mm : ndarray, shape (runs,)
        Exact tool travel over the step [mm].
    """

    velocity_mm_min: NDArray[np.float64]
    delayed_command_mm_min: NDArray[np.float64]
    travel_mm: NDArray[np.float64]


class FeedDrive:
    """A batch of feed drives (Eq. 6), exactly discretised at the plant step.

    Parameters
    ----------
    bandwidth_rad_s : array_like, shape (runs,) or scalar
        Velocity-loop bandwidth ``a`` of each run [rad/s].
    delay_steps : array_like of int, shape (runs,) or scalar
        Dead time of each run in whole plant steps.
    plant_step_s : float
        Plant step ``dt`` [s].
    runs : int
        Number of runs in the batch.
    """

    def __init__(
        self, bandwidth_rad_s: ArrayLike, delay_steps: ArrayLike, plant_step_s: float, runs: int
    ) -> None:
        a = np.broadcast_to(np.asarray(bandwidth_rad_s, dtype=float), (runs,)).copy()
        n = np.broadcast_to(np.asarray(delay_steps), (runs,)).copy()
        if not np.issubdtype(n.dtype, np.integer):
            raise DeadTimeError("delay_steps must be whole numbers of plant steps")
        if np.any(n < 0):
            raise DeadTimeError("delay_steps must be >= 0")
        if np.any(a <= 0):
            raise ValueError("bandwidth_rad_s must be > 0")
        self.runs = runs
        self.plant_step_s = float(plant_step_s)
        self.bandwidth_rad_s = a
        self.delay_steps = n.astype(np.int64)
        self.phi = np.exp(-a * plant_step_s)
        #: travel coefficient of (v[k] - u_d): integral of exp(-a t) over the step [s]
        self.lag_integral_s = -np.expm1(-a * plant_step_s) / a
        self._rows = np.arange(runs)
        self._size = int(self.delay_steps.max(initial=0)) + 1

    def init(self, velocity_mm_min: ArrayLike = 0.0) -> FeedDriveState:
        """Drives at rest (or at a constant velocity held for all of the past).

        Parameters
        ----------
        velocity_mm_min : array_like, shape (runs,) or scalar
            Initial velocity, also taken as every past command [mm/min].
        """
        v0 = np.broadcast_to(np.asarray(velocity_mm_min, dtype=float), (self.runs,)).copy()
        history = np.repeat(v0[:, None], self._size, axis=1)
        return FeedDriveState(v0, history, 0)

    def step(
        self, state: FeedDriveState, command_mm_min: NDArray[np.float64]
    ) -> tuple[FeedDriveState, FeedDriveOutput]:
        """Advance one plant step with the command held over the step.

        Parameters
        ----------
        state : FeedDriveState
        command_mm_min : ndarray, shape (runs,)
            Commanded feedrate ``u[k]`` [mm/min].

        Returns
        -------
        state : FeedDriveState
            State at ``k + 1``; the input state is not modified.
        output : FeedDriveOutput
            Velocity at ``k``, the delayed command and the travel over the step.
        """
        history = state.history_mm_min.copy()
        history[:, state.head] = command_mm_min
        delayed = history[self._rows, (state.head - self.delay_steps) % self._size]
        v = state.velocity_mm_min
        v_next = self.phi * v + (1.0 - self.phi) * delayed
        travel = (delayed * self.plant_step_s + (v - delayed) * self.lag_integral_s) / 60.0
        new_state = FeedDriveState(v_next, history, (state.head + 1) % self._size)
        return new_state, FeedDriveOutput(v, delayed, travel)


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
    "DeadTimeError",
    "FeedDrive",
    "FeedDriveOutput",
    "FeedDriveParams",
    "FeedDriveState",
    "dead_time_steps",
    "step_response",
    "time_to_63_percent_s",
]
