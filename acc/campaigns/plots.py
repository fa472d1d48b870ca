"""Figures of a campaign: metric distributions, force percentile bands, failure rates.

Each function draws onto a given Axes (a new one if None) and returns it.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from numpy.typing import NDArray


def _axes(ax: Axes | None) -> Axes:
    if ax is None:
        _, ax = plt.subplots()
    return ax


def plot_metric_distribution(
    summary: Mapping[str, NDArray], metric: str, ax: Axes | None = None, by: str = "controller"
) -> Axes:
    """Box plot of one metric over the completed runs, one box per value of ``by`` (the
    controller kind by default).

    Parameters
    ----------
    summary : mapping of str to ndarray, shape (runs,)
        Columns of a sweep summary (:func:`acc.campaigns.sweep.read_summary`).
    metric : str
        Column to show (its unit is in its name).
    ax : matplotlib Axes or None
    by : str
        Column that groups the runs.

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax)
    groups = sorted(set(summary[by].tolist()))
    ok = ~summary["failed"]
    data = []
    for g in groups:
        x = summary[metric][(summary[by] == g) & ok]
        data.append(x[np.isfinite(x)])
    ax.boxplot(data, tick_labels=[f"{g:g}" if isinstance(g, float) else str(g) for g in groups],
               whis=(5, 95), showfliers=True)
    ax.set_xlabel(by)
    ax.set_ylabel(metric)
    ax.set_title(f"{metric} (whiskers 5-95 %)", fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)
    return ax


def plot_force_bands(
    traces: Mapping[str, NDArray],
    summary: Mapping[str, NDArray],
    ax: Axes | None = None,
    percentiles: Sequence[float] = (5.0, 25.0, 50.0, 75.0, 95.0),
    by: str = "controller",
    profile: str | None = "radial_depths_mm",
) -> Axes:
    """Percentile bands of the force traces over runs, one colour per group, and the reference.

    Runs are grouped by ``by`` and, when the campaign holds several, by ``profile`` (a part
    with other depths is another response, not spread around the same one).

    Parameters
    ----------
    traces : mapping
        ``time_s`` (n,), ``run_ids`` (runs,), ``force_N`` (runs, n)
        (:func:`acc.campaigns.sweep.read_traces`).
    summary : mapping of str to ndarray, shape (runs,)
    ax : matplotlib Axes or None
    percentiles : sequence of float
        Symmetric pairs around the median (odd count, ascending) [%].
    by : str
        Summary column that groups the runs.
    profile : str or None
        Second grouping column, used when it takes more than one value among the traced runs
        (default: the depth profile).

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax)
    p = sorted(percentiles)
    t = traces["time_s"]
    row_of_run = {int(r): i for i, r in enumerate(summary["run"])}
    rows = [row_of_run[int(r)] for r in traces["run_ids"]]
    labels = np.array([str(summary[by][i]) for i in rows])
    if profile is not None and profile in summary:
        parts = [str(summary[profile][i]) for i in rows]
        if len(set(parts)) > 1:
            labels = np.array([f"{g}, {q} mm" for g, q in zip(labels, parts, strict=True)])
    if "reference_force_N" in summary:
        refs = {float(summary["reference_force_N"][i]) for i in rows}
        if len(refs) == 1:
            ax.axhline(refs.pop(), color="k", ls="--", lw=0.8, label="reference")
    for g in sorted(set(labels.tolist())):
        f = traces["force_N"][labels == g]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: no run left
            q = np.nanpercentile(f, p, axis=0)
        (line,) = ax.plot(t, q[len(p) // 2], lw=1.2, label=f"{g} median")
        for lo in range(len(p) // 2):
            ax.fill_between(
                t,
                q[lo],
                q[-1 - lo],
                color=line.get_color(),
                alpha=0.15 + 0.15 * lo,
                lw=0,
                label=f"{g} {p[lo]:g}-{p[-1 - lo]:g} %" if lo == 0 else None,
            )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("force [N]")
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    return ax


def plot_failure_rate(
    summary: Mapping[str, NDArray],
    parameter: str,
    ax: Axes | None = None,
    bins: int = 10,
    by: str = "controller",
) -> Axes:
    """Fraction of failed (unstable) runs against a swept numeric parameter.

    Parameters
    ----------
    summary : mapping of str to ndarray, shape (runs,)
    parameter : str
        Numeric column; with more than ``bins`` distinct values it is binned.
    ax : matplotlib Axes or None
    bins : int
    by : str
        Column that groups the runs (one line each).

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax)
    x = np.asarray(summary[parameter], dtype=float)
    values = np.unique(x)
    if len(values) > bins:
        edges = np.linspace(values[0], values[-1], bins + 1)
        index = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1)
        centres = 0.5 * (edges[:-1] + edges[1:])
    else:
        index = np.searchsorted(values, x)
        centres = values
    for g in sorted(set(summary[by].tolist())):
        rows = summary[by] == g
        rate = np.full(len(centres), np.nan)
        for j in range(len(centres)):
            sel = rows & (index == j)
            if np.any(sel):
                rate[j] = np.mean(summary["failed"][sel])
        ax.plot(centres, 100.0 * rate, "o-", label=str(g))
    ax.set_xlabel(parameter)
    ax.set_ylabel("failed runs [%]")
    ax.set_ylim(-5, 105)
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    return ax


__all__ = ["plot_failure_rate", "plot_force_bands", "plot_metric_distribution"]
