"""``acc run`` on a contouring scenario (``[simulation] model = "xy_contour"``).

``acc run CONTOUR.toml --out DIR`` runs the scenario's two axes (Peng's servo axes or
Lacerda & Belo's elastic axes, with or without the cross-coupled controller) along its path
(:mod:`acc.scenarios.contour`) and writes ``summary.csv`` (the contour-error IAE and maximum,
and the corner metrics M1-M4 with the incoming-line error on a corner path, or the circular
test's F, G and reversal glitches on a circle, then the verdict: ``failed``,
``failure_reason``, ``saturated_fraction``), ``traces.npz``/``traces.csv`` (the
reference, the axes and the exact contour error with its estimates), ``path.png`` (the
corner at true scale, or the circle's radial deviation magnified) and
``contour_error.png``.  A run that diverged (:mod:`acc.engine.axis_verdicts`) is written
like any other, its metrics NaN (none is computed from it) and its traces ending where it
stopped; the result line ends with ``[FAILED: <reason>]`` and the exit status is 0, as for
the force loop.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from acc.cli.common import CommandError, failed_title


def run_contour(args: argparse.Namespace, scenario: Any) -> int:
    """``acc run`` on a contouring scenario."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acc.cli.axis import run_source, verdict_suffix
    from acc.cli.common import say
    from acc.limits import shorten
    from acc.output import (
        staged_directory,
        write_csv,
        write_scenario_manifest,
        write_signal_traces,
    )
    from controllers.contouring.plots import (
        ballbar_magnification,
        plot_contour_error,
        plot_path_overlay,
        plot_polar_circle,
    )

    try:
        ref, pos, signals, verdict = scenario.simulate()
    except (Exception, MemoryError) as exc:  # noqa: BLE001 - reported in one line
        raise CommandError(
            f"{run_source(args, scenario)}: the contouring simulation failed: "
            f"{type(exc).__name__}: {shorten(str(exc))}"
        ) from None
    row = scenario.summary_row(ref, pos, signals, verdict)
    out = Path(args.out)
    traced = {k: np.asarray(v) for k, v in signals.items()}
    with staged_directory(out) as stage:
        write_csv(stage / "summary.csv", [row])
        write_scenario_manifest(stage / "manifest.json", scenario,
                                {"overrides": list(args.set)})
        write_signal_traces(stage, ref.time_s, traced)
        fig, ax = plt.subplots(figsize=(5.5, 5.0))
        try:
            if ref.circle is not None:
                centre, radius, _ = ref.circle
                rel = pos - np.asarray(centre)
                dev = np.abs(np.hypot(rel[:, 0], rel[:, 1]) - radius)
                peak = float(np.nanmax(dev)) if np.isfinite(dev).any() else 0.0
                plot_polar_circle(rel, (0.0, 0.0), radius, ax,
                                  magnification=ballbar_magnification(peak, radius))
            else:
                plot_path_overlay(ref.ideal_path_mm, pos, ax, magnification=1.0)
                if math.isfinite(ref.vertex_time_s):
                    v = ref.vertex_mm
                    ax.set_xlim(v[0] - 1.5, v[0] + 1.5)
                    ax.set_ylim(v[1] - 1.5, v[1] + 1.5)
            ax.set_title(failed_title(Path(args.scenario).name, row), fontsize=9)
            fig.tight_layout()
            fig.savefig(stage / "path.png", dpi=110)
        finally:
            plt.close(fig)
        fig, ax = plt.subplots(figsize=(7.0, 4.0))
        try:
            shown = {"exact": signals["contour_error_mm"]}
            for key, label in (("linear_estimate_mm", "linear (4.78)"),
                               ("curvature_estimate_mm", "Eq. 16")):
                if key in signals:
                    shown[label] = signals[key]
            plot_contour_error(ref.time_s, shown, ax)
            if row.get("failed"):
                ax.set_title(failed_title("", row).strip(), fontsize=9)
            fig.tight_layout()
            fig.savefig(stage / "contour_error.png", dpi=110)
        finally:
            plt.close(fig)
    say(
        args,
        f"{args.scenario}: {scenario.path.kind} path, {scenario.axis.kind} axes, "
        f"{scenario.position_controller.kind}, contour controller "
        f"{scenario.contour_controller.kind}: max |contour error| "
        f"{1e3 * row['max_abs_contour_error_mm']:.2f} um, IAE "
        f"{1e3 * row['iae_contour_mm_s']:.3f} um s" + verdict_suffix(row),
        f"wrote {out}/summary.csv, manifest.json, traces.csv, traces.npz, path.png, "
        "contour_error.png",
    )
    return 0


def analyze_contour(args: argparse.Namespace, scenario: Any) -> int:
    """``acc analyze`` on a contouring scenario: not analysed yet, said in one line."""
    raise CommandError(
        f"{scenario.source}: acc analyze does not analyse contouring scenarios ([simulation] "
        "model = 'xy_contour'); analyse each axis with an axis scenario (model = 'axis', e.g. "
        "experiments/peng_servo_axis.toml) or simulate the path with acc run")


__all__ = ["analyze_contour", "run_contour"]
