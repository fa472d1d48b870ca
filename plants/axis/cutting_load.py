"""The cutting load on a feed axis: a force on the table (or a torque on the motor) in time.

Peng (seed 000, Sec. 4.2.2) applies a step of cutting torque ``T_c`` to the motor shaft
(4.99) and finds the position error it leaves (4.101); the practical maximum feed force is
2000 N (L1224).  The axis slot of the engine takes the feed force on the table [N]
(positive opposes positive motion); a torque step is converted with the axis's
force-to-torque factor, ``F = T_c / k`` (3.37), so the motor sees exactly ``T_c``.

The load is a piecewise-polynomial signal (:mod:`acc.engine.piecewise`); arbitrary
sequences are given sample by sample to :func:`acc.engine.axis_simulate.simulate_axis`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from acc.engine.piecewise import whole_steps

#: Load kinds.
LOAD_KINDS = ("none", "force_step", "torque_step")


@dataclass(frozen=True)
class CuttingLoadParams:
    """A step of cutting load on one axis.

    Attributes
    ----------
    kind : {"none", "force_step", "torque_step"}
    force_N : float
        Feed force after the step [N] (``"force_step"``).
    torque_Nm : float
        Cutting torque on the motor after the step [N m] (``"torque_step"``; servo axes).
    start_s : float
        Time of the step [s], >= 0, a whole number of plant steps.
    """

    kind: str = "none"
    force_N: float = 0.0
    torque_Nm: float = 0.0
    start_s: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in LOAD_KINDS:
            raise ValueError(f"kind must be one of {', '.join(LOAD_KINDS)}, got {self.kind!r}")
        for name in ("force_N", "torque_Nm"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")
        if not (math.isfinite(self.start_s) and self.start_s >= 0):
            raise ValueError(f"start_s must be >= 0, got {self.start_s!r}")

    def breakpoints(
        self, plant_step_s: float, force_to_torque_m: float | None = None
    ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Breakpoint steps and force values [N] of the load.

        Parameters
        ----------
        plant_step_s : float
            ``dt`` [s].
        force_to_torque_m : float, optional
            The axis's ``T_c / F`` [N m/N]; required for ``"torque_step"``.
        """
        if self.kind == "none":
            return np.zeros(1, np.int64), np.zeros(1)
        if self.kind == "torque_step":
            if not force_to_torque_m:
                raise ValueError("a torque_step load needs an axis with a force-to-torque factor")
            level = self.torque_Nm / force_to_torque_m
        else:
            level = self.force_N
        n = whole_steps(self.start_s, plant_step_s, "start_s")
        if n == 0:
            return np.zeros(1, np.int64), np.array([level])
        return np.array([0, n], np.int64), np.array([0.0, level])


__all__ = ["LOAD_KINDS", "CuttingLoadParams"]
