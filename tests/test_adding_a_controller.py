"""A controller kind added in one module (``tests/pid_kind.py``) reaches everything: scenario
validation, the compiled engine, campaigns, ``acc analyze``, ``acc tune`` and ``acc kinds``.

Numbers from independent computations: with no derivative the PID equals the built-in PI
run for run (a different element, so this checks the wiring, not the code against itself);
with a derivative, the force at the control instants equals python-control's response of
the sampled loop assembled here from the plant (ZOH at the control period, z^-10 delay) and
the PID's transfer function written out below.
"""

import importlib
import sys

import control
import numpy as np
import pytest

from acc.cli.main import main
from acc.engine.element import unregister_element
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario, ScenarioError
from controllers.registry import controller_kinds, resolved_gains, unregister_controller


@pytest.fixture
def pid_kind():
    module = importlib.import_module("tests.pid_kind")
    yield module
    unregister_controller("pid_test")
    unregister_element("controller.pid_test")
    sys.modules.pop("tests.pid_kind", None)


def _constant_depth(**values) -> Scenario:
    base = {
        "workpiece.segment_length_mm": [10_000.0],
        "workpiece.radial_depth_mm": [3.0],
        "workpiece.axial_depth_mm": [10.0],
        "simulation.time_limit_s": 6.0,
        "sensor.noise_std_N": 0.0,
        "sensor.lowpass_cutoff_hz": 0.0,
        "controller.initial_override": 0.0,
        "controller.override_min": 0.0,
        "controller.override_max": 100.0,
    }
    return Scenario().with_values({**base, **values})


def test_the_kind_and_its_keys_are_known_only_once_registered(pid_kind):
    assert "pid_test" in controller_kinds()
    sc = Scenario().with_values({"controller.kind": "pid_test", "controller.pid_kd_s_per_N": 1e-4})
    assert sc.controller.pid_kd_s_per_N == 1e-4
    with pytest.raises(ScenarioError, match=r"pid_derivative_filter_s must be > 0"):
        sc.with_values({"controller.pid_derivative_filter_s": -1.0})


def test_unknown_without_registration():
    assert "pid_test" not in controller_kinds()
    with pytest.raises(ScenarioError, match=r"controller.pid_kd_s_per_N: unknown key"):
        Scenario().with_values({"controller.pid_kd_s_per_N": 1e-4})


def test_without_derivative_it_is_the_pi_run_for_run(pid_kind):
    base = Scenario().with_values(
        {"simulation.time_limit_s": 8.0, "workpiece.segment_length_mm": [4.0, 4.0, 4.0]}
    )
    pi = simulate(base, record_every_steps=7)
    pid = simulate(base.with_values({"controller.kind": "pid_test"}), record_every_steps=7)
    for name in ("force_N", "override"):
        np.testing.assert_array_equal(pid.signal(name), pi.signal(name))
    assert pid.metrics["iae_N_s"][0] == pi.metrics["iae_N_s"][0]


def test_with_derivative_equals_the_sampled_loop_of_python_control(pid_kind):
    kd, tf = 2e-4, 0.03
    sc = _constant_depth(
        **{
            "controller.kind": "pid_test",
            "controller.pid_kd_s_per_N": kd,
            "controller.pid_derivative_filter_s": tf,
        }
    )
    res = simulate(sc)
    tc, m = sc.simulation.control_period_s, sc.simulation.steps_per_control
    g = resolved_gains(sc.controller, sc.nominal_plant, tc)
    a, k2, p2 = 29.33, 12.57, -3.75
    plant = control.c2d(control.tf([a * k2], np.polymul([1, a], [1, -p2])), tc, "zoh")
    delay = control.tf([1], [1] + [0] * 10, tc)
    pid = (
        control.tf([g.kp_per_N], [1], tc)
        + control.tf([g.ki_per_N_s * tc], [1, -1], tc)
        + control.tf([kd, -kd], [tf + tc, -tf], tc)
    )
    closed = control.feedback(120.0 * pid * plant * delay, 1)
    n = 500
    _, y = control.forced_response(closed, np.arange(n) * tc, np.full(n, 500.0))
    f = res.signal("force_N")[0, ::m][:n]
    override = res.signal("override")[0]
    assert 0.0 < np.nanmin(override[m:]) and np.nanmax(override) < 100.0  # no clamp
    np.testing.assert_allclose(f, y, rtol=1e-9, atol=1e-9 * 500)
    # and the derivative changes the response (the test would not pass with kd ignored)
    pi = simulate(_constant_depth()).signal("force_N")[0, ::m][:n]
    assert np.max(np.abs(pi - f)) > 1.0


def test_campaign_analysis_tuning_and_listing_see_it(pid_kind, tmp_path, capsys):
    # analyze: rows for the new kind with its loop's margins
    out = tmp_path / "an"
    args = ["analyze", "experiments/kim_chung_2001.toml", "--out", str(out)]
    assert main([*args, "--kinds", "pi", "pid_test"]) == 0
    text = (out / "analysis.csv").read_text()
    # nominal, three depths and the four corners of the [design] set (gain x dead time)
    assert text.count("pid_test") == 4 + 4
    # kinds: listed with its keys
    assert main(["kinds"]) == 0
    listing = capsys.readouterr().out
    assert "pid_test" in listing and "pid_kd_s_per_N" in listing
    # tune: its tunable keys, never worse than the start
    from acc.design.tuning import tune

    sc = Scenario().with_values(
        {"controller.kind": "pid_test", "controller.pid_kd_s_per_N": 1e-4,
         "sensor.lowpass_cutoff_hz": 0.0}
    )
    res = tune(sc, dead_time_range_s=(0.1, 0.1), max_evaluations=6)
    assert set(res.values) == {
        "controller.kp_per_N", "controller.ki_per_N_s", "controller.pid_kd_s_per_N"
    }
    assert res.cost_s <= res.initial_cost_s + 1e-12


def test_kinds_are_listed_in_one_order_whichever_module_was_imported_first():
    # the registry fills as modules are imported; the listing (acc kinds, the key reference
    # page's "read by") must not depend on which import came first
    import subprocess
    from pathlib import Path

    code = ("import {first}\n"
            "from controllers.registry import controller_kinds\n"
            "print(' '.join(controller_kinds()))")
    listed = []
    for first in ("controllers.filtered_smith_predictor", "controllers.robust_force_controller",
                  "controllers.pi"):
        done = subprocess.run([sys.executable, "-c", code.format(first=first)],
                              capture_output=True, text=True, check=True,
                              cwd=Path(__file__).resolve().parents[1])
        listed.append(done.stdout.split())
    assert listed[0] == listed[1] == listed[2] == [
        "pi", "constant", "adaptive_pi", "dob_pi", "dob_adaptive_pi", "fsp_pi",
        "fsp_adaptive_pi"]
