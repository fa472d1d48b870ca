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
    status = main(["tune", str(src), "--out", str(out), "--max-evaluations", "4",
                   "--dead-time-range-s", "0.1", "0.1"])
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
