"""Disturbance observer around the nominal feed-to-force plant, Kim & Chung Eqs. (10)-(11).

Loop (Fig. 8).  The plant is ``P(s) = P0(s) e^{-L s}`` from commanded feed ``u`` [mm/min]
to force ``f`` [N], with rational part ``P0 = a K2 / ((s + a)(s - p2))``.  The observer
compares the feed the force implies with the feed that was commanded one dead time ago:

.. math:: \\hat d = Q(s) \\left[ P_{n0}^{-1}(s)\\, f - e^{-L_n s} u \\right], \\qquad
          u = e' - \\hat d

where ``e'`` is the feed asked for by the outer (PI) controller.  For ``P = Pn (1 + Delta)``
and a feed disturbance ``d`` this gives Eq. (10); the inner loop is
``1 + Q Delta e^{-L s} = 0`` (``Delta = P / Pn - 1`` taken on the rational parts when
both dead times agree), so ``max_w |Delta(jw) Q(jw)| < 1`` is sufficient for its stability.

Discretisation at the control period ``T_c`` (done once per parameter set):

* ``Q(s) P_{n0}^{-1}(s)`` on the sampled force.  ``P_{n0}^{-1}`` is split as
  ``(s^2 + (a - p2) s - a p2) / (a K2)``, so the force goes through one fixed filter bank
  ``Q(s) [s^2, s, 1]^T`` and the model enters only in the output combination.  A model
  that changes every period (the estimated one, for ``dob_adaptive_pi``) therefore needs no
  re-discretisation.  The force is a continuous signal, so the bank is discretised with a
  first-order (triangle) hold, exact for a force that is linear between samples.
* ``Q(s)`` on the commanded feed, which *is* held over each period: zero-order hold, exact.
  ``Q`` strictly proper makes this path strictly causal, so ``d_hat[k]`` needs commands up
  to ``k - 1`` only (no algebraic loop).
* The nominal dead time ``L_n`` is a delay line of ``N = L_n / T_c`` whole control periods.

Both discrete paths keep the DC gains exactly (``1 / Pn(0)`` and 1), so a constant plant
equal to the model gives ``d_hat -> 0`` and a constant feed disturbance ``d`` gives
``d_hat -> d`` exactly.  An optional saturation bounds ``|d_hat|``.
"""

from __future__ import annotations

from typing import NamedTuple

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from controllers.q_filter import PAPER_ORDER, q_filter

#: Powers of s the force bank applies after Q: rows of its output are Q s^2, Q s, Q.
_BANK_POWERS = (2, 1, 0)


def _companion(num: NDArray, den: NDArray, powers: tuple[int, ...]) -> control.StateSpace:
    """Continuous SIMO realisation of ``num(s) s^j / den(s)`` for ``j`` in ``powers``.

    Controllable canonical form on ``xi = y / den(s)``; states ``xi, xi', ...``.
    """
    den = np.trim_zeros(np.asarray(den, dtype=float), "f")
    n = len(den) - 1
    lead = den[0]
    d_asc = den[::-1] / lead  # d_asc[i]: coefficient of s^i, monic
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1, :] = -d_asc[:n]
    B = np.zeros((n, 1))
    B[-1, 0] = 1.0 / lead
    C = np.zeros((len(powers), n))
    D = np.zeros((len(powers), 1))
    for row, j in enumerate(powers):
        p = np.polymul(np.asarray(num, dtype=float), np.r_[1.0, np.zeros(j)])
        p_asc = p[::-1]
        if len(p_asc) > n + 1 and np.any(p_asc[n + 1 :] != 0):
            raise ValueError("Q(s) s^2 must be proper: the Q filter needs order >= 2 + deg(num)")
        p_asc = np.r_[p_asc, np.zeros(max(0, n + 1 - len(p_asc)))][: n + 1]
        C[row] = p_asc[:n] - p_asc[n] * d_asc[:n]
        D[row, 0] = p_asc[n] / lead
    return control.ss(A, B, C, D)


class ObserverFilters(NamedTuple):
    """Discrete filters of one observer (python-control, sample time ``T_c``).

    Attributes
    ----------
    force_bank : control.StateSpace
        ``Q [s^2, s, 1]^T`` on the force, first-order hold; 1 input [N], 3 outputs.
    input_filter : control.StateSpace
        ``Q`` on the delayed command, zero-order hold; 1 input, 1 output [mm/min].
    """

    force_bank: control.StateSpace
    input_filter: control.StateSpace


def observer_filters(q: control.TransferFunction, control_period_s: float) -> ObserverFilters:
    """Discretise the two observer paths for a Q filter (see the module docstring).

    Parameters
    ----------
    q : control.TransferFunction
        Continuous, strictly proper ``Q(s)`` with ``Q s^2`` proper (``Q = 0`` allowed).
    control_period_s : float
        ``T_c`` [s].
    """
    num = np.atleast_1d(np.squeeze(q.num[0][0])).astype(float)
    den = np.atleast_1d(np.squeeze(q.den[0][0])).astype(float)
    if not np.any(num):
        # Q = 0: a one-state realisation with zero output keeps the array shapes uniform
        num, den = np.zeros(1), np.ones(2)
    elif len(np.trim_zeros(num, "f")) >= len(np.trim_zeros(den, "f")):
        raise ValueError("Q(s) must be strictly proper")
    bank = _companion(num, den, _BANK_POWERS)
    qin = _companion(num, den, (0,))
    return ObserverFilters(
        control.c2d(bank, control_period_s, method="foh"),
        control.c2d(qin, control_period_s, method="zoh"),
    )


class DisturbanceObserverState(NamedTuple):
    """Observer state.

    Attributes
    ----------
    force_bank : ndarray, shape (runs, n)
        State of the force filter bank.
    input_filter : ndarray, shape (runs, n)
        State of ``Q`` on the delayed command.
    history_mm_min : ndarray, shape (runs, max_delay + 1)
        Ring buffer of past commands [mm/min].
    head : int
        Slot the next command is written to.
    """

    force_bank: NDArray[np.float64]
    input_filter: NDArray[np.float64]
    history_mm_min: NDArray[np.float64]
    head: int


class DisturbanceObserver:
    """A batch of discrete disturbance observers (module docstring).

    Parameters
    ----------
    tau_s : array_like, shape (runs,) or scalar
        Q-filter time constant ``tau`` of each run [s], > 0.
    delay_periods : array_like of int, shape (runs,) or scalar
        Nominal dead time in whole control periods ``N``.
    control_period_s : float
        ``T_c`` [s].
    runs : int
    limit_mm_min : array_like, shape (runs,) or scalar
        Saturation of ``|d_hat|`` [mm/min]; ``inf`` for none.
    order : int
        Q-filter order (3 in Eq. 11).
    q : control.TransferFunction, optional
        A Q filter to use instead of ``1 / (tau s + 1)^order`` for every run (e.g. ``Q = 0``).
    """

    def __init__(
        self,
        tau_s: ArrayLike,
        delay_periods: ArrayLike,
        control_period_s: float,
        runs: int,
        limit_mm_min: ArrayLike = np.inf,
        order: int = PAPER_ORDER,
        q: control.TransferFunction | None = None,
    ) -> None:
        tau = np.broadcast_to(np.asarray(tau_s, dtype=float), (runs,))
        n_delay = np.broadcast_to(np.asarray(delay_periods), (runs,)).astype(np.int64)
        if np.any(n_delay < 0):
            raise ValueError("delay_periods must be >= 0")
        self.runs = runs
        self.control_period_s = float(control_period_s)
        self.delay_periods = n_delay
        self.limit_mm_min = np.broadcast_to(np.asarray(limit_mm_min, dtype=float), (runs,)).copy()
        if np.any(self.limit_mm_min < 0):
            raise ValueError("limit_mm_min must be >= 0")
        filters: dict[float, ObserverFilters] = {}
        per_run = []
        for t in tau:
            if q is None and float(t) not in filters:
                filters[float(t)] = observer_filters(q_filter(float(t), order), control_period_s)
            per_run.append(observer_filters(q, control_period_s) if q is not None else filters[t])
        self.filters = tuple(per_run)
        self.bank_A = np.stack([f.force_bank.A for f in per_run])
        self.bank_B = np.stack([f.force_bank.B[:, 0] for f in per_run])
        self.bank_C = np.stack([f.force_bank.C for f in per_run])
        self.bank_D = np.stack([f.force_bank.D[:, 0] for f in per_run])
        self.in_A = np.stack([f.input_filter.A for f in per_run])
        self.in_B = np.stack([f.input_filter.B[:, 0] for f in per_run])
        self.in_C = np.stack([f.input_filter.C[0] for f in per_run])
        if np.any(np.stack([f.input_filter.D for f in per_run]) != 0):
            raise ValueError("the discrete Q on the command must be strictly causal")
        self._rows = np.arange(runs)
        self._size = int(n_delay.max(initial=0)) + 1

    def init(self) -> DisturbanceObserverState:
        """At rest: no force, no past command."""
        nb = self.bank_A.shape[1]
        ni = self.in_A.shape[1]
        return DisturbanceObserverState(
            np.zeros((self.runs, nb)),
            np.zeros((self.runs, ni)),
            np.zeros((self.runs, self._size)),
            0,
        )

    def estimate(
        self,
        state: DisturbanceObserverState,
        force_N: NDArray[np.float64],
        bandwidth_rad_s: NDArray[np.float64],
        k2_N_min_per_mm_s: NDArray[np.float64],
        p2_rad_s: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Disturbance estimate ``d_hat[k]`` [mm/min], shape (runs,).

        Parameters
        ----------
        state : DisturbanceObserverState
            State at ``k`` (commands up to ``k - 1`` absorbed).
        force_N : ndarray, shape (runs,)
            Measured force ``f[k]`` [N].
        bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s : ndarray, shape (runs,)
            Model ``a``, ``K2``, ``p2`` whose inverse the observer uses.
        """
        m = np.einsum("rij,rj->ri", self.bank_C, state.force_bank) + self.bank_D * force_N[:, None]
        a, k2, p2 = bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s
        implied_feed = (m[:, 0] + (a - p2) * m[:, 1] - a * p2 * m[:, 2]) / (a * k2)
        delayed_q = np.einsum("ri,ri->r", self.in_C, state.input_filter)
        return np.clip(implied_feed - delayed_q, -self.limit_mm_min, self.limit_mm_min)

    def advance(
        self,
        state: DisturbanceObserverState,
        force_N: NDArray[np.float64],
        command_mm_min: NDArray[np.float64],
    ) -> DisturbanceObserverState:
        """Absorb ``f[k]`` and the command ``u[k]`` applied from ``k``; state at ``k + 1``.

        Parameters
        ----------
        state : DisturbanceObserverState
        force_N : ndarray, shape (runs,)
            Measured force ``f[k]`` [N].
        command_mm_min : ndarray, shape (runs,)
            Command ``u[k]`` actually sent (after clamping) [mm/min].
        """
        history = state.history_mm_min.copy()
        history[:, state.head] = command_mm_min
        delayed = history[self._rows, (state.head - self.delay_periods) % self._size]
        xb = np.einsum("rij,rj->ri", self.bank_A, state.force_bank) + self.bank_B * force_N[:, None]
        xi = np.einsum("rij,rj->ri", self.in_A, state.input_filter) + self.in_B * delayed[:, None]
        return DisturbanceObserverState(xb, xi, history, (state.head + 1) % self._size)


__all__ = [
    "DisturbanceObserver",
    "DisturbanceObserverState",
    "ObserverFilters",
    "observer_filters",
]
