"""Closed-loop simulator: exactness against python-control, steady state, batching, anti-windup."""

import math

import control
import numpy as np
import pytest

from acc.engine.metrics import constant_feed_time_s, safe_feeds_mm_min
from acc.engine.roots import brentq
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario
from controllers.registry import resolved_gains


def constant_depth(depth_mm: float, time_limit_s: float, **extra) -> Scenario:
    values = {
        "workpiece.segment_length_mm": [10_000.0],
        "workpiece.radial_depth_mm": [depth_mm],
        "workpiece.axial_depth_mm": [10.0],
        "simulation.time_limit_s": time_limit_s,
        "sensor.noise_std_N": 0.0,
        "sensor.lowpass_cutoff_hz": 0.0,
    }
    values.update(extra)
    return Scenario().with_values(values)


def test_linear_loop_equals_python_control_sampled_data_response():
    """Constant depth, no clamp: the force at control instants is the step response of the
    sampled loop F_prog C(z) Pd(z) z^-N / (1 + ...), computed independently with python-control
    (ZOH c2d of Eq. 8 at the control period, delay as z^-10)."""
    sc = constant_depth(
        3.0,
        6.0,
        **{
            "controller.initial_override": 0.0,
            "controller.override_min": 0.0,
            "controller.override_max": 100.0,
        },
    )
    res = simulate(sc)
    tc = sc.simulation.control_period_s
    m = sc.simulation.steps_per_control
    gains = resolved_gains(sc.controller, sc.nominal_plant, tc)
    a, k2, p2 = 29.33, 12.57, -3.75
    plant = control.c2d(control.tf([a * k2], np.polymul([1, a], [1, -p2])), tc, "zoh")
    delay = control.tf([1], [1] + [0] * 10, tc)  # z^-10 = 0.1 s / 0.01 s
    pi = control.tf([gains.kp_per_N, gains.ki_per_N_s * tc - gains.kp_per_N], [1, -1], tc)
    loop = sc.controller.programmed_feed_mm_min * pi * plant * delay
    closed = control.feedback(loop, 1)
    n = 600
    _, y = control.forced_response(closed, np.arange(n) * tc, np.full(n, 500.0))
    f = res.signal("force_N")[0, ::m][:n]
    override = res.signal("override")[0]
    assert 0.0 < override.min() and override.max() < 100.0  # no clamp was active
    np.testing.assert_allclose(f[1:], y[1:], rtol=1e-9, atol=1e-9 * 500)
    assert f[0] == y[0] == 0.0


def test_steady_state_force_equals_reference_on_every_table_depth():
    scs = [constant_depth(d, 25.0) for d in (2.0, 3.0, 4.0)]
    res = simulate(scs, record_every_steps=1000)
    assert not res.metrics["failed"].any()
    final = res.signal("force_N")[:, -1]
    # integral action: the error decays exponentially (slowest closed-loop pole about
    # -1.5 rad/s at 2 mm), so after 24 s it is below 1e-6 N on every Table 1 depth
    np.testing.assert_allclose(final, 500.0, rtol=0, atol=1e-6)


def stepped_scenarios() -> list[Scenario]:
    base = Scenario().with_values(
        {
            "workpiece.segment_length_mm": [3.0, 3.0, 3.0],
            "simulation.time_limit_s": 6.0,
            "simulation.plant_step_s": 0.002,
        }
    )
    return [
        base.with_values({"sensor.noise_std_N": 8.0}),
        base.with_values({"workpiece.radial_depth_mm": [4.0, 2.0, 3.0], "sensor.noise_std_N": 3.0}),
        base.with_values({"feed_drive.dead_time_s": 0.05, "controller.reference_force_N": 400.0}),
        base.with_values({"force_process.gain_multiplier": 1.7, "sensor.noise_std_N": 5.0}),
    ]


def test_batch_of_n_runs_equals_n_single_runs():
    scs = stepped_scenarios()
    batch = simulate(scs)
    for i, sc in enumerate(scs):
        single = simulate(sc, run_ids=[i])
        n = single.time_s.size
        for name in batch.signals:
            np.testing.assert_allclose(
                batch.signal(name)[i, :n], single.signal(name)[0], rtol=1e-12, atol=1e-12
            )
        for name, values in batch.metrics.items():
            np.testing.assert_allclose(values[i], single.metrics[name][0], rtol=1e-12)


def test_same_seed_same_noise_and_other_seed_other_noise():
    sc = stepped_scenarios()[0]
    a = simulate(sc).signal("measured_force_N")
    b = simulate(sc).signal("measured_force_N")
    c = simulate(sc.with_values({"simulation.seed": 7})).signal("measured_force_N")
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    # white noise of the stated size: measured - true over the cut has std close to 8 N
    res = simulate(sc)
    resid = (res.signal("measured_force_N") - res.signal("force_N"))[0]
    assert resid.std() == pytest.approx(8.0, rel=0.05)  # ~3000 samples: 1.3 % std error


def test_metrics_agree_with_a_computation_from_the_trace():
    sc = stepped_scenarios()[1]
    res = simulate(sc)
    dt = sc.simulation.plant_step_s
    f = res.signal("force_N")[0]
    cutting = (res.signal("radial_depth_mm")[0] > 0) & (res.signal("position_mm")[0] < 9.0)
    e = f - 500.0
    assert res.metrics["iae_N_s"][0] == pytest.approx(np.abs(e[cutting]).sum() * dt, rel=1e-12)
    assert res.metrics["rms_error_N"][0] == pytest.approx(
        np.sqrt(np.mean(e[cutting] ** 2)), rel=1e-12
    )
    first_past_end = np.argmax(res.signal("position_mm")[0] >= 9.0)
    assert res.metrics["machining_time_s"][0] == pytest.approx(first_past_end * dt)
    seg2 = res.signal("radial_depth_mm")[0] == 2.0
    assert res.metrics["peak_force_N_seg2"][0] == f[seg2 & cutting].max()


def test_constant_safe_feed_time_matches_simulation_and_never_exceeds_reference():
    sc = Scenario().with_values(
        {"controller.kind": "constant", "sensor.noise_std_N": 0.0, "simulation.time_limit_s": 40.0}
    )
    res = simulate(sc, record_every_steps=None)
    m = res.metrics
    # safe feed = 500 N / max G; the 2 mm row has the largest static gain 10.05/2.35
    assert res.parameters["safe_feed_mm_min"][0] == pytest.approx(500 / (10.05 / 2.35))
    assert m["peak_force_N"][0] <= 500.0 + 1e-9
    assert m["machining_time_s"][0] == pytest.approx(m["conventional_time_s"][0], abs=0.0011)
    assert m["conventional_time_s"][0] == pytest.approx(
        constant_feed_time_s(60.0, 500 / (10.05 / 2.35), 29.33, 0.1), rel=1e-12
    )


def test_safe_feeds_of_a_batch_are_the_reference_over_the_largest_cutting_gain():
    """Every run's safe constant feed, against its definition written here (``r / max G``
    over the segments that cut, ``G > 0``; air segments have ``G = 0``) to the bit, and a
    run without a cutting segment refused as the scalar function refuses it."""
    rng = np.random.default_rng(11)
    gains = rng.uniform(1.0, 30.0, (200, 4))
    gains[rng.uniform(size=gains.shape) < 0.3] = 0.0  # air
    gains[np.all(gains == 0.0, axis=1), 0] = 7.0
    reference = rng.uniform(100.0, 900.0, 200)
    want = [reference[i] / max(g for g in gains[i] if g > 0) for i in range(200)]
    np.testing.assert_array_equal(safe_feeds_mm_min(reference, gains), want)
    gains[17] = 0.0
    with pytest.raises(ValueError):
        safe_feeds_mm_min(reference, gains)


@pytest.mark.parametrize("length_mm", [1e-300, 1e-9, 1e-4, 0.3, 60.0, 1e5])
@pytest.mark.parametrize("bandwidth_rad_s", [0.05, 29.33, 5e3])
def test_constant_feed_time_solves_the_drive_travel_to_rounding(length_mm, bandwidth_rad_s):
    """Newton's root of the travel equation against Brent's method in the time itself,
    converged to rounding (no absolute tolerance), from 1 nm to 100 m at three drive
    bandwidths (and 1e-300 mm, a start far from the root); and the travel at that time is
    the length."""
    feed, dead = 350.0, 0.1
    v, a = feed / 60.0, bandwidth_rad_s

    def travel_mm(t: float) -> float:
        x = a * (t - dead)
        g = x * x * (0.5 - x * (1 / 6 - x * (1 / 24 - x / 120))) if x < 1e-3 else x + math.expm1(-x)
        return v * g / a

    hi = dead + 2.0 * (length_mm / v + 1.0 / a)
    reference = brentq(lambda t: travel_mm(t) - length_mm, dead, hi, xtol=1e-300,
                       rtol=4 * 2.220446049250313e-16, maxiter=2000)
    t = constant_feed_time_s(length_mm, feed, a, dead)
    assert t - dead == pytest.approx(reference - dead, rel=1e-13)
    assert travel_mm(t) == pytest.approx(length_mm, rel=1e-12)



def test_constant_feed_time_over_random_parts_feeds_and_drives():
    """1000 random parts (1 nm to 1 km), feeds and drive bandwidths, log-uniform: every time
    is found and is Brent's converged root to 1e-12 (where g's rounding floor stops Newton's
    steps shrinking, as near x = 1e-3, the loop must still end)."""
    rng = np.random.default_rng(7)
    for _ in range(1000):
        length_mm, feed, a = 10 ** rng.uniform([-6, -2, -2], [6, 5, 4])
        v = feed / 60.0

        def travel_mm(t: float, a: float = a, v: float = v) -> float:
            x = a * t
            g = x * x * (0.5 - x * (1 / 6 - x * (1 / 24 - x / 120))) if x < 1e-3 else (
                x + math.expm1(-x))
            return v * g / a

        hi = 2.0 * (length_mm / v + 1.0 / a)
        reference = brentq(lambda t, s=length_mm: travel_mm(t) - s, 0.0, hi, xtol=1e-300,
                           rtol=4 * 2.220446049250313e-16, maxiter=2000)
        assert constant_feed_time_s(length_mm, feed, a, 0.0) == pytest.approx(
            reference, rel=1e-12), (length_mm, feed, a)



def test_constant_feed_time_of_a_length_that_underflows_is_the_dead_time():
    """a length / v below the smallest double: the travel takes no time after the dead time
    (no 0/0 in Newton's step)."""
    assert constant_feed_time_s(1e-320, 6e13, 1e-10, 0.1) == 0.1


def air_entry(air_mm: float, anti_windup: str) -> Scenario:
    return Scenario().with_values(
        {
            "workpiece.segment_length_mm": [air_mm, 30.0],
            "workpiece.radial_depth_mm": [0.0, 3.0],
            "workpiece.axial_depth_mm": [0.0, 10.0],
            "sensor.noise_std_N": 0.0,
            "simulation.time_limit_s": 30.0,
            "controller.anti_windup": anti_windup,
        }
    )


def excess_after_engagement(res) -> float:
    """Integral of the force above the reference after engagement [N s]."""
    f = res.signal("force_N")[0]
    return float(np.clip(f - 500.0, 0, None).sum() * 0.001)


def test_anti_windup_long_clamp_stay_gives_the_same_entry_as_a_short_one():
    """During an air cut the override sits at its clamp.  With clamping anti-windup the
    excess force after engagement does not depend on how long the clamp lasted (integrator
    frozen); without it, a 10 s stay winds the integrator up and the force stays high."""
    short = simulate(air_entry(8.0, "clamping"))  # 2 s at 240 mm/min
    long = simulate(air_entry(40.0, "clamping"))  # 10 s
    e_short, e_long = excess_after_engagement(short), excess_after_engagement(long)
    assert e_long == pytest.approx(e_short, rel=0.01)
    assert long.metrics["peak_force_N"][0] == pytest.approx(
        short.metrics["peak_force_N"][0], rel=0.01
    )
    wound = simulate(air_entry(40.0, "none"))
    assert excess_after_engagement(wound) > 3.0 * e_long


def test_dataframe_export_holds_the_signals_and_the_summary_rows():
    from acc.scenarios.force import load_scenario
    from tests.cli_run import SHIPPED

    sc = load_scenario(SHIPPED).with_values(
        {"simulation.plant_step_s": 0.002, "simulation.time_limit_s": 0.5})
    result = simulate([sc, sc.with_values({"controller.reference_force_N": 400.0})],
                      record_every_steps=5, run_ids=[7, 8])
    traces = result.to_dataframe()
    n = len(result.time_s)
    assert len(traces) == 2 * n and list(traces.columns[:2]) == ["run", "time_s"]
    second = traces[traces["run"] == 8]
    np.testing.assert_array_equal(second["force_N"].to_numpy(), result.signal("force_N")[1])
    np.testing.assert_array_equal(second["time_s"].to_numpy(), result.time_s)
    summary = result.to_dataframe("metrics")
    assert list(summary["run"]) == [7, 8]
    assert list(summary.columns) == list(result.summary_rows()[0])
    assert summary["reference_force_N"].tolist() == [sc.controller.reference_force_N, 400.0]
    np.testing.assert_array_equal(summary["rms_error_N"], result.metrics["rms_error_N"])
    with pytest.raises(ValueError, match="what must be"):
        result.columns("trace")
