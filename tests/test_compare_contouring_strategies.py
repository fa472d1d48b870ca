"""The contouring strategy study end to end (``--quick``: 3 paired seeds): the claims the
README makes from it hold seed by seed, the incoming-line error equals Peng's closed form
(4.91), and a paired difference far below the resolution gets no verdict."""

from __future__ import annotations

import csv
import math
from collections import defaultdict
from dataclasses import replace

import pytest

from acc.design import axis_analysis as aa
from tests.cli_run import experiment_module


def _load():
    return experiment_module("compare_contouring_strategies")


def _read(path):
    with path.open() as fh:
        return list(csv.DictReader(fh))


def test_quick_study(tmp_path):
    mod = _load()
    assert mod.main(["--quick", "--out", str(tmp_path)]) == 0
    per_seed = _read(tmp_path / "per_seed.csv")
    summary = _read(tmp_path / "summary.csv")
    v: dict[tuple, dict[int, float]] = defaultdict(dict)
    draw: dict[int, tuple[float, float]] = {}
    for r in per_seed:
        if r["plant"] == "peng_servo":
            v[r["path"], r["metric"], r["strategy"]][int(r["seed"])] = float(r["value"])
            draw[int(r["seed"])] = (float(r["mismatch"]), float(r["feed_mm_s"]))
    seeds = sorted(draw)
    assert seeds == list(range(mod.QUICK_SEEDS))

    # the lead-lag's incoming-line error is Peng's steady mismatch error (4.91) on the 45 deg
    # diamond side, f per axis (independent: the closed form, not a simulation)
    for s in seeds:
        b_y, feed = draw[s]
        closed = aa.contour_error_mm(mod.AX, replace(mod.AX, viscous_friction_Nm_s_rad=b_y),
                                     mod.LL, mod.T, feed * math.sqrt(2), math.pi / 4)
        assert v["diamond", "line_error_mm", "lead_lag"][s] == pytest.approx(abs(closed),
                                                                             rel=1e-3)

    # README claims, seed by seed: the cross-coupled controller cuts the circle error and the
    # line error; Eq. 16 beats Eq. 11 on the circle; the two are the same on straight lines
    for s in seeds:
        base = v["circle", "max_error_mm", "lead_lag"][s]
        eq11 = v["circle", "max_error_mm", "cec_eq11"][s]
        eq16 = v["circle", "max_error_mm", "cec_eq16"][s]
        assert eq16 < eq11 < 0.5 * base
        assert v["diamond", "line_error_mm", "cec_eq16"][s] < 0.5 * v[
            "diamond", "line_error_mm", "lead_lag"][s]
        assert v["diamond", "line_error_mm", "cec_eq16"][s] == pytest.approx(
            v["diamond", "line_error_mm", "cec_eq11"][s], rel=1e-9)

    # the verdict rule: a common feed-forward leaves the mismatch error unchanged (to far below
    # a nanometre), and that is not called a difference
    row = next(r for r in summary if (r["plant"], r["path"], r["metric"], r["controller"])
               == ("peng_servo", "diamond", "line_error_mm", "velocity_ff"))
    assert abs(float(row["paired_difference"])) < 1e-8
    assert row["verdict"] == "no significant difference"
    assert float(row["resolution"]) >= mod.RESOLUTION
    # ... while a real, consistent difference still gets one
    row = next(r for r in summary if (r["plant"], r["path"], r["metric"], r["controller"])
               == ("peng_servo", "circle", "iae_mm_s", "integrator"))
    assert row["verdict"] == "higher"
    assert (tmp_path / "diamond_error.png").stat().st_size > 0
    assert (tmp_path / "strategies.png").stat().st_size > 0
    # the summary figure draws each strategy's mean in um, coloured by its verdict
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    numeric = [{k: (float(x) if k in ("mean", "ci95_half_width") else x) for k, x in r.items()}
               for r in summary]
    fig, ax = plt.subplots()
    mod.draw_strategy_means(numeric, "circle", "max_error_mm", ax)
    mine = [r for r in numeric if (r["plant"], r["path"], r["metric"]) == (
        "peng_servo", "circle", "max_error_mm")]
    bars = ax.patches
    assert [b.get_width() for b in bars] == pytest.approx([1e3 * r["mean"] for r in mine])
    assert [b.get_facecolor() for b in bars] == [
        to_rgba(mod.VERDICT_COLOURS[r["verdict"]]) for r in mine]
    plt.close(fig)
