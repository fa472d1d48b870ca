"""The running maximum of the position loops' metrics keeps a NaN (a diverged run)."""

from __future__ import annotations

import math

from acc.engine.loop_metrics import nan_max


def test_nan_max_is_the_maximum_of_finite_values() -> None:
    assert nan_max(1.0, 2.5) == 2.5
    assert nan_max(2.5, 1.0) == 2.5
    assert nan_max(0.0, -1.0) == 0.0


def test_nan_max_keeps_a_nan_once_seen() -> None:
    largest = 0.0
    for value in (1.0, math.nan, 7.0, 3.0):
        largest = nan_max(largest, value)
    assert math.isnan(largest)
