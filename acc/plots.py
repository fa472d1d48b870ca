"""Figures of simulation results.  Every function draws onto a given Axes and returns it."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
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


def _stacked_figure(
    result: Any, run: int, title: str | None, plotters: Sequence[Callable[..., Axes]]
) -> Figure:
    """One panel per plotter, stacked over a shared time axis."""
    fig, axes = plt.subplots(
        len(plotters), 1, sharex=True, figsize=(7.5, 7.0), constrained_layout=True
    )
    for plot, ax in zip(plotters, axes, strict=True):
        plot(result, run, ax)
    axes[-1].set_xlabel("time [s]")
    if title:
        axes[0].set_title(title)
    return fig


def response_figure(result: SimulationResult, run: int = 0, title: str | None = None) -> Figure:
    """Force, feed and depth over time, stacked (in the manner of Kim & Chung Fig. 10)."""
    return _stacked_figure(result, run, title, (plot_force, plot_feed, plot_depth))


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


# --- the feed-axis lab ---------------------------------------------------------------------
def plot_axis_position(result: Any, run: int = 0, ax: Axes | None = None) -> Axes:
    """Reference and table position [mm] over time [s] (an
    :class:`acc.engine.axis_simulate.AxisResult`)."""
    ax = _axes(ax)
    ax.plot(result.time_s, result.signals["x_ref_mm"][run], "k--", lw=0.8, label="reference")
    ax.plot(result.time_s, result.signals["x_mm"][run], lw=1.1, label="table")
    ax.set_ylabel("position [mm]")
    ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    return ax


def plot_following_error(result: Any, run: int = 0, ax: Axes | None = None) -> Axes:
    """Following error ``x_ref - x`` [um] over time [s]."""
    ax = _axes(ax)
    ax.plot(result.time_s, 1e3 * result.signals["following_error_mm"][run], lw=1.0)
    ax.set_ylabel("following error [um]")
    ax.grid(True, alpha=0.3)
    return ax


def plot_axis_drive(result: Any, run: int = 0, ax: Axes | None = None) -> Axes:
    """Table velocity [mm/s] and, on a twin axis, the armature current [A] (servo axis)."""
    ax = _axes(ax)
    ax.plot(result.time_s, result.signals["velocity_mm_s"][run], lw=1.0, color="C0")
    ax.set_ylabel("velocity [mm/s]", color="C0")
    ax.grid(True, alpha=0.3)
    current = result.signals.get("current_A")
    if current is not None and np.isfinite(current[run]).any():
        current = current[run]
        twin = ax.twinx()
        twin.plot(result.time_s, current, lw=0.8, color="C1")
        twin.set_ylabel("current [A]", color="C1")
    return ax


def axis_response_figure(result: Any, run: int = 0, title: str | None = None) -> Figure:
    """Position, following error, velocity and current of an axis run, stacked."""
    return _stacked_figure(
        result, run, title, (plot_axis_position, plot_following_error, plot_axis_drive)
    )


__all__ = [
    "axis_response_figure",
    "plot_axis_drive",
    "plot_axis_position",
    "plot_depth",
    "plot_feed",
    "plot_following_error",
    "plot_force",
    "plot_force_runs",
    "response_figure",
]
