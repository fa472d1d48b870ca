"""Fixed-gain feedrate-override PI on the force error, with anti-windup.

At each control instant ``k`` (period ``T_c``) with measured force ``y[k]`` [N]:

``e[k] = r - y[k]``, ``w[k] = kp e[k] + i[k]``, ``override[k] = clip(w[k], o_min, o_max)``,
``i[k+1] = i[k] + ki T_c e[k]``  (so ``C(z) = kp + ki T_c / (z - 1)``).

Anti-windup ``"clamping"`` (conditional integration): the integrator is held whenever the
unclamped output is beyond a limit and the error pushes it further out.  The integrator
then stays at the value it had when the clamp was reached, however long the clamp lasts,
so leaving the clamp is as prompt after one second as after a minute.  ``"none"`` keeps
integrating (for comparison).  The CNC applies ``feed = override x programmed feed``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

ANTI_WINDUP_KINDS = ("clamping", "none")


class PIState(NamedTuple):
    """PI state.

    Attributes
    ----------
    integral : ndarray, shape (runs,)
        Integrator ``i[k]`` [override, -].
    """

    integral: NDArray[np.float64]


class FeedOverridePI:
    """A batch of feedrate-override PI controllers.

    Parameters
    ----------
    reference_force_N : array_like, shape (runs,) or scalar
        Force reference ``r`` [N].
    kp_per_N, ki_per_N_s : array_like, shape (runs,) or scalar
        Gains [1/N], [1/(N s)].
    override_min, override_max : array_like, shape (runs,) or scalar
        Override limits [-].
    initial_override : array_like, shape (runs,) or scalar
        Integrator at start [-].
    control_period_s : float
        ``T_c`` [s].
    runs : int
    anti_windup : {"clamping", "none"}
    """

    def __init__(
        self,
        reference_force_N: ArrayLike,
        kp_per_N: ArrayLike,
        ki_per_N_s: ArrayLike,
        override_min: ArrayLike,
        override_max: ArrayLike,
        initial_override: ArrayLike,
        control_period_s: float,
        runs: int,
        anti_windup: str = "clamping",
    ) -> None:
        if anti_windup not in ANTI_WINDUP_KINDS:
            raise ValueError(f"anti_windup must be one of {ANTI_WINDUP_KINDS}, got {anti_windup!r}")

        def vec(x: ArrayLike) -> NDArray[np.float64]:
            return np.broadcast_to(np.asarray(x, dtype=float), (runs,)).copy()

        self.runs = runs
        self.reference_force_N = vec(reference_force_N)
        self.kp_per_N = vec(kp_per_N)
        self.ki_per_N_s = vec(ki_per_N_s)
        self.override_min = vec(override_min)
        self.override_max = vec(override_max)
        self.initial_override = vec(initial_override)
        self.control_period_s = float(control_period_s)
        self.anti_windup = anti_windup
        if np.any(self.override_min > self.override_max):
            raise ValueError("override_min must be <= override_max")

    def init(self) -> PIState:
        """Integrator at the initial override."""
        return PIState(self.initial_override.copy())

    def step(
        self, state: PIState, measured_force_N: NDArray[np.float64]
    ) -> tuple[PIState, NDArray[np.float64]]:
        """One control period.

        Parameters
        ----------
        state : PIState
        measured_force_N : ndarray, shape (runs,)
            Measured force at this control instant [N].

        Returns
        -------
        state : PIState
        override : ndarray, shape (runs,)
            Clamped feedrate override [-].
        """
        e = self.reference_force_N - measured_force_N
        i = state.integral
        w = self.kp_per_N * e + i
        override = np.clip(w, self.override_min, self.override_max)
        di = self.ki_per_N_s * self.control_period_s * e
        if self.anti_windup == "clamping":
            hold = ((w > self.override_max) & (e > 0)) | ((w < self.override_min) & (e < 0))
            di = np.where(hold, 0.0, di)
        return PIState(i + di), override


class ConstantOverride:
    """The conventional baseline: a fixed override, whatever the force.

    Parameters
    ----------
    override : array_like, shape (runs,) or scalar
        Override [-].
    runs : int
    """

    def __init__(self, override: ArrayLike, runs: int) -> None:
        self.runs = runs
        self.override = np.broadcast_to(np.asarray(override, dtype=float), (runs,)).copy()

    def init(self) -> tuple[()]:
        """No state."""
        return ()

    def step(
        self, state: tuple[()], measured_force_N: NDArray[np.float64]
    ) -> tuple[tuple[()], NDArray[np.float64]]:
        """Return the fixed override, shape (runs,)."""
        return state, self.override.copy()


__all__ = ["ANTI_WINDUP_KINDS", "ConstantOverride", "FeedOverridePI", "PIState"]
