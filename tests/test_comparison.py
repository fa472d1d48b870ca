"""Controller comparison: table rows are the runs' metrics; on a 3x harder material the
analysis and the comparison agree on which controller holds the force."""

import numpy as np
import pytest

from acc.design.analysis import is_stable, loop_spec, sampled_closed_loop
from acc.design.comparison import TABLE_METRICS, compare
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario


def hard_4mm() -> Scenario:
    return Scenario().with_values(
        {
            "workpiece.segment_length_mm": [1000.0],
            "workpiece.radial_depth_mm": [4.0],
            "workpiece.axial_depth_mm": [10.0],
            "force_process.gain_multiplier": 3.0,
            "sensor.noise_std_N": 0.0,
            "sensor.lowpass_cutoff_hz": 20.0,
            "simulation.time_limit_s": 20.0,
            "simulation.plant_step_s": 0.002,
        }
    )


def test_table_rows_are_the_metrics_of_each_run_simulated_alone():
    sc = hard_4mm().with_values({"simulation.time_limit_s": 3.0})
    comp = compare(sc, kinds=("pi", "dob_adaptive_pi"), gain_multipliers=(1.0, 3.0), seeds=2)
    rows = comp.table()
    assert [(r["controller"], r["gain_multiplier"], r["seed"]) for r in rows] == [
        ("pi", 1.0, 0),
        ("dob_adaptive_pi", 1.0, 0),
        ("pi", 1.0, 1),
        ("dob_adaptive_pi", 1.0, 1),
        ("pi", 3.0, 0),
        ("dob_adaptive_pi", 3.0, 0),
        ("pi", 3.0, 1),
        ("dob_adaptive_pi", 3.0, 1),
    ]
    i = comp.run("dob_adaptive_pi", 3.0, seed=1)
    alone = simulate(
        sc.with_values(
            {"controller.kind": "dob_adaptive_pi", "force_process.gain_multiplier": 3.0}
        ),
        noise_ids=[3],  # multiplier index 1 x 2 seeds + seed 1
        record_every_steps=None,
    )
    for m in TABLE_METRICS:
        np.testing.assert_allclose(rows[i][m], float(alone.metrics[m][0]), rtol=1e-12)


def test_hard_material_fixed_pi_oscillates_and_adaptive_pi_holds_as_analysis_says():
    sc = hard_4mm()
    # analysis (sampled loop, exact delay): the fixed PI on 3 x the 4 mm plant is unstable,
    # the adaptive PI with a converged estimate is not
    spec = loop_spec(sc, 4.0, kind="pi")
    assert not is_stable(sampled_closed_loop(spec))
    assert is_stable(sampled_closed_loop(loop_spec(sc, 4.0, kind="adaptive_pi")))
    comp = compare(
        sc, kinds=("pi", "adaptive_pi"), gain_multipliers=(3.0,), seeds=1, record_every_steps=5
    )
    f = comp.result.signal("force_N")
    last = comp.result.time_s >= 15.0
    swing_pi = np.ptp(f[comp.run("pi", 3.0), last])
    swing_adaptive = np.ptp(f[comp.run("adaptive_pi", 3.0), last])
    assert swing_pi > 0.2 * 500.0  # a sustained oscillation (held by the override clamps)
    assert swing_adaptive < 0.02 * 500.0  # settled within the 2 % band


def test_kinds_compared_see_the_same_noise_bit_for_bit():
    """Common random numbers: over an air approach the force is exactly 0, so the measured
    force is the sensor noise itself (no filter); it must be the same array for every kind,
    and differ between seeds."""
    sc = Scenario().with_values(
        {
            "workpiece.segment_length_mm": [2.0, 5.0],
            "workpiece.radial_depth_mm": [0.0, 3.0],
            "workpiece.axial_depth_mm": [10.0, 10.0],
            "sensor.noise_std_N": 5.0,
            "sensor.lowpass_cutoff_hz": 0.0,
            "simulation.time_limit_s": 3.0,
        }
    )
    comp = compare(sc, kinds=("pi", "dob_adaptive_pi", "constant"), seeds=2, record_every_steps=1)
    res = comp.result
    depth = res.signal("radial_depth_mm")
    air = np.all(depth == 0.0, axis=0) & np.isfinite(depth).all(axis=0)
    assert air.sum() > 500
    y = res.signal("measured_force_N")[:, air]
    assert np.all(res.signal("force_N")[:, air] == 0.0)
    for seed in range(2):
        runs = [comp.run(k, seed=seed) for k in comp.kinds]
        for r in runs[1:]:
            np.testing.assert_array_equal(y[r], y[runs[0]])
    assert not np.array_equal(y[comp.run("pi", seed=0)], y[comp.run("pi", seed=1)])


def test_paired_statistics_against_an_independent_computation():
    """Mean, t interval and paired difference as scipy.stats computes them."""
    from scipy import stats

    from acc.design.paired import paired_comparison

    rng = np.random.default_rng(4)
    base = rng.normal(100.0, 5.0, 12)
    better = base - 3.0 + rng.normal(0.0, 0.5, 12)
    same = base + rng.normal(0.0, 5.0, 12)
    rows = {r.kind: r for r in paired_comparison({"pi": base, "a": better, "b": same}, "pi")}
    lo, hi = stats.t.interval(0.95, 11, loc=base.mean(), scale=stats.sem(base))
    assert rows["pi"].mean.low == pytest.approx(lo, rel=1e-12)
    assert rows["pi"].mean.high == pytest.approx(hi, rel=1e-12)
    d = better - base
    lo, hi = stats.t.interval(0.95, 11, loc=d.mean(), scale=stats.sem(d))
    assert rows["a"].difference.low == pytest.approx(lo, rel=1e-12)
    assert rows["a"].verdict == "lower"
    # a paired t-test agrees with the verdicts
    assert stats.ttest_rel(better, base).pvalue < 0.05
    assert stats.ttest_rel(same, base).pvalue >= 0.05
    assert rows["b"].verdict == "no significant difference"


def test_a_difference_below_the_resolution_gets_no_verdict():
    """A constant paired difference of 1e-10 (rounding between two equal laws) has a zero-width
    interval that excludes 0, but is no difference; a real constant one still is."""
    from acc.design.paired import paired_comparison

    base = np.random.default_rng(7).uniform(0.02, 0.03, 8)  # e.g. line errors in mm
    values = {"base": base, "rounding": base + 1e-10, "real": base + 1e-3,
              "real_lower": base - 1e-3}
    rows = {r.kind: r for r in paired_comparison(values, "base")}
    assert rows["rounding"].difference.excludes_zero  # the interval alone would call it
    assert rows["rounding"].verdict == "no significant difference"
    assert rows["rounding"].below_resolution
    assert rows["rounding"].resolution == pytest.approx(1e-6 * np.abs(base + 1e-10).mean())
    assert rows["real"].verdict == "higher"
    assert rows["real_lower"].verdict == "lower"
    # an absolute resolution above a real difference withholds its verdict
    rows = {r.kind: r for r in paired_comparison(values, "base", abs_resolution=2e-3)}
    assert rows["real"].verdict == "no significant difference"
    with pytest.raises(ValueError, match="abs_resolution"):
        paired_comparison(values, "base", abs_resolution=-1.0)
