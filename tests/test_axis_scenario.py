"""Axis scenarios through the command line: files written, numbers from the steady-state
balance, and one-line errors naming the key for every section."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from acc.scenarios.axis import AXIS_SECTIONS
from tests.cli_run import ROOT, acc, assert_one_line_error
from tests.test_axis_servo import _steady_following_error_mm

AXIS_FILE = str(ROOT / "experiments" / "peng_servo_axis.toml")


def _row(path):  # noqa: ANN001, ANN202
    with open(path, encoding="utf-8") as fh:
        return next(csv.DictReader(fh))


def test_run_writes_the_traces_and_the_ramp_error_of_the_balance(tmp_path):
    out = tmp_path / "run"
    r = acc("run", AXIS_FILE, "--out", str(out), "--set", 'cutting_load.kind="none"')
    assert r.status == 0, r.err
    for name in ("summary.csv", "traces.csv", "traces.npz", "response.png"):
        assert (out / name).stat().st_size > 0
    row = _row(out / "summary.csv")
    assert float(row["final_following_error_mm"]) == pytest.approx(
        _steady_following_error_mm(25.0), rel=1e-6
    )
    traces = np.load(out / "traces.npz")
    assert traces["x_mm"].shape == traces["time_s"].shape == (1000,)


def test_analyze_reports_the_velocity_constant_of_the_balance(tmp_path):
    out = tmp_path / "an"
    r = acc("analyze", AXIS_FILE, "--out", str(out))
    assert r.status == 0, r.err
    row = _row(out / "analysis.csv")
    assert float(row["ramp_following_error_mm"]) == pytest.approx(
        _steady_following_error_mm(25.0), rel=1e-9
    )
    assert 0 < float(row["spectral_radius"]) < 1
    assert (out / "analysis.png").stat().st_size > 0


def test_a_combination_without_a_linear_loop_is_named(tmp_path):
    r = acc("analyze", AXIS_FILE, "--out", str(tmp_path / "x"), "--set",
            'position_controller.kind="pid"')
    assert r.status != 0
    assert "not analysable" in r.err
    assert not (tmp_path / "x").exists()


BAD_VALUES = [
    ("simulation.duration_s=0.0005", "simulation.duration_s"),
    ("simulation.control_period_s=0.0015", "simulation.control_period_s"),
    ('axis.kind="linear"', "axis.kind"),
    ("servo_axis.inertia_kg_m2=-1.0", "servo_axis.inertia_kg_m2"),
    ("oscillating_axis.oscillator_frequency_Hz=nan", "oscillating_axis.oscillator_frequency_Hz"),
    ('position_controller.kind="mpc"', "position_controller.kind"),
    ('lead_lag.integrator_form="magic"', "lead_lag.integrator_form"),
    ("pid.max_output=inf", "pid.max_output"),
    ('state_control.source="gyro"', "state_control.source"),
    ('trajectory.kind="spiral"', "trajectory.kind"),
    ("trajectory.start_s=0.0105", "trajectory.start_s"),
    ('cutting_load.kind="torque_ramp"', "cutting_load.kind"),
    ("lead_lag.gian=1.0", "lead_lag.gian"),
]


@pytest.mark.parametrize("assignment, key", BAD_VALUES)
def test_bad_values_are_one_line_errors_naming_the_key(tmp_path, assignment, key):
    out = tmp_path / "bad"
    r = acc("run", AXIS_FILE, "--out", str(out), "--set", assignment)
    assert_one_line_error(r, key)
    assert not out.exists()


def test_every_section_has_a_bad_value_case():
    assert {key.split(".")[0] for _, key in BAD_VALUES} == set(AXIS_SECTIONS)


def test_huron_axis_runs_and_its_kv_limit_is_analysed(tmp_path):
    huron = str(ROOT / "experiments" / "briquez_huron_axis.toml")
    r = acc("run", huron, "--out", str(tmp_path / "run"))
    assert r.status == 0, r.err
    row = _row(tmp_path / "run" / "summary.csv")
    assert abs(float(row["final_following_error_mm"])) < 0.01 * 0.01  # settled on the step
    r = acc("analyze", huron, "--out", str(tmp_path / "an"))
    assert r.status == 0, r.err
    row = _row(tmp_path / "an" / "analysis.csv")
    # K_v = 60 1/s is below the analysed limit with the feedback and the loop converges
    assert float(row["spectral_radius"]) < 1.0 < float(row["kv_limit_1_s"]) / 60.0
    assert float(row["kv_limit_1_s"]) > float(row["kv_limit_without_acceleration_feedback_1_s"])


def _bad_values(tp):  # noqa: ANN001, ANN202
    """Values of the wrong type, and non-finite numbers, for a field type."""
    if tp is float:
        return ["abc", float("nan"), float("inf"), True]
    if tp is int:
        return [0.5, "abc", True]
    if tp is bool:
        return [2, "yes"]
    return [1.0, [1]]


def test_every_key_of_every_section_names_itself_on_a_bad_value():
    from acc.errors import ScenarioError
    from acc.scenarios.axis import axis_scenario_from_dict
    from acc.scenarios.force import field_types

    checked = 0
    for section, cls in AXIS_SECTIONS.items():
        for key, tp in field_types(cls).items():
            for value in _bad_values(tp):
                data = {"simulation": {"model": "axis"}, section: {key: value}}
                if section == "simulation":
                    data["simulation"] = {"model": "axis", key: value}
                with pytest.raises(ScenarioError) as info:
                    axis_scenario_from_dict(data, "f.toml")
                message = str(info.value)
                assert "\n" not in message
                assert f"{section}.{key}" in message, message
                checked += 1
    assert checked > 150
