"""Figures of simulation results.  Every function draws onto a given Axes and returns it."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from acc.engine.result import SimulationResult


def _axes(ax: Axes | None) -> Axes:
    if ax is None:
        _, ax = plt.subplots()
    return ax


def plot_force(result: SimulationResult, run: int = 0, ax: Axes | None = None) -> Axes:
    """True and measured force against the reference [N] over time [s]."""
    ax = _axes(ax)
    t = result.time_s
    ax.plot(t, result.signal("measured_force_N")[run], color="0.7", lw=0.6, label="measured")
    ax.plot(t, result.signal("force_N")[run], color="C0", lw=1.2, label="force")
    ax.plot(t, result.signal("reference_force_N")[run], "k--", lw=1.0, label="reference")
    ax.set_ylabel("force [N]")
    ax.legend(loc="lower right", fontsize="small")
    ax.grid(True, alpha=0.3)
    return ax


def plot_feed(result: SimulationResult, run: int = 0, ax: Axes | None = None) -> Axes:
    """Commanded feedrate and feed velocity [mm/min] over time [s]."""
    ax = _axes(ax)
    t = result.time_s
    ax.plot(t, result.signal("commanded_feed_mm_min")[run], color="C1", lw=1.0, label="commanded")
    ax.plot(t, result.signal("feed_velocity_mm_min")[run], color="C2", lw=1.0, label="velocity")
    ax.set_ylabel("feed [mm/min]")
    ax.legend(loc="lower right", fontsize="small")
    ax.grid(True, alpha=0.3)
    return ax


def plot_depth(result: SimulationResult, run: int = 0, ax: Axes | None = None) -> Axes:
    """Radial depth of cut the tool meets [mm] over time [s]."""
    ax = _axes(ax)
    ax.step(result.time_s, result.signal("radial_depth_mm")[run], where="post", color="C3")
    ax.set_ylabel("radial depth [mm]")
    ax.grid(True, alpha=0.3)
    return ax


def response_figure(result: SimulationResult, run: int = 0, title: str | None = None) -> Figure:
    """Force, feed and depth over time, stacked (in the manner of Kim & Chung Fig. 10)."""
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(7.5, 7.0), constrained_layout=True)
    plot_force(result, run, axes[0])
    plot_feed(result, run, axes[1])
    plot_depth(result, run, axes[2])
    axes[2].set_xlabel("time [s]")
    if title:
        axes[0].set_title(title)
    return fig


def plot_force_runs(
    result: SimulationResult, runs: Sequence[int], labels: Sequence[str], ax: Axes | None = None
) -> Axes:
    """Force of several runs on one Axes [N] over time [s], with the first run's reference."""
    ax = _axes(ax)
    for r, label in zip(runs, labels, strict=True):
        ax.plot(result.time_s, result.signal("force_N")[r], lw=1.0, label=label)
    ax.plot(result.time_s, result.signal("reference_force_N")[runs[0]], "k--", lw=0.8)
    ax.set_ylabel("force [N]")
    ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    return ax


__all__ = ["plot_depth", "plot_feed", "plot_force", "plot_force_runs", "response_figure"]
