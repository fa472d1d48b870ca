"""Cutting-force measurement: additive white noise and a first-order low-pass filter.

The raw signal at plant step ``k`` is ``s[k] = f[k] + sigma n[k]`` with ``n`` standard normal
samples drawn by the caller from each run's own generator.  The filter
``H(s) = 1 / (s / w_c + 1)`` is discretised as ``y[k] = phi y[k-1] + (1 - phi) s[k]`` with
``phi = exp(-w_c dt)``: exact for a signal held over ``(t[k-1], t[k]]``.  A cut-off of 0
means no filter (``y = s``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class ForceSensorParams:
    """Measurement chain of one run.

    Attributes
    ----------
    noise_std_N : float
        Standard deviation of the additive white noise per plant step [N], >= 0.
    lowpass_cutoff_hz : float
        Cut-off of the first-order low-pass [Hz]; 0 disables the filter.
    """

    noise_std_N: float = 0.0
    lowpass_cutoff_hz: float = 0.0

    def __post_init__(self) -> None:
        if not self.noise_std_N >= 0:
            raise ValueError(f"noise_std_N must be >= 0, got {self.noise_std_N}")
        if not self.lowpass_cutoff_hz >= 0:
            raise ValueError(f"lowpass_cutoff_hz must be >= 0, got {self.lowpass_cutoff_hz}")


class ForceSensorState(NamedTuple):
    """Filter output at the previous step [N], shape (runs,)."""

    filtered_N: NDArray[np.float64]


class ForceSensor:
    """A batch of force sensors.

    Parameters
    ----------
    noise_std_N : ndarray, shape (runs,)
        Noise standard deviation [N].
    lowpass_cutoff_hz : ndarray, shape (runs,)
        Filter cut-off [Hz], 0 = none.
    plant_step_s : float
        Plant step [s].
    """

    def __init__(
        self, noise_std_N: NDArray, lowpass_cutoff_hz: NDArray, plant_step_s: float
    ) -> None:
        self.noise_std_N = np.asarray(noise_std_N, dtype=float)
        wc = 2.0 * math.pi * np.asarray(lowpass_cutoff_hz, dtype=float)
        #: filter pole factor; 0 where there is no filter, so y = s
        self.phi = np.where(wc > 0, np.exp(-wc * plant_step_s), 0.0)
        self.runs = self.noise_std_N.shape[0]
        #: whether any run has measurement noise
        self.noisy = bool(np.any(self.noise_std_N > 0))

    def init(self, force_N: float = 0.0) -> ForceSensorState:
        """Filter at rest at a given force [N]."""
        return ForceSensorState(np.full(self.runs, float(force_N)))

    def step(
        self, state: ForceSensorState, force_N: NDArray, standard_normal: NDArray | None
    ) -> tuple[ForceSensorState, NDArray[np.float64]]:
        """Measure one plant step.

        Parameters
        ----------
        state : ForceSensorState
        force_N : ndarray, shape (runs,)
            True force [N].
        standard_normal : ndarray, shape (runs,), or None
            Standard normal samples for this step (None when no run is noisy).

        Returns
        -------
        state : ForceSensorState
        measured_N : ndarray, shape (runs,)
            Measured force [N].
        """
        raw = force_N if standard_normal is None else force_N + self.noise_std_N * standard_normal
        y = self.phi * state.filtered_N + (1.0 - self.phi) * raw
        return ForceSensorState(y), y


__all__ = ["ForceSensor", "ForceSensorParams", "ForceSensorState"]
