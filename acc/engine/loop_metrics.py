"""Compiled helpers for the metrics the position loops accumulate step by step."""

from __future__ import annotations

from acc.engine.element import jit


@jit
def nan_max(largest: float, value: float) -> float:
    """The running maximum ``max(largest, value)`` that keeps a NaN once one arrives.

    A diverged run (NaN samples) therefore reports NaN, not the largest finite value seen
    before it diverged.

    Parameters
    ----------
    largest : float
        The maximum so far (any unit; NaN once a NaN was seen).
    value : float
        This step's value, same unit.

    Returns
    -------
    float
        ``value`` when it is larger than ``largest`` or NaN, else ``largest``.
    """
    if value > largest or value != value:
        return value
    return largest


__all__ = ["nan_max"]
