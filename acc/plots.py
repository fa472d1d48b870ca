"""Figures of simulation results.  Every function draws onto a given Axes and returns it."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import NDArray

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


def breakage_figure(result: SimulationResult, run: int = 0, title: str | None = None) -> Figure:
    """Tool breakage in the closed loop: the force and its reference around the break
    (top) and the detector's tooth averages, normalised differences, threshold and alarm on
    the recorded monitor signal (bottom, Peng Figs 3.22/3.23)."""
    from controllers.monitoring.breakage_monitor import recorded_detection
    from controllers.monitoring.tool_breakage import plot_tool_breakage

    det = recorded_detection(result, run)
    sc = result.scenarios[run]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 6.5), constrained_layout=True)
    period_s = 60.0 / (sc.geometry.spindle_speed_rpm * sc.geometry.teeth)
    broke = int(result.metrics["breakage_period"][run])
    centre = broke if broke >= 0 else det.period[-1] if det.period.size else 0
    lo, hi = (centre - 40) * period_s, (centre + 40) * period_s
    t = result.time_s
    keep = (t >= lo) & (t <= hi)
    top.plot(t[keep], result.signal("force_N")[run][keep], lw=0.7, label="force")
    top.plot(t[keep], result.signal("measured_force_N")[run][keep], lw=1.0,
             label="force the controller sees")
    top.plot(t[keep], result.signal("reference_force_N")[run][keep], "k--", lw=0.8)
    if broke >= 0:
        top.axvline(broke * period_s, color="k", ls=":", label="breakage period")
    top.set_xlabel("time [s]")
    top.set_ylabel("force [N]")
    top.legend(fontsize="small", loc="upper left")
    unit = "A" if sc.tool_breakage.signal == "current" else "N"
    plot_tool_breakage(bottom, det, signal_label=f"tooth average [{unit}]",
                       breakage_period=broke)
    bottom.set_xlim(centre - 40, centre + 40)
    shown = (det.period >= centre - 40) & (det.period <= centre + 40)
    values = np.concatenate([det.normalised_difference[shown], det.threshold[shown]])
    values = values[np.isfinite(values)]
    if values.size:
        span = max(values.max() - values.min(), 1e-9)
        bottom.set_ylim(values.min() - 0.1 * span, values.max() + 0.1 * span)
    if title:
        top.set_title(title)
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


# --- the feed-axis lab ---------------------------------------------------------------------
#: Largest magnitude drawn; beyond it (and for NaN or inf) a sample is left out.  Matplotlib's
#: tick locator overflows near the float64 maximum; no signal of a run that passed its
#: bounds (:mod:`acc.engine.axis_verdicts`) comes near it.
MAX_SHOWN = 1e100


def _shown(values: Any) -> NDArray:
    """``values`` with the non-finite and the absurdly large samples as NaN (not drawn)."""
    v = np.asarray(values, float)
    with np.errstate(invalid="ignore"):
        return np.where(np.abs(v) <= MAX_SHOWN, v, np.nan)


def plot_axis_position(result: Any, run: int = 0, ax: Axes | None = None) -> Axes:
    """Reference and table position [mm] over time [s] (an
    :class:`acc.engine.axis_simulate.AxisResult`)."""
    ax = _axes(ax)
    ax.plot(result.time_s, _shown(result.signals["x_ref_mm"][run]), "k--", lw=0.8,
            label="reference")
    ax.plot(result.time_s, _shown(result.signals["x_mm"][run]), lw=1.1, label="table")
    ax.set_ylabel("position [mm]")
    ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    return ax


def plot_following_error(result: Any, run: int = 0, ax: Axes | None = None) -> Axes:
    """Following error ``x_ref - x`` [um] over time [s]."""
    ax = _axes(ax)
    ax.plot(result.time_s, 1e3 * _shown(result.signals["following_error_mm"][run]), lw=1.0)
    ax.set_ylabel("following error [um]")
    ax.grid(True, alpha=0.3)
    return ax


def plot_axis_drive(result: Any, run: int = 0, ax: Axes | None = None) -> Axes:
    """Table velocity [mm/s] and, on a twin axis, the armature current [A] (servo axis)."""
    ax = _axes(ax)
    ax.plot(result.time_s, _shown(result.signals["velocity_mm_s"][run]), lw=1.0, color="C0")
    ax.set_ylabel("velocity [mm/s]", color="C0")
    ax.grid(True, alpha=0.3)
    current = result.signals.get("current_A")
    if current is not None and np.isfinite(_shown(current[run])).any():
        current = _shown(current[run])
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
