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

The sensor in the model (``dob_sensor_cutoff_hz = w_s / 2 pi > 0``).  The force the observer
reads is the measured one, ``y_m = H f`` with ``H = 1 / (1 + s / w_s)``; a model without
``H`` sees ``H P`` as the plant, a model error of ``H - 1`` (the nominal loop then differs
from the bare PI loop).  With the sensor modelled, the observer inverts ``H Pn``:
``d_hat = Q [(H P_{n0})^{-1} y_m - e^{-L_n s} u]``.  ``H^{-1} = 1 + s / w_s`` is fixed, so it
joins the force bank, ``Q (1 + s / w_s) [s^2, s, 1]^T``; the model's combination is
unchanged.  ``Q`` then needs relative degree >= 3.

Q's numerator: :func:`controllers.q_filter.q_polynomials` (``dob_q_numerator``,
``dob_q_order``); the paper's Eq. (11) is the default.

Compiled: :func:`estimate` and :func:`advance` are the observer's per-period law (records
from :func:`observer_records`); :func:`observer_filters` gives the same discrete filters as
python-control systems for the analysis.

Both discrete paths keep the DC gains exactly (``1 / Pn(0)`` and 1), so a constant plant
equal to the model gives ``d_hat -> 0`` and a constant feed disturbance ``d`` gives
``d_hat -> d`` exactly.  An optional saturation bounds ``|d_hat|``.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import delay_size, init_states, jit, record, register_element, ring_size
from controllers.discretisation import hold_discretisation
from controllers.q_filter import PAPER_ORDER, check_q_numerator, q_polynomials

#: Powers of s the force bank applies after Q: rows of its output are Q s^2, Q s, Q.
_BANK_POWERS = (2, 1, 0)


OBSERVER_MODELS = ("nominal", "estimated")


@dataclass(frozen=True)
class ObserverOptions:
    """``[controller]`` options of the observer kinds.

    Attributes
    ----------
    dob_tau_s : float
        Q-filter time constant ``tau`` of Eq. (11) [s], > 0.
    dob_disturbance_limit_mm_min : float or None
        Saturation of the disturbance estimate ``|d_hat|`` [mm/min]; None = none.
    dob_model : {"estimated", "nominal"}
        Model the observer of ``dob_adaptive_pi`` inverts.
    dob_q_numerator : tuple of float
        ``a_0, a_1, ...`` of Q's numerator ``sum a_i (tau s)^i`` (ascending powers; ``a_0 =
        1``, unit DC gain); ``(1,)`` is Eq. (11).
    dob_q_order : int
        ``n`` of Q's denominator ``(tau s + 1)^n``; relative degree ``n - m >= 2`` (``>= 3``
        with the sensor modelled).
    dob_sensor_cutoff_hz : float
        Cut-off of the sensor low-pass the observer's model includes [Hz]; 0: the model
        ignores the sensor (Kim & Chung).  Set it to ``sensor.lowpass_cutoff_hz``.
    """

    dob_tau_s: float = 0.1
    dob_disturbance_limit_mm_min: float | None = None
    dob_model: str = "estimated"
    dob_q_numerator: tuple[float, ...] = (1.0,)
    dob_q_order: int = PAPER_ORDER
    dob_sensor_cutoff_hz: float = 0.0

    def __post_init__(self) -> None:
        if not self.dob_tau_s > 0:
            raise ValueError(f"dob_tau_s must be > 0, got {self.dob_tau_s}")
        limit = self.dob_disturbance_limit_mm_min
        if limit is not None and not limit >= 0:
            raise ValueError(f"dob_disturbance_limit_mm_min must be >= 0, got {limit}")
        if self.dob_model not in OBSERVER_MODELS:
            raise ValueError(f"dob_model must be one of {OBSERVER_MODELS}, got {self.dob_model!r}")
        if isinstance(self.dob_q_order, bool) or int(self.dob_q_order) != self.dob_q_order or (
            self.dob_q_order < 2
        ):
            raise ValueError(f"dob_q_order must be a whole number >= 2, got {self.dob_q_order}")
        if not (self.dob_sensor_cutoff_hz >= 0 and np.isfinite(self.dob_sensor_cutoff_hz)):
            raise ValueError(
                f"dob_sensor_cutoff_hz must be >= 0 (0: none), got {self.dob_sensor_cutoff_hz}"
            )
        check_q_numerator(
            self.dob_q_numerator, int(self.dob_q_order), 3 if self.dob_sensor_cutoff_hz else 2
        )

    def q_polynomials(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``Q(s)`` as ``(num, den)``, highest power first
        (:func:`controllers.q_filter.q_polynomials`)."""
        return q_polynomials(self.dob_tau_s, self.dob_q_numerator, int(self.dob_q_order))


def _companion(num: NDArray, den: NDArray, powers: tuple[int, ...]) -> tuple[NDArray, ...]:
    """Continuous SIMO realisation ``(A, B, C, D)`` of ``num(s) s^j / den(s)``, ``j`` in
    ``powers``: controllable canonical form on ``xi = y / den(s)``; states ``xi, xi', ...``."""
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
    return A, B, C, D


class ObserverMatrices(NamedTuple):
    """Discrete state-space matrices of the two observer paths (sample time ``T_c``).

    Attributes
    ----------
    force_bank : tuple of ndarray
        ``(A, B, C, D)`` of ``Q [s^2, s, 1]^T`` on the force, first-order hold: 1 input
        [N], 3 outputs.
    input_filter : tuple of ndarray
        ``(A, B, C, D)`` of ``Q`` on the delayed command, zero-order hold [mm/min].
    """

    force_bank: tuple[NDArray, NDArray, NDArray, NDArray]
    input_filter: tuple[NDArray, NDArray, NDArray, NDArray]


def sensor_inverse(sensor_cutoff_hz: float) -> NDArray[np.float64]:
    """``H^{-1} = s / w_s + 1`` (highest power first), ``[1]`` for no sensor model."""
    if sensor_cutoff_hz > 0:
        return np.array([1.0 / (2.0 * np.pi * sensor_cutoff_hz), 1.0])
    return np.ones(1)


def observer_matrices(
    q_num: ArrayLike, q_den: ArrayLike, control_period_s: float, sensor_cutoff_hz: float = 0.0
) -> ObserverMatrices:
    """Discretise the two observer paths of a Q filter (see the module docstring).

    ``scipy.signal.cont2discrete`` (what python-control's ``c2d`` calls) of the canonical
    realisations; ``Q = 0`` gives a one-state realisation with zero output.

    Parameters
    ----------
    q_num, q_den : array_like
        ``Q(s)`` numerator and denominator, highest power first; strictly proper, with
        ``Q s^2`` proper.
    control_period_s : float
        ``T_c`` [s].
    sensor_cutoff_hz : float
        The model's sensor low-pass [Hz] (0: none): the force bank is then
        ``Q (1 + s / w_s) [s^2, s, 1]^T`` (module docstring).
    """
    num = np.atleast_1d(np.asarray(q_num, dtype=float))
    den = np.atleast_1d(np.asarray(q_den, dtype=float))
    if not np.any(num):
        num, den = np.zeros(1), np.ones(2)
    elif len(np.trim_zeros(num, "f")) >= len(np.trim_zeros(den, "f")):
        raise ValueError("Q(s) must be strictly proper")
    bank_num = np.polymul(num, sensor_inverse(sensor_cutoff_hz))
    bank = hold_discretisation(_companion(bank_num, den, _BANK_POWERS), control_period_s, "foh")
    qin = hold_discretisation(_companion(num, den, (0,)), control_period_s, "zoh")
    return ObserverMatrices(bank, qin)


@functools.lru_cache(maxsize=1024)
def _matrices(
    num: tuple, den: tuple, control_period_s: float, sensor_cutoff_hz: float = 0.0
) -> ObserverMatrices:
    return observer_matrices(num, den, control_period_s, sensor_cutoff_hz)


class ObserverFilters(NamedTuple):
    """Discrete filters of one observer (python-control, sample time ``T_c``), for analysis.

    Attributes
    ----------
    force_bank : control.StateSpace
        ``Q [s^2, s, 1]^T`` on the force, first-order hold; 1 input [N], 3 outputs.
    input_filter : control.StateSpace
        ``Q`` on the delayed command, zero-order hold; 1 input, 1 output [mm/min].
    """

    force_bank: Any
    input_filter: Any


def observer_filters(
    q: Any, control_period_s: float, sensor_cutoff_hz: float = 0.0
) -> ObserverFilters:
    """The filters of :func:`observer_matrices` as python-control state-space systems.

    Parameters
    ----------
    q : control.TransferFunction
        Continuous, strictly proper ``Q(s)`` with ``Q s^2`` proper (``Q = 0`` allowed).
    control_period_s : float
        ``T_c`` [s].
    sensor_cutoff_hz : float
        The model's sensor low-pass [Hz] (0: none).
    """
    import control

    num = np.atleast_1d(np.squeeze(q.num[0][0])).astype(float)
    den = np.atleast_1d(np.squeeze(q.den[0][0])).astype(float)
    m = observer_matrices(num, den, control_period_s, sensor_cutoff_hz)
    return ObserverFilters(
        control.ss(*m.force_bank, control_period_s), control.ss(*m.input_filter, control_period_s)
    )


def _dtypes(order: int = 4, ring: int = 16) -> tuple[np.dtype, np.dtype]:
    params = record(
        "observer.disturbance",
        [
            ("order", "i8"),
            ("bank_A", "f8", (order, order)),
            ("bank_B", "f8", (order,)),
            ("bank_C", "f8", (3, order)),
            ("bank_D", "f8", (3,)),
            ("input_A", "f8", (order, order)),
            ("input_B", "f8", (order,)),
            ("input_C", "f8", (order,)),
            ("delay_periods", "i8"),
            ("ring_mask", "i8"),
            ("limit_mm_min", "f8"),
        ],
    )
    state = record(
        "observer.disturbance",
        [
            ("force_bank", "f8", (order,)),
            ("input_filter", "f8", (order,)),
            ("next_bank", "f8", (order,)),
            ("next_input", "f8", (order,)),
            ("head", "i8"),
            ("history_mm_min", "f8", (ring,)),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At rest: no force, no past command."""
    for i in range(s.force_bank.shape[0]):
        s.force_bank[i] = 0.0
        s.input_filter[i] = 0.0
    s.head = 0
    for i in range(s.history_mm_min.shape[0]):
        s.history_mm_min[i] = 0.0


@jit
def _bank_outputs(p, s, force_N: float, n: int) -> tuple[float, float, float, float]:  # noqa: ANN001
    """The force bank's three outputs and the input filter's output, over the first ``n``
    states (called with a constant ``n``, it is inlined and its loops unrolled)."""
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    for j in range(n):
        m0 += p.bank_C[0, j] * s.force_bank[j]
    for j in range(n):
        m1 += p.bank_C[1, j] * s.force_bank[j]
    for j in range(n):
        m2 += p.bank_C[2, j] * s.force_bank[j]
    m0 += p.bank_D[0] * force_N
    m1 += p.bank_D[1] * force_N
    m2 += p.bank_D[2] * force_N
    dq = 0.0
    for j in range(n):
        dq += p.input_C[j] * s.input_filter[j]
    return m0, m1, m2, dq


@jit
def estimate(p, s, force_N: float, bandwidth_rad_s: float, k2: float, p2: float) -> float:  # noqa: ANN001
    """Disturbance estimate ``d_hat[k]`` [mm/min] from the state at ``k`` and ``f[k]`` [N],
    inverting the model ``a``, ``K2`` [N/(mm/min)/s], ``p2`` [rad/s].

    The usual orders (2 to 4) are passed to the bank as constants, whose loops the compiler
    then unrolls: loops of the run-time order cost about 3 % of a plant step of
    ``dob_adaptive_pi`` (order 3) with :func:`advance`'s.
    """
    n = p.order
    if n == 3:
        m0, m1, m2, dq = _bank_outputs(p, s, force_N, 3)
    elif n == 4:
        m0, m1, m2, dq = _bank_outputs(p, s, force_N, 4)
    elif n == 2:
        m0, m1, m2, dq = _bank_outputs(p, s, force_N, 2)
    else:
        m0, m1, m2, dq = _bank_outputs(p, s, force_N, n)
    a = bandwidth_rad_s
    implied = (m0 + (a - p2) * m1 - a * p2 * m2) / (a * k2)
    d = implied - dq
    if d < -p.limit_mm_min:
        return -p.limit_mm_min
    if d > p.limit_mm_min:
        return p.limit_mm_min
    return d


@jit
def _advance_banks(p, s, force_N: float, delayed: float, n: int) -> None:  # noqa: ANN001
    """Both filters' states to ``k + 1`` over the first ``n`` states (as
    :func:`_bank_outputs`)."""
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += p.bank_A[i, j] * s.force_bank[j]
        s.next_bank[i] = acc + p.bank_B[i] * force_N
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += p.input_A[i, j] * s.input_filter[j]
        s.next_input[i] = acc + p.input_B[i] * delayed
    for i in range(n):
        s.force_bank[i] = s.next_bank[i]
        s.input_filter[i] = s.next_input[i]


@jit
def advance(p, s, force_N: float, command_mm_min: float) -> None:  # noqa: ANN001
    """Absorb ``f[k]`` and the command ``u[k]`` applied from ``k``; state at ``k + 1``."""
    s.history_mm_min[s.head] = command_mm_min
    delayed = s.history_mm_min[(s.head - p.delay_periods) & p.ring_mask]
    n = p.order
    if n == 3:  # the usual orders as constants (estimate)
        _advance_banks(p, s, force_N, delayed, 3)
    elif n == 4:
        _advance_banks(p, s, force_N, delayed, 4)
    elif n == 2:
        _advance_banks(p, s, force_N, delayed, 2)
    else:
        _advance_banks(p, s, force_N, delayed, n)
    s.head = (s.head + 1) & p.ring_mask


@jit
def step(p, s, force_N: float, command_mm_min: float, bandwidth_rad_s: float, k2: float,  # noqa: ANN001
         p2: float) -> float:
    """One control period alone (estimate, then advance with the given command)."""
    d = estimate(p, s, force_N, bandwidth_rad_s, k2, p2)
    advance(p, s, force_N, command_mm_min)
    return d


DISTURBANCE = register_element(
    "observer.disturbance",
    _dtypes,
    init,
    step,
    "Q-filter disturbance observer of Eqs. (10)-(11), nominal dead time explicit",
)


def observer_records(
    q_filters: Sequence[tuple[ArrayLike, ArrayLike]],
    delay_periods: ArrayLike,
    control_period_s: float,
    limit_mm_min: ArrayLike = np.inf,
    sensor_cutoff_hz: ArrayLike = 0.0,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of observers.

    Parameters
    ----------
    q_filters : sequence of (num, den), length runs
        Each run's ``Q(s)`` (highest power first); runs with equal filters are discretised
        once.
    delay_periods : array_like of int, shape (runs,) or scalar
        Nominal dead time in whole control periods ``N``, >= 0.
    control_period_s : float
        ``T_c`` [s].
    limit_mm_min : array_like, shape (runs,) or scalar
        Saturation of ``|d_hat|`` [mm/min]; ``inf`` for none.
    sensor_cutoff_hz : array_like, shape (runs,) or scalar
        Sensor low-pass each run's model includes [Hz]; 0: none.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs = len(q_filters)
    n_delay = np.broadcast_to(np.asarray(delay_periods), (runs,)).astype(np.int64)
    if np.any(n_delay < 0):
        raise ValueError("delay_periods must be >= 0")
    limit = np.broadcast_to(np.asarray(limit_mm_min, dtype=float), (runs,))
    if np.any(limit < 0):
        raise ValueError("limit_mm_min must be >= 0")
    sensor = np.broadcast_to(np.asarray(sensor_cutoff_hz, dtype=float), (runs,))
    if np.any(~(sensor >= 0)):
        raise ValueError("sensor_cutoff_hz must be >= 0")
    mats = [
        _matrices(
            tuple(float(x) for x in np.atleast_1d(num)),
            tuple(float(x) for x in np.atleast_1d(den)),
            float(control_period_s),
            float(wc),
        )
        for (num, den), wc in zip(q_filters, sensor, strict=True)
    ]
    order = max(m.force_bank[0].shape[0] for m in mats)
    params, state = DISTURBANCE.records(
        runs, order=ring_size(order), ring=delay_size(int(n_delay.max(initial=0)) + 1)
    )
    for i, m in enumerate(mats):
        (ba, bb, bc, bd), (ia, ib, ic, idd) = m
        if np.any(idd != 0):
            raise ValueError("the discrete Q on the command must be strictly causal")
        n = ba.shape[0]
        row = params[i]
        row["order"] = n
        row["bank_A"][:n, :n] = ba
        row["bank_B"][:n] = bb[:, 0]
        row["bank_C"][:, :n] = bc
        row["bank_D"][:] = bd[:, 0]
        row["input_A"][:n, :n] = ia
        row["input_B"][:n] = ib[:, 0]
        row["input_C"][:n] = ic[0]
    params["delay_periods"] = n_delay
    params["ring_mask"] = state.dtype["history_mm_min"].shape[0] - 1
    params["limit_mm_min"] = limit
    return params, init_states(params, state)


__all__ = [
    "DISTURBANCE",
    "OBSERVER_MODELS",
    "ObserverOptions",
    "ObserverFilters",
    "ObserverMatrices",
    "advance",
    "estimate",
    "observer_filters",
    "observer_matrices",
    "observer_records",
    "sensor_inverse",
]
