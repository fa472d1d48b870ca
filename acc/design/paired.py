"""Paired statistics over seeds: means with confidence intervals, paired differences against a
baseline controller, and rankings claimed only where a difference is significant.

Runs compared across controller kinds share their noise and disturbance realisations (the
same seed and noise id: common random numbers), so seed ``i`` of kind A and seed ``i`` of the
baseline form a pair.  For a metric ``x`` (e.g. IAE) over ``n`` paired seeds:

* the mean of each kind with a two-sided ``level`` confidence interval, ``mean +-
  t_{(1+level)/2, n-1} s / sqrt(n)`` (Student's t);
* the paired difference ``x_A - x_baseline`` per seed, its mean and the same interval; the
  difference is *significant* when the interval excludes 0 **and** its mean exceeds the
  resolution ``max(abs_resolution, rel_resolution * scale)``, ``scale`` the larger of the two
  kinds' mean absolute values over the pairs.  Without the resolution, two runs that differ
  only by floating-point rounding (a paired difference of 1e-10 with zero spread, e.g. two
  algebraically equal laws evaluated in a different order) would have an interval of zero
  width that excludes 0 and be called different;
* a verdict per kind: ``"lower"``/``"higher"`` than the baseline where significant, else
  ``"no significant difference"``.

Pairs where either value is not finite (a failed run) are left out, and counted.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class Interval:
    """A mean with its confidence interval.

    Attributes
    ----------
    mean : float
    half_width : float
        Half-width of the interval (NaN with fewer than 2 values).
    n : int
        Values used.
    """

    mean: float
    half_width: float
    n: int

    @property
    def low(self) -> float:
        """Lower end."""
        return self.mean - self.half_width

    @property
    def high(self) -> float:
        """Upper end."""
        return self.mean + self.half_width

    @property
    def excludes_zero(self) -> bool:
        """True if the whole interval is on one side of 0."""
        return bool(self.low > 0 or self.high < 0)


def mean_interval(values: ArrayLike, level: float = 0.95) -> Interval:
    """Mean and Student-t confidence interval of the finite values."""
    from scipy.stats import t

    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    n = x.size
    if n == 0:
        return Interval(math.nan, math.nan, 0)
    if n == 1:
        return Interval(float(x[0]), math.nan, 1)
    half = float(t.ppf(0.5 + level / 2.0, n - 1) * x.std(ddof=1) / math.sqrt(n))
    return Interval(float(x.mean()), half, n)


@dataclass(frozen=True)
class PairedRow:
    """One kind against the baseline, for one metric.

    Attributes
    ----------
    kind : str
    mean : Interval
        The kind's mean over its seeds.
    difference : Interval or None
        Paired difference kind - baseline (None for the baseline itself).
    pairs_left_out : int
        Pairs with a non-finite value on either side.
    verdict : str
        ``"baseline"``, ``"lower"``, ``"higher"`` or ``"no significant difference"``.
    resolution : float
        The smallest mean difference that can be called, in the metric's unit (0 for the
        baseline itself).
    """

    kind: str
    mean: Interval
    difference: Interval | None
    pairs_left_out: int
    verdict: str
    resolution: float = 0.0

    @property
    def below_resolution(self) -> bool:
        """True if the mean difference is within the resolution (no verdict claimed)."""
        d = self.difference
        return d is not None and not abs(d.mean) > self.resolution


def paired_comparison(
    values: Mapping[str, ArrayLike],
    baseline: str,
    level: float = 0.95,
    rel_resolution: float = 1e-6,
    abs_resolution: float = 0.0,
) -> list[PairedRow]:
    """Every kind's mean and paired difference against ``baseline`` (module docstring).

    Parameters
    ----------
    values : mapping of kind to array_like, shape (seeds,)
        The metric per seed; index ``i`` of every kind is the same noise realisation.
    baseline : str
        The kind the others are compared with.
    level : float
        Confidence level of the intervals.
    rel_resolution : float
        Resolution relative to the metric's scale (the larger mean absolute value of the
        kind and the baseline over the pairs); the default 1e-6 is far above the rounding
        of a simulated metric and far below any difference worth a verdict.
    abs_resolution : float
        Resolution in the metric's unit (e.g. 1e-6 for a length in mm: one nanometre).

    Raises
    ------
    ValueError
        If a kind has a different number of values from the baseline, or a resolution is
        negative or not finite.
    """
    for name, r in (("rel_resolution", rel_resolution), ("abs_resolution", abs_resolution)):
        if not (math.isfinite(r) and r >= 0.0):
            raise ValueError(f"{name} must be finite and >= 0, got {r!r}")
    base = np.asarray(values[baseline], dtype=float)
    rows = []
    for kind, raw in values.items():
        x = np.asarray(raw, dtype=float)
        if x.shape != base.shape:
            raise ValueError(f"{kind}: {x.shape[0]} values, baseline has {base.shape[0]}")
        if kind == baseline:
            rows.append(PairedRow(kind, mean_interval(x, level), None, 0, "baseline"))
            continue
        both = np.isfinite(x) & np.isfinite(base)
        diff = mean_interval(x[both] - base[both], level)
        scale = max(float(np.abs(x[both]).mean()), float(np.abs(base[both]).mean())) \
            if both.any() else 0.0
        resolution = max(abs_resolution, rel_resolution * scale)
        if diff.excludes_zero and abs(diff.mean) > resolution:
            verdict = "lower" if diff.mean < 0 else "higher"
        else:
            verdict = "no significant difference"
        rows.append(PairedRow(kind, mean_interval(x, level), diff, int((~both).sum()), verdict,
                              resolution))
    return rows


def paired_table(rows: list[PairedRow], metric: str, level: float = 0.95) -> list[dict]:
    """Rows of :func:`paired_comparison` as flat dicts (for CSV and Markdown)."""
    pct = f"{100 * level:g}"
    out = []
    for r in rows:
        d = r.difference
        out.append(
            {
                "controller": r.kind,
                "metric": metric,
                "seeds": r.mean.n,
                "mean": r.mean.mean,
                f"ci{pct}_half_width": r.mean.half_width,
                "paired_difference": math.nan if d is None else d.mean,
                f"difference_ci{pct}_low": math.nan if d is None else d.low,
                f"difference_ci{pct}_high": math.nan if d is None else d.high,
                "resolution": r.resolution,
                "pairs_left_out": r.pairs_left_out,
                "verdict": r.verdict,
            }
        )
    return out


__all__ = ["Interval", "PairedRow", "mean_interval", "paired_comparison", "paired_table"]
