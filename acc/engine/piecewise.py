"""A signal that is a polynomial of degree <= 2 between breakpoints, on the integer clock.

Used for the position reference of an axis (steps, ramps, parabolas, feed holds: the
single-axis interpolator) and for the cutting load on an axis (torque or force steps, or an
arbitrary sequence given sample by sample).

Breakpoint ``i`` starts at plant step ``n_i`` (whole steps, ``n_0 = 0``, increasing).  For
``n_i <= k < n_{i+1}`` with ``tau = (k - n_i) dt`` (an integer count times the step, never an
accumulated float):

.. math:: y(k) = c_{0,i} + c_{1,i}\\,\\tau + c_{2,i}\\,\\tau^2 / 2, \\qquad
          \\dot y(k) = c_{1,i} + c_{2,i}\\,\\tau, \\qquad \\ddot y(k) = c_{2,i}

so ``c_0`` is the value, ``c_1`` the slope [unit/s] and ``c_2`` the curvature [unit/s^2] at
the breakpoint.  A sequence given per sample is one breakpoint per step with ``c_1 = c_2 =
0`` (the value held over the step, as a zero-order hold).

The element ``signal.piecewise`` keeps the index of the current piece in its state, so a
step costs O(1) however many breakpoints there are (the clock only moves forward).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import delay_size, init_states, jit, record, register_element


def whole_steps(time_s: float, plant_step_s: float, name: str) -> int:
    """``time_s / plant_step_s`` as a whole number of steps, or ValueError naming ``name``."""
    ratio = time_s / plant_step_s
    n = int(round(ratio))
    if abs(ratio - n) > 1e-9 * max(1.0, abs(ratio)):
        raise ValueError(
            f"{name} = {time_s} s is not a whole number of plant steps of {plant_step_s} s"
        )
    return n


def _dtypes(pieces: int = 8) -> tuple[np.dtype, np.dtype]:
    params = record(
        "signal.piecewise",
        [
            ("plant_step_s", "f8"),
            ("count", "i8"),  # breakpoints in use (<= pieces)
            ("start_step", "i8", (pieces,)),
            ("value", "f8", (pieces,)),
            ("slope_per_s", "f8", (pieces,)),
            ("curvature_per_s2", "f8", (pieces,)),
        ],
    )
    state = record("signal.piecewise", [("piece", "i8")])
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At the first breakpoint."""
    s.piece = 0


@jit
def step(p, s, k: int) -> tuple[float, float, float]:  # noqa: ANN001
    """Value, slope [unit/s] and curvature [unit/s^2] at plant step ``k`` (k never
    decreases between calls)."""
    i = s.piece
    while i + 1 < p.count and k >= p.start_step[i + 1]:
        i += 1
    s.piece = i
    tau = (k - p.start_step[i]) * p.plant_step_s
    c1 = p.slope_per_s[i]
    c2 = p.curvature_per_s2[i]
    return p.value[i] + c1 * tau + 0.5 * c2 * tau * tau, c1 + c2 * tau, c2


PIECEWISE = register_element(
    "signal.piecewise",
    _dtypes,
    init,
    step,
    "piecewise polynomial (degree <= 2) signal on the integer clock: references and loads",
)


def piecewise_records(
    start_steps: Sequence[ArrayLike],
    values: Sequence[ArrayLike],
    slopes: Sequence[ArrayLike] | None = None,
    curvatures: Sequence[ArrayLike] | None = None,
    *,
    plant_step_s: float,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of piecewise signals.

    Parameters
    ----------
    start_steps : sequence of array_like of int, length runs
        Each run's breakpoints ``n_i`` [plant steps]: first 0, strictly increasing.
    values, slopes, curvatures : sequence of array_like, length runs
        ``c_0`` [unit], ``c_1`` [unit/s], ``c_2`` [unit/s^2] at each breakpoint (same length
        as the run's breakpoints); slopes and curvatures default to zero.
    plant_step_s : float
        ``dt`` [s], > 0.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    if not plant_step_s > 0:
        raise ValueError(f"plant_step_s must be > 0, got {plant_step_s}")
    runs = len(start_steps)
    if runs == 0:
        raise ValueError("piecewise_records needs at least one run")
    rows = []
    for r in range(runs):
        n = np.atleast_1d(np.asarray(start_steps[r]))
        if not np.issubdtype(n.dtype, np.integer):
            raise ValueError("breakpoints must be whole plant steps (integers)")
        c0 = np.atleast_1d(np.asarray(values[r], dtype=float))
        c1 = np.zeros_like(c0) if slopes is None else np.atleast_1d(np.asarray(slopes[r], float))
        c2 = (
            np.zeros_like(c0)
            if curvatures is None
            else np.atleast_1d(np.asarray(curvatures[r], float))
        )
        if not (n.shape == c0.shape == c1.shape == c2.shape) or n.ndim != 1:
            raise ValueError("breakpoints and coefficients must have the same length per run")
        if n[0] != 0 or np.any(np.diff(n) <= 0):
            raise ValueError("breakpoints must start at step 0 and increase strictly")
        rows.append((n, c0, c1, c2))
    pieces = delay_size(max(len(row[0]) for row in rows))
    params, state = PIECEWISE.records(runs, pieces=pieces)
    params["plant_step_s"] = plant_step_s
    for r, (n, c0, c1, c2) in enumerate(rows):
        m = len(n)
        params["count"][r] = m
        params["start_step"][r, :m] = n
        params["start_step"][r, m:] = np.iinfo(np.int64).max
        params["value"][r, :m] = c0
        params["slope_per_s"][r, :m] = c1
        params["curvature_per_s2"][r, :m] = c2
    return params, init_states(params, state)


def sampled_records(samples: ArrayLike, *, plant_step_s: float) -> tuple[NDArray, NDArray]:
    """A batch of signals given sample by sample, each held over its plant step.

    Parameters
    ----------
    samples : array_like, shape (runs, n)
        Value at plant steps ``0 .. n-1``; the last value is held afterwards.
    plant_step_s : float
        ``dt`` [s].

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    y = np.atleast_2d(np.asarray(samples, dtype=float))
    steps = np.arange(y.shape[1], dtype=np.int64)
    return piecewise_records([steps] * y.shape[0], list(y), plant_step_s=plant_step_s)


__all__ = ["PIECEWISE", "piecewise_records", "sampled_records", "whole_steps"]
