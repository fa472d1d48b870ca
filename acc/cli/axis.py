"""``acc run`` and ``acc analyze`` on an axis scenario (``[simulation] model = "axis"``).

``acc run AXIS.toml --out DIR`` simulates the feed axis in the compiled axis loop and writes
``summary.csv`` (the run's metrics and verdict), ``traces.csv``/``traces.npz`` and
``response.png`` (reference and position, following error, velocity, current and command).
A run that diverged (:mod:`acc.engine.axis_verdicts`) is written like any other, its
metrics NaN and its traces ending where it stopped; the result line ends with
``[FAILED: <reason>]`` and the exit status is 0, as for the force loop.

``acc analyze AXIS.toml --out DIR`` writes ``analysis.csv`` and ``analysis.png`` for Peng's
servo axis under the lead-lag filter (the linear sampled loop (2.31)): margins, closed-loop
poles, velocity constant, ramp following error, stiffness against cutting torque, and a Bode
plot of the loop gain with its margins.  Other combinations are named as not analysable.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from acc.cli.common import CommandError, failed_title


def run_source(args: argparse.Namespace, scenario: Any) -> str:
    """Where a run's values came from, for a message: the file, and the ``--set``
    overrides when there are some (they may have caused it)."""
    from acc.limits import shorten

    sets = getattr(args, "set", None) or []
    return f"{scenario.source} with --set {shorten(' '.join(sets), 120)}" if sets else \
        str(scenario.source)


def _simulate(args: argparse.Namespace, scenario: Any) -> Any:
    """The run; an exception inside it (validation should have caught it: the safety net)
    is one line naming the file and the overrides."""
    from acc.limits import shorten

    try:
        return scenario.simulate(record_every_steps=1)
    except (Exception, MemoryError) as exc:  # noqa: BLE001 - reported in one line
        raise CommandError(
            f"{run_source(args, scenario)}: the axis simulation failed: "
            f"{type(exc).__name__}: {shorten(str(exc))}"
        ) from None


def run_axis(args: argparse.Namespace, scenario: Any) -> int:
    """``acc run`` on an axis scenario."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acc.cli.common import say
    from acc.output import (
        staged_directory,
        write_csv,
        write_scenario_manifest,
        write_signal_traces,
    )
    from acc.plots import axis_response_figure

    result = _simulate(args, scenario)
    out = Path(args.out)
    row = scenario.summary_row(result)
    with staged_directory(out) as stage:
        write_csv(stage / "summary.csv", [row])
        write_scenario_manifest(stage / "manifest.json", scenario,
                                {"overrides": list(args.set)})
        write_signal_traces(stage, result.time_s, {k: v[0] for k, v in result.signals.items()})
        title = (
            f"{Path(args.scenario).name}: {scenario.axis.kind} axis, "
            f"{scenario.position_controller.kind}"
        )
        fig = axis_response_figure(result, title=failed_title(title, row))
        try:
            fig.savefig(stage / "response.png", dpi=120)
        finally:
            plt.close(fig)
    m = result.metrics
    say(
        args,
        f"{args.scenario}: {scenario.axis.kind} axis under {scenario.position_controller.kind}, "
        f"{scenario.trajectory.kind}: max |following error| "
        f"{1e3 * m['max_abs_following_error_mm'][0]:.2f} um, final "
        f"{1e3 * m['final_following_error_mm'][0]:.2f} um"
        + verdict_suffix(row),
        f"wrote {out}/summary.csv, manifest.json, traces.csv, traces.npz, response.png",
    )
    return 0


def verdict_suffix(row: dict[str, Any]) -> str:
    """The end of a lab run's result line: the share of steps at a limit (when the run has
    one) and ``[FAILED: <reason>]`` for a failed run."""
    share = row.get("saturated_fraction", math.nan)
    text = f", at a limit {100 * share:.1f} % of steps" if math.isfinite(share) else ""
    return text + (f" [FAILED: {row['failure_reason']}]" if row["failed"] else "")


def analyze_axis(args: argparse.Namespace, scenario: Any) -> int:
    """``acc analyze`` on an axis scenario."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acc.cli.common import say
    from acc.design import axis_analysis as aa
    from acc.output import staged_directory, write_csv

    out = Path(args.out)
    ax, ctrl = scenario.axis_params, scenario.controller_params
    period = scenario.simulation.control_period_s
    analysable = (
        scenario.axis.kind == "servo"
        and scenario.position_controller.kind == "lead_lag"
        and ctrl.integrator_form == "none"
        and not ctrl.computational_delay_samples
        and not ctrl.output_limit_V
        and period == scenario.simulation.plant_step_s
    )
    if scenario.axis.kind == "oscillating" and scenario.position_controller.kind == (
        "state_control"
    ):
        return _analyze_state_control(args, scenario)
    if not analysable:
        raise CommandError(
            f"{scenario.source}: not analysable: the linear loop (2.31) covers the servo axis "
            "under the plain lead-lag filter (no integrator, delay or limit, control period = "
            "plant step)"
        )
    margins = aa.stability_margins(ax, ctrl, period)
    poles = aa.closed_loop_poles(ax, ctrl, period)
    k_vel = aa.velocity_constant_1_s(ax, ctrl, period)
    stiff = aa.torque_stiffness(ax, ctrl, period)
    feed = scenario.trajectory.programmed_feed_mm_s
    row = {
        **{k: float(v) for k, v in margins.items()},
        "spectral_radius": float(abs(poles).max()),
        "velocity_constant_1_s": k_vel,
        "ramp_following_error_mm": feed / k_vel if feed and math.isfinite(k_vel) else 0.0,
        "stiffness_mm_per_Nm": stiff.mm_per_Nm,
        "stiffness_mm_per_N": stiff.mm_per_N,
    }
    with staged_directory(out) as stage:
        write_csv(stage / "analysis.csv", [row])
        fig = axis_bode_figure(ax, ctrl, period, margins)
        try:
            fig.savefig(stage / "analysis.png", dpi=110)
        finally:
            plt.close(fig)
    say(
        args,
        f"{args.scenario}: GM {margins['gain_margin']:.2f} "
        f"PM {margins['phase_margin_deg']:.1f} deg "
        f"wc {margins['gain_crossover_rad_s']:.1f} rad/s, K_vel {k_vel:.2f} 1/s, "
        f"stiffness {1e3 * stiff.mm_per_Nm:.3f} um/(N m)",
        f"wrote {out}/analysis.csv, analysis.png",
    )
    return 0


def _analyze_state_control(args: argparse.Namespace, scenario: Any) -> int:
    """Briquez's loop: Table 1, sampling conditions and the sampled K_v limits with and
    without the acceleration feedback, and the closed-loop poles at the scenario's K_v."""
    from dataclasses import replace

    from acc.cli.common import say
    from acc.design import axis_analysis as aa
    from acc.output import staged_directory, write_csv

    ax, law = scenario.axis_params, scenario.controller_params
    period = scenario.simulation.control_period_s
    if period != scenario.simulation.plant_step_s or law.output_limit or (
        law.accelerometer_offset_m_s2
    ):
        raise CommandError(
            f"{scenario.source}: not analysable: the linear loop needs control period = plant "
            "step, no output limit and no accelerometer offset"
        )
    try:
        loop = aa.rsc_closed_loop(ax, law, period)
        with_rsc = aa.kv_limits(ax, law, period, kv_max_1_s=2000.0, grid=1000)
        plain = aa.kv_limits(ax, replace(law, source="none"), period, kv_max_1_s=2000.0,
                             grid=1000)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise CommandError(f"{scenario.source}: the analysis failed: {exc}") from None
    cond = aa.sampling_conditions(ax.oscillator_frequency_Hz, period, ax.speed_loop_bandwidth_Hz)
    row = {
        "position_gain_1_s": law.position_gain_1_s,
        "spectral_radius": aa.spectral_radius(loop),
        "kv_limit_1_s": with_rsc.stability_limit_1_s,
        "kv_fastest_decay_1_s": with_rsc.fastest_decay_1_s,
        "kv_limit_without_acceleration_feedback_1_s": plain.stability_limit_1_s,
        "kv_gain_factor": with_rsc.stability_limit_1_s / plain.stability_limit_1_s,
        "continuous_kv_bound_1_s": aa.continuous_kv_limit_1_s(
            ax.oscillator_frequency_Hz, ax.oscillator_damping
        ),
        "sampling_limit_Hz": cond["sampling_limit_Hz"],
        "condition_4": cond["condition_4"],
        "condition_5": cond["condition_5"],
    }
    out = Path(args.out)
    with staged_directory(out) as stage:
        write_csv(stage / "analysis.csv", [row])
    say(
        args,
        f"{args.scenario}: K_v limit {row['kv_limit_1_s']:.1f} 1/s with "
        f"{law.source} acceleration feedback, "
        f"{row['kv_limit_without_acceleration_feedback_1_s']:.1f} without (factor "
        f"{row['kv_gain_factor']:.2f}); spectral radius "
        f"{row['spectral_radius']:.4f} at K_v {law.position_gain_1_s:g} 1/s",
        f"wrote {out}/analysis.csv",
    )
    return 0


def axis_bode_figure(ax: Any, ctrl: Any, period_s: float, margins: dict) -> Any:
    """Bode plot of the sampled loop gain ``L(z)`` with its margins marked."""
    import control
    import matplotlib.pyplot as plt
    import numpy as np

    from acc.design import axis_analysis as aa

    loop = aa.open_loop_tf(ax, ctrl, period_s)
    w = np.logspace(0, math.log10(0.999 * math.pi / period_s), 600)
    mag, phase, _ = control.frequency_response(loop, w)
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(6.4, 5.2))
    a1.semilogx(w, 20 * np.log10(np.abs(mag)), color="C0")
    a1.axhline(0.0, color="k", lw=0.6)
    a2.semilogx(w, np.degrees(np.unwrap(phase)), color="C0")
    a2.axhline(-180.0, color="k", lw=0.6)
    wc, wg = margins["gain_crossover_rad_s"], margins["phase_crossover_rad_s"]
    if math.isfinite(wc):
        a2.plot([wc, wc], [-180.0, -180.0 + margins["phase_margin_deg"]], color="C3", lw=2,
                label=f"PM {margins['phase_margin_deg']:.1f} deg at {wc:.0f} rad/s")
    if math.isfinite(wg):
        a1.plot([wg, wg], [0.0, -margins["gain_margin_dB"]], color="C3", lw=2,
                label=f"GM {margins['gain_margin_dB']:.1f} dB at {wg:.0f} rad/s")
    a1.set_ylabel("|L| [dB]")
    a2.set_ylabel("phase of L [deg]")
    a2.set_xlabel("frequency [rad/s]")
    for a in (a1, a2):
        a.grid(True, which="both", alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=8)
    a1.set_title(f"servo axis under lead-lag D(z), T = {1e3 * period_s:g} ms")
    fig.tight_layout()
    return fig


__all__ = ["analyze_axis", "axis_bode_figure", "run_axis", "run_source", "verdict_suffix"]
