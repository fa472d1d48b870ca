"""Worst-case tuning: never worse than the start, respects the margin, writes a valid file."""

import pytest

from acc.design.tuning import tune, worst_case, write_scenario_toml
from acc.scenario import Scenario, load_scenario


def test_tune_improves_and_round_trips(tmp_path):
    sc = Scenario().with_values(
        {
            "sensor.lowpass_cutoff_hz": 0.0,
            "force_process.radial_depth_mm": [2.0, 4.0],
            "force_process.k2_N_min_per_mm_s": [10.05, 20.11],
            "force_process.p2_rad_s": [-2.35, -5.35],
            "workpiece.radial_depth_mm": [2.0, 4.0, 4.0],
        }
    )
    res = tune(sc, min_phase_margin_deg=45.0, dead_time_range_s=(0.1, 0.1), max_evaluations=8)
    # the result is the best point seen, the start included
    assert res.cost_s <= res.initial_cost_s + 1e-12
    # recomputed independently from the written gains
    from acc.design.tuning import _specs

    iae, pm = worst_case(_specs(res.scenario, (0.1,)))
    assert iae == pytest.approx(res.cost_s, rel=1e-12)
    path = tmp_path / "tuned.toml"
    write_scenario_toml(path, res.scenario)
    back = load_scenario(path)
    assert back.controller.kp_per_N == res.values["controller.kp_per_N"]
    assert back == res.scenario


def test_acc_tune_writes_a_scenario_that_reads_back_equal(tmp_path, capsys):
    """The TOML round trip of a tuned scenario of an observer kind, with every kind of
    value a scenario holds (floats, integers, booleans, strings, lists, option keys)."""
    import tomllib

    from acc.cli.main import main

    src = tmp_path / "start.toml"
    write_scenario_toml(
        src,
        Scenario().with_values(
            {
                "controller.kind": "dob_adaptive_pi",
                "controller.dob_disturbance_limit_mm_min": 30.0,
                "controller.estimator": "kalman",
                "force_process.radial_depth_mm": [3.0],
                "force_process.k2_N_min_per_mm_s": [12.57],
                "force_process.p2_rad_s": [-3.75],
                "workpiece.radial_depth_mm": [3.0, 0.0, 3.0],
                "geometry.tooth_passing": True,
                "geometry.teeth": 3,
                "simulation.seed": 7,
            }
        ),
    )
    out = tmp_path / "tuned.toml"
    # the observer loop has 34 deg at the start: a 30 deg constraint can be met
    status = main(["tune", str(src), "--out", str(out), "--max-evaluations", "4",
                   "--dead-time-range-s", "0.1", "0.1", "--min-phase-margin-deg", "30"])
    assert status == 0
    text = out.read_text(encoding="utf-8")
    assert text.startswith(f"# acc tune {src}: worst-case IAE")
    tuned = load_scenario(out)
    values = tomllib.loads(text)
    assert values == tuned.to_dict()  # every key resolved, nothing lost or added
    assert tuned.controller.estimator == "kalman" and tuned.geometry.teeth == 3
    assert tuned.controller.dob_tau_s == values["controller"]["dob_tau_s"]
    assert load_scenario(src).with_values(
        {f"controller.{k}": values["controller"][k] for k in ("kp_per_N", "ki_per_N_s",
                                                                "dob_tau_s")}
    ) == tuned


def test_casadi_tuner_improves_a_poor_start_and_meets_every_constraint():
    """From gains 8x too small, the worst IAE over the plant set (the sampled loops the
    simulator runs) must fall by at least 60 %; |S| and |T|, recomputed here on a finer grid
    from acc's own closed-loop objects, stay within the bounds; every loop is stable."""
    import control
    import numpy as np

    from acc.design.analysis import is_stable, loop_spec, sampled_closed_loop
    from acc.design.robust_tuning import plant_set, robust_tune

    sc = Scenario().with_values({"sensor.lowpass_cutoff_hz": 0.0})
    nominal = loop_spec(sc)
    poor = {"kp_per_N": nominal.kp_per_N / 8, "ki_per_N_s": nominal.ki_per_N_s / 8}
    res = robust_tune(sc, max_sensitivity=2.0, max_complementary_sensitivity=1.5,
                      material_range=(0.8, 1.25), dead_time_range_s=(0.1, 0.1), start=poor)
    assert res.iae_s <= 0.4 * res.initial_iae_s
    start_scenario = sc.with_values({f"controller.{k}": v for k, v in poor.items()})
    iae0, _ = worst_case(plant_set(start_scenario, (0.8, 1.25), (0.1, 0.1)))
    assert res.initial_iae_s == pytest.approx(iae0, rel=1e-12)  # the true start, no penalty
    omega = np.logspace(-4, np.log10(0.999 * np.pi / 0.01), 4000)
    for spec in plant_set(res.scenario, (0.8, 1.25), (0.1, 0.1)):
        cl = sampled_closed_loop(spec)
        assert is_stable(cl)
        t = np.asarray(control.frequency_response(cl, omega).complex).ravel()
        assert np.abs(1 - t).max() <= 2.0 * 1.01
        assert np.abs(t).max() <= 1.5 * 1.01


@pytest.mark.parametrize(
    "options",
    [["--max-sensitivity", "1.001"],  # casadi (pi)
     ["--method", "nelder-mead", "--min-phase-margin-deg", "80", "--max-evaluations", "3"]],
)
def test_acc_tune_exits_1_in_one_line_when_the_constraints_cannot_be_met(tmp_path, options):
    from tests.cli_run import SHIPPED, acc

    out = tmp_path / "t.toml"
    r = acc("tune", SHIPPED, "--out", str(out), *options)
    assert r.status == 1
    errors = [line for line in r.err_lines if "cannot be met" in line or "no gains meet" in line]
    assert len(errors) == 1
    assert not out.exists()
