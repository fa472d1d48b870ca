"""What can be checked on a drawn figure, one test per figure function.

Each test builds small inputs directly (summary columns, traces, results with named signals),
draws, calls ``fig.canvas.draw()`` and checks what a reviewer would: axis labels with units,
every legend inside the figure, distinct colours where a legend promises them, panels whose
lines vary, bar labels that do not overprint, and counts equal to those computed here from
the rows.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.text import Text  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

UNIT = re.compile(r"\[[^\]]+\]|\([^)]*(N|mm|um|s|%|A|deg)[^)]*\)")


# --- checks ---------------------------------------------------------------------------------
def _draw(fig: Figure) -> None:
    fig.canvas.draw()


def _legends(fig: Figure) -> list[Any]:
    out = list(fig.legends)
    for ax in fig.axes:
        if ax.get_legend() is not None:
            out.append(ax.get_legend())
    return out


def assert_legends_inside(fig: Figure) -> None:
    """Every legend's window extent lies inside the figure's (1 px of slack)."""
    _draw(fig)
    box = fig.bbox
    for leg in _legends(fig):
        e = leg.get_window_extent()
        assert e.x0 >= box.x0 - 1 and e.y0 >= box.y0 - 1, (e, box)
        assert e.x1 <= box.x1 + 1 and e.y1 <= box.y1 + 1, (e, box)


def legend_colors(legend: Any) -> list[tuple[float, ...]]:
    """The colour of each legend handle (line colour, or patch face colour)."""
    out = []
    for h in legend.legend_handles:
        c = h.get_color() if isinstance(h, Line2D) else h.get_facecolor()
        out.append(tuple(np.round(to_rgba(c), 3)))
    return out


def assert_units(label: str) -> None:
    assert label, "axis label missing"
    assert UNIT.search(label), f"no unit in {label!r}"


def _overlap(a: Any, b: Any) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def _varies(line: Line2D) -> bool:
    y = np.asarray(line.get_ydata(), float)
    y = y[np.isfinite(y)]
    return y.size > 1 and float(np.ptp(y)) > 0.0


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


# --- sweep figures --------------------------------------------------------------------------
PROFILES = ("2 3 4", "2 4 3", "3 2 4", "3 4 2", "4 2 3", "4 3 2")


def sweep_rows(kinds=("pi", "constant"), profiles=PROFILES, samples=3, seed=0):
    """A sweep summary built directly: every kind on every profile, a few samples each."""
    rng = np.random.default_rng(seed)
    rows = [(k, p, s) for k in kinds for p in profiles for s in range(samples)]
    n = len(rows)
    return {
        "run": np.arange(n),
        "controller": np.array([r[0] for r in rows]),
        "controller.kind": np.array([r[0] for r in rows]),
        "radial_depths_mm": np.array([r[1] for r in rows]),
        "workpiece.radial_depth_mm": np.array([r[1] for r in rows]),
        "force_process.gain_multiplier": rng.uniform(0.8, 1.25, n),
        "reference_force_N": np.full(n, 500.0),
        "failed": np.zeros(n, bool),
        "oscillating": np.zeros(n, bool),
        "overload": np.zeros(n, bool),
        "rms_error_N": rng.uniform(40.0, 90.0, n),
        "max_overshoot_pct": rng.uniform(0.0, 40.0, n),
        "machining_time_s": rng.uniform(25.0, 35.0, n),
        "productivity_gain_pct": rng.uniform(0.0, 15.0, n),
    }


def sweep_traces(summary, steps=60):
    t = np.arange(steps) * 0.5
    runs = summary["run"]
    rng = np.random.default_rng(1)
    force = 500.0 * (1 - np.exp(-t / 2.0))[None, :] + rng.normal(0, 20, (runs.size, steps))
    force += 10.0 * np.arange(runs.size)[:, None] % 60
    return {"time_s": t, "run_ids": runs, "force_N": force}


def test_plot_force_bands_one_axes_many_groups():
    """Twelve groups (2 kinds x 6 profiles) on one Axes: the legend (once per group, the
    bands once) fits inside the figure and no two groups share a colour."""
    from acc.campaigns.plots import plot_force_bands

    summary = sweep_rows()
    fig, ax = plt.subplots(figsize=(7, 3.6), layout="constrained")
    plot_force_bands(sweep_traces(summary), summary, ax=ax)
    assert_legends_inside(fig)
    assert_units(ax.get_xlabel())
    assert_units(ax.get_ylabel())
    groups = [ln for ln in ax.get_lines() if ln.get_label().endswith("median")]
    assert len(groups) == 12
    colors = [tuple(np.round(to_rgba(ln.get_color()), 3)) for ln in groups]
    assert len(set(colors)) == 12


def test_force_bands_figure_one_panel_per_profile():
    from acc.campaigns.plots import force_bands_figure

    summary = sweep_rows()
    fig = force_bands_figure(sweep_traces(summary), summary)
    assert_legends_inside(fig)
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert len(panels) == len(PROFILES)
    (legend,) = fig.legends
    medians = [c for c, t in zip(legend_colors(legend), legend.get_texts(), strict=True)
               if t.get_text().endswith("median")]
    assert len(medians) == 2 and len(set(medians)) == 2
    for ax in panels:
        assert all(_varies(ln) for ln in ax.get_lines() if ln.get_label().endswith("median"))
    assert_units(panels[0].get_ylabel())


def test_plot_metric_distribution_labels_with_units():
    from acc.campaigns.plots import plot_metric_distribution

    summary = sweep_rows()
    fig, ax = plt.subplots()
    plot_metric_distribution(summary, "rms_error_N", ax=ax)
    _draw(fig)
    assert_units(ax.get_ylabel())
    assert "rms_error_N" not in ax.get_ylabel()
    assert not ax.texts  # values to show: no note


def test_a_metric_no_completed_run_has_says_so_in_its_panel():
    from acc.campaigns.plots import plot_metric_distribution

    summary = dict(sweep_rows())
    summary["machining_time_s"] = np.full(len(summary["failed"]), np.nan)
    fig, ax = plt.subplots()
    plot_metric_distribution(summary, "machining_time_s", ax=ax)
    _draw(fig)
    (note,) = ax.texts
    assert "no completed run has a value" in note.get_text()
    assert list(ax.get_yticks()) == []


def test_metrics_figure_groups_by_kind_and_profile():
    """Boxes per kind and per profile within it (2 x 6 per panel), readable labels with
    units, the profile legend inside the figure, tick labels apart."""
    from acc.campaigns.plots import metrics_figure

    summary = sweep_rows(kinds=("pi", "adaptive_pi", "dob_pi", "constant"))
    metrics = ("rms_error_N", "max_overshoot_pct", "machining_time_s", "productivity_gain_pct")
    fig = metrics_figure(summary, metrics, by="controller",
                         swept=("controller.kind", "workpiece.radial_depth_mm",
                                "force_process.gain_multiplier"))
    assert_legends_inside(fig)
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert len(panels) == len(metrics)
    for ax in panels:
        assert_units(ax.get_ylabel())
        assert len(ax.patches) == 4 * len(PROFILES)  # one box per kind and profile
    (legend,) = fig.legends
    assert len(set(legend_colors(legend))) == len(PROFILES)
    ticks = [t.get_window_extent() for t in panels[-1].get_xticklabels() if t.get_text()]
    assert len(ticks) == 4
    assert not any(_overlap(a, b) for i, a in enumerate(ticks) for b in ticks[i + 1:])


def outcome_rows():
    """Runs of two kinds over a swept gain (three values): some failed, some oscillating
    without failing, one overloaded."""
    gains = np.repeat([1.0, 2.5, 5.0], 4)
    n = gains.size
    summary = {
        "run": np.arange(2 * n),
        "controller": np.array(["pi"] * n + ["adaptive_pi"] * n),
        "lead_lag.gain": np.concatenate([gains, gains]),
        "failed": np.zeros(2 * n, bool),
        "oscillating": np.zeros(2 * n, bool),
        "overload": np.zeros(2 * n, bool),
    }
    summary["failed"][[8, 9, 10]] = True  # pi at gain 5: three of four diverged
    summary["oscillating"][[4, 5, 11, 12 + 8]] = True  # oscillating, not failed (mostly)
    summary["overload"][[12 + 1]] = True
    return summary


def _cell_counts(ax) -> dict[tuple[int, int], str]:
    return {(round(t.get_position()[1]), round(t.get_position()[0])): t.get_text()
            for t in ax.texts}


@pytest.mark.parametrize("flag", ["failed", "oscillating", "overload"])
def test_plot_failure_rate_counts_equal_the_rows(flag):
    """Each cell says ``flagged/runs``; both numbers are counted here from the rows."""
    from acc.campaigns.plots import plot_failure_rate

    summary = outcome_rows()
    fig, ax = plt.subplots()
    plot_failure_rate(summary, "lead_lag.gain", ax=ax, flag=flag)
    _draw(fig)
    cells = _cell_counts(ax)
    groups = sorted(set(summary["controller"].tolist()))
    for i, g in enumerate(groups):
        for j, v in enumerate((1.0, 2.5, 5.0)):
            sel = (summary["controller"] == g) & (summary["lead_lag.gain"] == v)
            want = f"{int(np.sum(summary[flag][sel]))}/{int(np.sum(sel))}"
            assert cells[(i, j)] == want
    total = int(np.sum(summary[flag]))
    assert f"{total} of {summary[flag].size} runs" in ax.get_title()
    assert [t.get_text() for t in ax.get_yticklabels()] == groups


def test_failure_rate_figure_shows_oscillating_runs_that_did_not_fail():
    from acc.campaigns.plots import failure_rate_figure

    summary = outcome_rows()
    fig = failure_rate_figure(summary, "lead_lag.gain")
    assert_legends_inside(fig)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    osc = next(t for t in titles if t.startswith("oscillating"))
    assert f"{int(np.sum(summary['oscillating']))} of" in osc
    assert int(np.sum(summary["oscillating"] & ~summary["failed"])) > 0


# --- run figures (force loop, axis, contour) -----------------------------------------------
@dataclass
class Result:
    """A result with named signals, as the figure functions read it."""

    time_s: np.ndarray
    signals: dict[str, np.ndarray]
    scenarios: list[Any] = field(default_factory=list)
    metrics: dict[str, np.ndarray] = field(default_factory=dict)

    def signal(self, name: str) -> np.ndarray:
        return self.signals[name]


def force_result(tooth_passing: bool) -> tuple[Result, float]:
    dt, rpm, teeth = 0.001, 600.0, 4
    t = np.arange(4000) * dt
    rev = 60.0 / rpm
    mean = 300.0 * (1 - np.exp(-t / 0.3)) + 60.0 * (t > 2.5)
    if tooth_passing:  # a tooth in cut half of each tooth period, peak twice the mean
        phase = (t / (rev / teeth)) % 1.0
        force = np.where(phase < 0.5, 2.0 * mean, 0.0)
    else:
        force = mean
    geometry = SimpleNamespace(tooth_passing=tooth_passing, spindle_speed_rpm=rpm, teeth=teeth)
    signals = {
        "force_N": force[None], "measured_force_N": (mean + 3.0)[None],
        "reference_force_N": np.full((1, t.size), 300.0),
        "commanded_feed_mm_min": np.full((1, t.size), 150.0) - 20 * (t > 2.5),
        "feed_velocity_mm_min": np.full((1, t.size), 149.0) - 20 * (t > 2.51),
        "radial_depth_mm": np.where(t > 2.5, 4.0, 3.0)[None],
    }
    return Result(t, signals, [SimpleNamespace(geometry=geometry)]), rev


def test_response_figure_force_per_revolution_under_tooth_passing():
    """The force panel draws one point per spindle revolution: the peak and the mean over
    each revolution, computed here from the tooth-passing signal."""
    from acc.plots import response_figure

    result, rev = force_result(tooth_passing=True)
    fig = response_figure(result)
    assert_legends_inside(fig)
    ax = fig.axes[0]
    per = int(round(rev / 0.001))
    blocks = result.signals["force_N"][0][: (4000 // per) * per].reshape(-1, per)
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    peak = lines["force peak per revolution"]
    np.testing.assert_allclose(peak.get_ydata(), blocks.max(axis=1))
    np.testing.assert_allclose(lines["force mean per revolution"].get_ydata(),
                               blocks.mean(axis=1))
    assert max(len(ln.get_xdata()) for ln in ax.get_lines()
               if ln.get_label() != "reference") == 4000 // per
    for a in fig.axes:
        assert_units(a.get_ylabel())


def test_response_figure_measured_drawn_over_the_force():
    """Without tooth passing the measured force is drawn above the force (thinner, its own
    colour), so where they coincide both lines and legend entries show."""
    from acc.plots import response_figure

    result, _ = force_result(tooth_passing=False)
    fig = response_figure(result)
    assert_legends_inside(fig)
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    force, measured = lines["force"], lines["measured"]
    assert measured.get_zorder() > force.get_zorder()
    assert measured.get_linewidth() < force.get_linewidth()
    colors = legend_colors(ax.get_legend())
    assert len(set(colors)) == len(colors)


def axis_result(step_mm: float = 0.01) -> Result:
    """A 10 um position step settled in about 0.15 s, recorded for 2 s."""
    dt = 0.001
    t = np.arange(2000) * dt
    ref = np.where(t >= 0.01, step_mm, 0.0)
    tau = np.clip(t - 0.01, 0.0, None)
    x = np.where(t >= 0.01, step_mm * (1 - np.exp(-tau / 0.02) * np.cos(2 * np.pi * 40 * tau)),
                 0.0)
    v = np.gradient(x, dt)
    signals = {"x_ref_mm": ref[None], "x_mm": x[None], "following_error_mm": (ref - x)[None],
               "velocity_mm_s": v[None], "current_A": (5.0 * v)[None]}
    return Result(t, signals)


def test_axis_response_figure_small_step_in_um_and_zoomed():
    from acc.plots import axis_response_figure

    result = axis_result()
    fig = axis_response_figure(result, title="step")
    assert_legends_inside(fig)
    position, error = fig.axes[0], fig.axes[1]
    assert "[um]" in position.get_ylabel() and "[um]" in error.get_ylabel()
    # the last sample that is more than 1 % of its range from its final value, per signal
    t = result.time_s
    last = 0.0
    for k in ("x_ref_mm", "following_error_mm", "velocity_mm_s", "current_A"):
        v = result.signals[k][0]
        moving = np.flatnonzero(np.abs(v - v[-1]) > 0.01 * np.ptp(v))
        last = max(last, t[moving[-1] + 1])
    assert position.get_xlim()[1] == pytest.approx(1.5 * last)
    assert position.get_xlim()[1] < 0.4 * t[-1]
    for ax in fig.axes:
        assert_units(ax.get_ylabel())


def test_plot_contour_error_no_curve_hidden():
    """Two estimates equal to the exact error: the exact curve is widest and underneath,
    each estimate thinner and above the one before, and no two share colour and style."""
    from controllers.contouring.plots import plot_contour_error

    t = np.linspace(0.0, 1.0, 200)
    e = 0.03 * np.sin(2 * np.pi * t)
    fig, ax = plt.subplots()
    plot_contour_error(t, {"exact": e, "linear (4.78)": e + 0.005, "Eq. 16": e}, ax)
    assert_legends_inside(fig)
    lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]
    widths = [ln.get_linewidth() for ln in lines]
    orders = [ln.get_zorder() for ln in lines]
    assert widths[0] > max(widths[1:])
    assert orders == sorted(orders) and len(set(orders)) == len(orders)
    styles = {(tuple(np.round(to_rgba(ln.get_color()), 3)), str(ln.get_linestyle()))
              for ln in lines}
    assert len(styles) == len(lines)
    assert_units(ax.get_ylabel())


# --- analysis figures -----------------------------------------------------------------------
KINDS6 = ("pi", "adaptive_pi", "dob_pi", "dob_adaptive_pi", "fsp_pi", "fsp_adaptive_pi")


def test_plot_gain_ratio_bars_labels_apart():
    """Six kinds on four plants, neighbouring values close (as on the shipped scenario):
    no two bar labels overlap, and the legend is inside the figure."""
    from acc.design.loop_plots import plot_gain_ratio_bars

    values = np.array([[3.08, 3.08, 1.89, 1.89, 3.41, 3.41], [3.35, 3.06, 2.01, 1.89, 3.90, 3.41],
                       [3.08, 3.08, 1.89, 1.89, 3.41, 3.41], [2.19, 3.08, 1.36, 1.89, 2.32, 3.40]])
    rows = [{"controller": k, "plant": p, "max_gain_ratio_sampled": values[i, j]}
            for i, p in enumerate(("nominal", "2 mm", "3 mm", "4 mm"))
            for j, k in enumerate(KINDS6)]
    fig, ax = plt.subplots(figsize=(4.4, 3.2))  # a panel of the analysis figure
    plot_gain_ratio_bars(rows, ax)
    assert_legends_inside(fig)
    labels = [t for t in ax.texts if isinstance(t, Text) and t.get_text()]
    assert len(labels) == 24
    boxes = [t.get_window_extent() for t in labels]
    assert not any(_overlap(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    assert_units(ax.get_ylabel())
    # the legend does not cover a label
    legend = ax.get_legend().get_window_extent()
    assert not any(_overlap(legend, b) for b in boxes)


def test_plot_bode_margin_markers_distinct_per_curve():
    """Loops whose margins fall at nearly one frequency: each curve marks its margins with
    its own marker shape, and the legend shows it."""
    import control

    from acc.design.loop_plots import plot_bode

    w = np.logspace(-1, 2, 400)
    loops = {}
    for n, k in enumerate((8.0, 9.0, 10.0, 11.0)):
        L = control.tf([k], [1.0, 2.0, 0.0]) * control.tf(*control.pade(0.1 + 0.002 * n, 4))
        loops[f"k={k:g}"] = control.frd(L, w)
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True)
    plot_bode(loops, (a1, a2))
    assert_legends_inside(fig)
    markers = [ln.get_marker() for ln in a1.get_lines() if len(ln.get_xdata()) == 1]
    assert len(markers) == len(loops) and len(set(markers)) == len(loops)
    legend = a1.get_legend()
    assert [h.get_marker() for h in legend.legend_handles] == markers
    assert_units(a1.get_ylabel())
    assert_units(a2.get_ylabel())


def test_comparison_figure_estimates_only_for_kinds_with_an_estimator():
    from acc.design.comparison import Comparison, comparison_figure
    from controllers.registry import controller_kind

    kinds = ("pi", "adaptive_pi", "dob_pi", "dob_adaptive_pi")
    t = np.arange(500) * 0.01
    runs = len(kinds)
    ramp = np.linspace(0.0, 1.0, t.size)
    signals = {
        "force_N": 500.0 * (1 - np.exp(-t))[None].repeat(runs, 0),
        "reference_force_N": np.full((runs, t.size), 500.0),
        "commanded_feed_mm_min": 150.0 + ramp[None].repeat(runs, 0),
        "estimated_static_gain_N_per_mm_min": 3.0 + ramp[None].repeat(runs, 0),
        "disturbance_estimate_mm_min": 10.0 * ramp[None].repeat(runs, 0),
    }
    comparison = Comparison(Result(t, signals), kinds, (1.0,), 1)
    fig = comparison_figure(comparison)
    assert_legends_inside(fig)
    panels = {ax.get_ylabel(): ax for ax in fig.axes}
    names = {k: {g.__name__ for g in controller_kind(k).options} for k in kinds}
    gain = [ln.get_label() for ln in panels["est. gain [N/(mm/min)]"].get_lines()]
    dist = [ln.get_label() for ln in panels["dist. est. [mm/min]"].get_lines()]
    assert gain == [k for k in kinds if "EstimatorOptions" in names[k]]
    assert dist == [k for k in kinds if "ObserverOptions" in names[k]]
    for ax in fig.axes:
        assert_units(ax.get_ylabel())


# --- the studies' figures (experiments/*.py) ------------------------------------------------
def test_breakage_study_figure_no_flat_panel():
    """Detection delay 1 tooth period in every run: no panel draws it as a flat line; the
    title says it, with the detection counts computed here; the overshoot panel varies."""
    import breakage_under_force_control as study

    kinds = study.KINDS
    seeds = 4
    keys = [(i, k) for i in range(seeds) for k in kinds]
    t = np.arange(2000) * 0.005
    rng = np.random.default_rng(3)
    signals = {"measured_force_N": 300 + rng.normal(0, 20, (len(keys), t.size)),
               "force_N": 300 + rng.normal(0, 80, (len(keys), t.size))}
    values = {
        "detection_delay_tooth_periods": {k: np.ones(seeds) for k in kinds},
        "breakage_overshoot_pct": {k: rng.uniform(5, 60, seeds) for k in kinds},
        "breakage_detected": {k: np.ones(seeds) for k in kinds},
        "breakage_missed": {k: np.zeros(seeds) for k in kinds},
        "breakage_false_alarm": {k: np.array([0.0, 1.0, 0.0, 0.0]) for k in kinds},
    }
    cases = [{"period": 203}] * seeds
    fig = study.figure(Result(t, signals), keys, values.__getitem__, cases, 0.025)
    assert_legends_inside(fig)
    for ax in fig.axes[1:]:
        drawn = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 1]
        assert drawn and all(_varies(ln) for ln in drawn), ax.get_ylabel()
        assert_units(ax.get_ylabel())
    title = fig.get_suptitle()
    assert f"1 in every run ({seeds * len(kinds)})" in title
    assert f"detected in {seeds * len(kinds)} of {seeds * len(kinds)} runs" in title
    assert f"false alarms in {len(kinds)}" in title


def test_disturbance_study_figure_keeps_the_largest_effects():
    """Every mean and interval end inside its panel's y range, the legend inside the figure."""
    import disturbance_rejection as study

    rng = np.random.default_rng(5)
    rows = []
    for name in ("force_step", "runout", "sensor_bias"):
        for kind in ("pi", "adaptive_pi", "dob_pi", "dob_adaptive_pi"):
            for depth in (2.0, 3.0, 4.0):
                for g in (0.5, 1.0, 3.0):
                    mean = 0.0 if kind == "pi" else float(rng.choice([-1, 1]) * 10 ** rng.uniform(
                        0.5, 3.7))
                    half = abs(mean) * 0.05 + 1.0
                    rows.append({"disturbance": name, "controller": kind, "radial_depth_mm": depth,
                                 "gain_multiplier": g, "paired_difference": mean,
                                 "difference_ci95_low": mean - half,
                                 "difference_ci95_high": mean + half})
    fig = study.figure(rows)
    assert_legends_inside(fig)
    for ax, name in zip(fig.axes, ("force_step", "runout", "sensor_bias"), strict=False):
        mine = [r for r in rows if r["disturbance"] == name]
        ends = [(0.0, r[k]) for r in mine for k in ("difference_ci95_low", "difference_ci95_high")]
        # in axes fractions: clear of the frame by more than a marker (3 pt of a 3.6 in panel)
        frac = ax.transLimits.transform(ax.transScale.transform(np.array(ends)))[:, 1]
        assert frac.min() > 0.02 and frac.max() < 0.98, (name, frac.min(), frac.max())
        assert_units(ax.get_ylabel())


def test_robust_design_pareto_names_inside_the_frame():
    import robust_design as study

    rows = [{"design": d, "k_kn_min": k, "p95_iae_N_s": x, "oscillating_runs": o, "pareto": p}
            for d, k, x, o, p in (
                ("adaptive_pi", 2.65, 1900.0, 0, False), ("dob_pi", 1.22, 8700.0, 40, False),
                ("pi", 1.93, 4800.0, 20, False), ("fsp_pi", 2.17, 5900.0, 20, False),
                ("adaptive_pi (PM 70)", 4.0, 1950.0, 0, True),
                ("pi (co-design)", 6.7, 1700.0, 0, True))]
    ax = study.plot_pareto(rows, 160.0, floor_p95=960.0, target_p95=1200.0)
    fig = ax.figure
    assert_legends_inside(fig)
    frame = ax.get_window_extent()
    for text in ax.texts:
        e = text.get_window_extent()
        assert frame.x0 <= e.x0 and e.x1 <= frame.x1 and frame.y0 <= e.y0 and e.y1 <= frame.y1, (
            text.get_text())
    assert min(t.get_fontsize() for t in ax.get_legend().get_texts()) >= 8
    assert_units(ax.get_xlabel())
    assert_units(ax.get_ylabel())


def test_servo_axis_figure_difference_panels():
    """Two nearly equal traces: under each, a panel with their difference (computed here
    where both cut), which varies."""
    import force_loop_on_servo_axis as study

    t = np.arange(3000) * 0.01
    base = 500.0 * (1 - np.exp(-t / 0.5))
    force = np.stack([base, base + 5.0 * np.sin(t)])
    force[1, -3:] = 0.0  # the second run leaves the part three samples earlier
    velocity = np.stack([120 + 0 * t, 120 + 0.5 * np.cos(t)])
    fig = study.drive_comparison_figure(t, force, velocity, np.full(t.size, 500.0))
    assert_legends_inside(fig)
    both = (force[0] > 0) & (force[1] > 0)
    diffs = [ax for ax in fig.axes if ax.get_ylabel().startswith("difference")]
    assert len(diffs) == 2
    for ax, signal in zip(diffs, (force, velocity), strict=True):
        (line,) = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == t.size]
        want = np.where(both, signal[1] - signal[0], np.nan)
        np.testing.assert_allclose(line.get_ydata(), want)
        assert _varies(line)
    for ax in fig.axes:
        assert_units(ax.get_ylabel())
