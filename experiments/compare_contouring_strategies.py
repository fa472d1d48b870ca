"""Contouring strategies compared on Peng's axes: one diamond corner and one circle, as a
paired campaign over axis mismatch and feed (spec §5.4 item 5).

Plant: two Peng servo axes (App. A), x with ``B_x = 0.09``, y with ``B_y`` drawn per seed
from U(0.09, 0.4) N m s/rad (the mismatch); feed drawn per seed from {10, 12.5, 20, 25} mm/s
(per axis on the diamond, along the path on the 10 mm circle).  Seed ``i`` gives the same
``(B_y, feed)`` to every strategy, so differences are paired (common random numbers).

Strategies (all with the same axes):

``lead_lag``             Peng's D(z) = 2.5 (z - 0.8825)/z, sharp corner (the baseline)
``accel_decel``          the same loop, each axis ramped to rest at the vertex over 0.1 s
                         (diamond only)
``spline_2``             the same loop, Peng's two-segment spline corner (diamond only)
``integrator``           the loop with a discrete parallel integrator ``k_i = 1e-3`` per
                         sample [ASSUMED, spec O-12], switched off 1 mm before the vertex
                         and on 3 mm after it on the diamond, always on on the circle
``velocity_ff``          LinuxCNC PID: P = K_p K_d (1 + a) counts/mm (the lead-lag's DC gain,
                         so the same velocity constant) plus FF1 = the nominal (B = 0.09)
                         axis's volts per mm/s, on both axes (the controller does not know
                         the mismatch), fed the interpolator's velocity (command-deriv)
``cec_eq11``/``cec_eq16`` the lead-lag axes plus Lacerda & Belo's cross-coupled controller
                         (P on the estimated contour error, Eq. 11 or Eq. 16), its gain the
                         best of a small grid on the nominal mismatched case
                         (``B_y = 0.3``, 20 mm/s), then held fixed

Metrics (exact contour error against the ideal path): diamond corner error M1, the
incoming-line error and the IAE; circle max ``|e|``, circular deviation G and the IAE.

Restricted state control (seed 004) damps a mechanical oscillator that Peng's rigid axes do
not have, so it is compared on a second plant: two of Briquez's Huron X axes (42 Hz,
damping 0.2, 400 Hz speed loop, 0.2 um scale, 2 ms period), the y oscillator's frequency
drawn per seed from U(30, 55) Hz, the same feeds and paths; strategies ``p_36`` (P at the
original K_v = 36.6/s), ``p_60`` (P at 60/s, the baseline of this block) and ``rsc_60``
(60/s with the observer's acceleration on the position reference, K_3p = 0.00584 mm per
m/s^2, the shipped Huron design; tuned for 42 Hz, not for the drawn y axis).

``python experiments/compare_contouring_strategies.py --out DIR [--seeds 8]`` prints per
metric each strategy's mean with its 95 % interval, the paired difference from the baseline
and a verdict; writes ``DIR/per_seed.csv``, ``DIR/summary.csv``, ``DIR/diamond_error.png``
and ``DIR/strategies.png`` (the means with their intervals, coloured by verdict).
A verdict is claimed only where the 95 % interval of the paired difference excludes 0 and
its mean exceeds the resolution, 1e-6 mm (1 nm; 1e-6 mm s for the IAE) or 1e-6 of the
metric's scale if larger (:func:`acc.design.paired.paired_comparison`): a difference far
below anything measurable is not called.  ``--quick`` runs 3 seeds (a smoke run).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import defaultdict
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from acc.design.paired import paired_comparison, paired_table  # noqa: E402
from acc.engine.contour_simulate import simulate_contouring, switched_integrator  # noqa: E402
from acc.engine.xy_simulate import XYReference, simulate_xy  # noqa: E402
from acc.output import write_csv  # noqa: E402
from controllers.axis.lead_lag import LeadLagParams  # noqa: E402
from controllers.axis.pid import AxisPIDParams  # noqa: E402
from controllers.axis.state_control import StateControlParams  # noqa: E402
from controllers.contouring.cross_coupled import CrossCoupledParams  # noqa: E402
from controllers.contouring.feedforward import velocity_feedforward_pid  # noqa: E402
from controllers.contouring.interpolator import PathParams, PathReference, interpolate  # noqa: E402
from controllers.monitoring.circular_test import evaluate_circle  # noqa: E402
from controllers.monitoring.contour_metrics import corner_metrics  # noqa: E402
from plants.axis.oscillating_axis import OscillatingAxisParams  # noqa: E402
from plants.axis.servo_axis import ServoAxisParams  # noqa: E402

T = 0.001
AX = ServoAxisParams()
LL = LeadLagParams()
LL_I = replace(LL, integrator_form="discrete_parallel", integrator_gain_per_sample=1e-3)
FEEDS_MM_S = (10.0, 12.5, 20.0, 25.0)
RADIUS_MM = 10.0
CEC_GRID_V_PER_MM = (10.0, 25.0, 50.0, 100.0)
#: Smallest paired difference given a verdict, in the metric's unit (mm, mm s).
RESOLUTION = 1e-6
QUICK_SEEDS = 3
#: Briquez's Huron X axis (seed 004; experiments/briquez_huron_axis.toml) and its laws.
HURON = OscillatingAxisParams()
HURON_STEP_S = 0.002
HURON_LAWS = {
    "p_36": StateControlParams(position_gain_1_s=36.6, source="none"),
    "p_60": StateControlParams(position_gain_1_s=60.0, source="none"),
    "rsc_60": StateControlParams(position_gain_1_s=60.0, source="observer",
                                 injection="position_reference",
                                 acceleration_offset_gain_mm_per_m_s2=0.00584,
                                 acceleration_delay_samples=1),
}
STRATEGIES = ("lead_lag", "accel_decel", "spline_2", "integrator", "velocity_ff", "cec_eq11",
              "cec_eq16")


def velocity_ff_pid(axis: ServoAxisParams = AX) -> AxisPIDParams:
    """P with the lead-lag's DC gain plus FF1 of the nominal axis."""
    return velocity_feedforward_pid(axis, LL)


def draws(seeds: int) -> list[tuple[float, float]]:
    """``(B_y, feed)`` of each seed."""
    out = []
    for s in range(seeds):
        rng = np.random.default_rng(s)
        out.append((float(rng.uniform(0.09, 0.4)), float(rng.choice(FEEDS_MM_S))))
    return out


def _grouped(refs: list[PathReference]) -> dict[int, list[int]]:
    groups: dict[int, list[int]] = defaultdict(list)
    for i, r in enumerate(refs):
        groups[r.samples].append(i)
    return groups


def run_peng(refs: list[PathReference], axes_y: list[ServoAxisParams],
             ctrls: list) -> list[np.ndarray]:
    """Tool positions (n, 2) of independent-axis runs (batched by sample count)."""
    out: list[np.ndarray] = [np.empty(0)] * len(refs)
    for idx in _grouped(refs).values():
        res = simulate_contouring([refs[i] for i in idx], AX, [axes_y[i] for i in idx],
                                  [ctrls[i] for i in idx])
        for j, i in enumerate(idx):
            out[i] = res.position_mm(j)
    return out


def run_xy(refs: list[PathReference], axes_y: list[ServoAxisParams],
           cec: list[CrossCoupledParams] | None = None, controller: object = LL
           ) -> list[np.ndarray]:
    """Tool positions from the coupled XY loop: lead-lag (or ``controller``) axes with a
    cross-coupled controller, the reference velocity available to feed-forward."""
    out: list[np.ndarray] = [np.empty(0)] * len(refs)
    for idx in _grouped(refs).values():
        rows = [XYReference.from_path(refs[i]) for i in idx]
        stacked = XYReference(*(np.stack([getattr(r, name) for r in rows]) for name in (
            "x_mm", "y_mm", "velocity_x_mm_s", "velocity_y_mm_s", "tangent_angle_rad",
            "centre_x_mm", "centre_y_mm", "radius_mm")))
        res = simulate_xy(AX, [axes_y[i] for i in idx], controller, controller, stacked,
                          cec=None if cec is None else [cec[i] for i in idx], plant_step_s=T,
                          control_period_s=T, command_limit_V=0.0)
        for j, i in enumerate(idx):
            out[i] = np.stack([res.signals["x_mm"][j], res.signals["y_mm"][j]], axis=1)
    return out


def _diamond(feed: float, corner: str = "sharp", dt: float = T) -> PathReference:
    return interpolate(PathParams(kind="diamond", feed_per_axis_mm_s=feed, corner=corner), dt)


def _circle(feed: float, dt: float = T) -> PathReference:
    return interpolate(PathParams(kind="circle", radius_mm=RADIUS_MM, feed_mm_s=feed), dt)


def diamond_metrics(ref: PathReference, pos: np.ndarray) -> dict[str, float]:
    e = ref.exact_contour_error(pos)
    if not np.all(np.isfinite(e)) or np.abs(e).max() > 10.0:
        return {"corner_M1_mm": math.nan, "line_error_mm": math.nan, "iae_mm_s": math.nan}
    m = corner_metrics(ref, pos)
    return {"corner_M1_mm": m.vertex_distance_mm,
            "line_error_mm": abs(m.linear_segment_error_mm),
            "iae_mm_s": float(np.abs(e).sum() * ref.plant_step_s)}


def circle_metrics(ref: PathReference, pos: np.ndarray) -> dict[str, float]:
    e = ref.exact_contour_error(pos)
    if not np.all(np.isfinite(e)) or np.abs(e).max() > 10.0:
        return {"max_error_mm": math.nan, "G_mm": math.nan, "iae_mm_s": math.nan}
    c = evaluate_circle(pos, (0.0, 0.0), RADIUS_MM, e, ref.plant_step_s)
    return {"max_error_mm": c.max_abs_error_mm, "G_mm": c.g_mm, "iae_mm_s": c.iae_mm_s}


def tune_cec(model: str) -> float:
    """The grid gain with the least summed IAE (diamond + circle) on the nominal case."""
    ay = replace(AX, viscous_friction_Nm_s_rad=0.3)
    refs = [_diamond(20.0)] * len(CEC_GRID_V_PER_MM) + [_circle(20.0)] * len(CEC_GRID_V_PER_MM)
    cec = [CrossCoupledParams(model=model, kp_V_per_mm=k) for k in CEC_GRID_V_PER_MM] * 2
    pos = run_xy(refs, [ay] * len(refs), cec)
    n = len(CEC_GRID_V_PER_MM)
    cost = [diamond_metrics(refs[i], pos[i])["iae_mm_s"]
            + circle_metrics(refs[n + i], pos[n + i])["iae_mm_s"] for i in range(n)]
    cost = [c if math.isfinite(c) else math.inf for c in cost]
    return CEC_GRID_V_PER_MM[int(np.argmin(cost))]


def oscillating_block(seeds: int) -> list[dict]:
    """Briquez's Huron axes: P at the original K_v, P at 60/s, and P at 60/s with RSC."""
    rng_f = [float(np.random.default_rng(1000 + s).uniform(30.0, 55.0)) for s in range(seeds)]
    feeds = [f for _, f in draws(seeds)]
    ays = [replace(HURON, oscillator_frequency_Hz=f) for f in rng_f]
    rows: list[dict] = []
    for path in ("diamond", "circle"):
        refs = [_diamond(f, dt=HURON_STEP_S) if path == "diamond" else _circle(f, HURON_STEP_S)
                for f in feeds]
        for strat, law in HURON_LAWS.items():
            out: list[np.ndarray] = [np.empty(0)] * seeds
            for idx in _grouped(refs).values():
                res = simulate_contouring([refs[i] for i in idx], HURON,
                                          [ays[i] for i in idx], law)
                for j, i in enumerate(idx):
                    out[i] = res.position_mm(j)
            for s in range(seeds):
                m = (diamond_metrics if path == "diamond" else circle_metrics)(refs[s], out[s])
                rows += [{"plant": "huron_oscillating", "path": path, "strategy": strat,
                          "seed": s, "mismatch": rng_f[s], "feed_mm_s": feeds[s], "metric": k,
                          "value": v} for k, v in m.items()]
    return rows


def campaign(seeds: int) -> tuple[list[dict], dict[str, float]]:
    """Per-seed metrics of every strategy on both paths, and the tuned CEC gains."""
    d = draws(seeds)
    ays = [replace(AX, viscous_friction_Nm_s_rad=b) for b, _ in d]
    feeds = [f for _, f in d]
    gains = {m: tune_cec(m) for m in ("linear", "curvature")}
    rows: list[dict] = []
    for path in ("diamond", "circle"):
        for strat in STRATEGIES:
            if path == "circle" and strat in ("accel_decel", "spline_2"):
                continue
            if path == "diamond":
                corner = {"accel_decel": "accel_decel", "spline_2": "spline_2"}.get(strat, "sharp")
                refs = [_diamond(f, corner) for f in feeds]
            else:
                refs = [_circle(f) for f in feeds]
            if strat.startswith("cec"):
                model = "linear" if strat == "cec_eq11" else "curvature"
                cec = [CrossCoupledParams(model=model, kp_V_per_mm=gains[model])] * seeds
                pos = run_xy(refs, ays, cec)
            elif strat == "velocity_ff":
                pos = run_xy(refs, ays, controller=velocity_ff_pid())
            else:
                if strat == "integrator":
                    ctrls = [switched_integrator(LL_I, r, 1.0, 3.0) if path == "diamond"
                             else LL_I for r in refs]
                else:
                    ctrls = [LL] * seeds
                pos = run_peng(refs, ays, ctrls)
            for s in range(seeds):
                m = (diamond_metrics if path == "diamond" else circle_metrics)(refs[s], pos[s])
                rows += [{"plant": "peng_servo", "path": path, "strategy": strat, "seed": s,
                          "mismatch": d[s][0], "feed_mm_s": d[s][1], "metric": k, "value": v}
                         for k, v in m.items()]
    return rows + oscillating_block(seeds), gains


def summarise(rows: list[dict]) -> list[dict]:
    """Paired comparison against each plant's baseline per path and metric."""
    out = []
    for plant, baseline in (("peng_servo", "lead_lag"), ("huron_oscillating", "p_60")):
        for path in ("diamond", "circle"):
            mine = [r for r in rows if r["plant"] == plant and r["path"] == path]
            for metric in sorted({r["metric"] for r in mine}):
                values: dict[str, list[float]] = defaultdict(list)
                for r in mine:
                    if r["metric"] == metric:
                        values[r["strategy"]].append(r["value"])
                for row in paired_table(paired_comparison(values, baseline,
                                                            abs_resolution=RESOLUTION), metric):
                    out.append({"plant": plant, "path": path, **row})
    return out


#: Panels of ``strategies.png``: (path, metric, axis label).
SUMMARY_PANELS = (("diamond", "corner_M1_mm", "diamond corner error M1 [um]"),
                  ("diamond", "line_error_mm", "diamond incoming-line error [um]"),
                  ("circle", "max_error_mm", "circle max |contour error| [um]"))
VERDICT_COLOURS = {"baseline": "0.5", "lower": "tab:green", "higher": "tab:red",
                   "no significant difference": "tab:blue"}


def draw_strategy_means(summary: list[dict], path: str, metric: str, ax: Any,
                        plant: str = "peng_servo") -> Any:
    """Each strategy's mean [um] with its 95 % interval, coloured by the paired verdict
    against the baseline (grey baseline, green lower, red higher, blue none); returns ``ax``."""
    rows = [r for r in summary
            if (r["plant"], r["path"], r["metric"]) == (plant, path, metric)]
    names = [r["controller"] for r in rows]
    y = np.arange(len(rows))[::-1]
    ax.barh(y, [1e3 * r["mean"] for r in rows], xerr=[1e3 * r["ci95_half_width"] for r in rows],
            color=[VERDICT_COLOURS[r["verdict"]] for r in rows], capsize=3)
    ax.set_yticks(y, names)
    return ax


def summary_figure(out: Path, summary: list[dict], seeds: int) -> None:
    """``strategies.png``: the paired campaign's means on Peng's axes, one panel per metric."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    fig, axes = plt.subplots(1, len(SUMMARY_PANELS), figsize=(11, 3.6))
    for ax, (path, metric, label) in zip(axes, SUMMARY_PANELS, strict=True):
        draw_strategy_means(summary, path, metric, ax)
        ax.set_xlabel(label)
    axes[0].legend(handles=[Patch(color=c, label=v) for v, c in VERDICT_COLOURS.items()],
                   fontsize=7, loc="lower right")
    fig.suptitle(f"Peng's axes, B_y ~ U(0.09, 0.4), feed from {FEEDS_MM_S} mm/s: means over "
                 f"{seeds} paired seeds, 95 % CI, verdict against lead_lag", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "strategies.png", dpi=90)
    plt.close(fig)


def figure(out: Path, gains: dict[str, float]) -> None:
    """Contour error against time of every strategy on the nominal mismatched diamond."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from controllers.contouring.plots import plot_contour_error

    ay = replace(AX, viscous_friction_Nm_s_rad=0.3)
    errors = {}
    for strat in STRATEGIES:
        corner = {"accel_decel": "accel_decel", "spline_2": "spline_2"}.get(strat, "sharp")
        ref = _diamond(20.0, corner)
        if strat.startswith("cec"):
            model = "linear" if strat == "cec_eq11" else "curvature"
            pos = run_xy([ref], [ay], [CrossCoupledParams(model=model,
                                                           kp_V_per_mm=gains[model])])[0]
        elif strat == "velocity_ff":
            pos = run_xy([ref], [ay], controller=velocity_ff_pid())[0]
        else:
            ctrl = switched_integrator(LL_I, ref, 1.0, 3.0) if strat == "integrator" else LL
            pos = run_peng([ref], [ay], [ctrl])[0]
        e = ref.exact_contour_error(pos)
        t = ref.time_s - ref.vertex_time_s
        keep = np.abs(t) <= 0.3
        errors[strat] = (t[keep], e[keep])
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for name, (t, e) in errors.items():
        plot_contour_error(t, {name: e}, ax)
    ax.set_xlabel("time from the vertex [s]")
    ax.set_title("mismatched diamond (B_y 0.3), 20 mm/s per axis: exact contour error")
    fig.tight_layout()
    fig.savefig(out / "diamond_error.png", dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path)
    ap.add_argument("--seeds", type=int, default=None,
                    help=f"paired draws (default 8, {QUICK_SEEDS} with --quick)")
    ap.add_argument("--quick", action="store_true", help=f"{QUICK_SEEDS} seeds (a smoke run)")
    args = ap.parse_args(argv)
    seeds = args.seeds if args.seeds is not None else (QUICK_SEEDS if args.quick else 8)
    if seeds < 2:
        ap.error("--seeds must be >= 2 (paired intervals)")
    rows, gains = campaign(seeds)
    summary = summarise(rows)
    print(f"CEC gains (grid {CEC_GRID_V_PER_MM} V/mm, nominal case): "
          f"Eq. 11 {gains['linear']:g}, Eq. 16 {gains['curvature']:g} V/mm")
    print(f"{'plant':<18}{'path':<8}{'metric':<15}{'strategy':<13}{'mean':>11}{'+-95%':>10}"
          f"{'paired diff':>13}  verdict (none below {RESOLUTION:g} or 1e-6 of the scale)")
    for r in summary:
        print(f"{r['plant']:<18}{r['path']:<8}{r['metric']:<15}{r['controller']:<13}"
              f"{r['mean']:>11.4g}{r['ci95_half_width']:>10.2g}{r['paired_difference']:>13.4g}"
              f"  {r['verdict']}")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        write_csv(args.out / "per_seed.csv", rows)
        write_csv(args.out / "summary.csv", summary)
        figure(args.out, gains)
        summary_figure(args.out, summary, seeds)
        print(f"wrote {args.out}/per_seed.csv, summary.csv, diamond_error.png, strategies.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
