"""Tool-breakage monitoring inside the force loop (``[tool_breakage]``).

Numbers from: the batch detector :func:`detect_breakage` (a vectorised implementation
independent of the streaming element) on the signal the loop recorded; the breakage's tooth
period from the injected break time and the geometric model's tooth order; the batch
cutter-fault model (NumPy ``CutterFaults.present`` and chip scales) for the faulted force;
force peaks and positions read off the recorded traces."""

import math

import numpy as np
import pytest

from acc.engine.element import output_runs
from acc.engine.simulate import simulate
from acc.scenarios.force import ScenarioError, scenario_from_dict
from controllers.monitoring.breakage_monitor import tooth_position_of_steps
from controllers.monitoring.tool_breakage import detect_breakage
from plants.cutter_faults import CutterFaults, faulted_forces_vs_time
from plants.cutting_coefficients import CuttingCoefficients
from plants.end_mill_geometry import MillingCut
from plants.geometric_process import GeometricForceOutput, GeometricProcessParams

DT = 1e-3
RPM, TEETH = 600.0, 4  # 25 plant steps per tooth period, tooth 0 at the entry at k = 0
BROKEN = 1
BREAK_PERIOD = 143  # a period of tooth 1: (-143) mod 4 = 1


def _scenario(**monitor):
    tb = {"enabled": True, "runout_um": [10.0, -5.0, 0.0, 5.0], **monitor}
    return scenario_from_dict({
        "simulation": {"time_limit_s": 4.5, "seed": 5},
        "feed_drive": {"kind": "servo_axis"},
        "sensor": {"kind": "peng_inverse_model", "lowpass_cutoff_hz": 5.0},
        "geometry": {"enabled": True, "tooth_passing": True, "component": "feed",
                     "spindle_speed_rpm": RPM, "teeth": TEETH},
        "workpiece": {"segment_length_mm": [30.0], "radial_depth_mm": [3.0],
                      "axial_depth_mm": [10.0]},
        "controller": {"kind": "pi", "reference_force_N": 300.0},
        "tool_breakage": tb,
    })


def _batch(result, scenario):
    signal = result.signal("breakage_monitor_signal")[0]
    q = tooth_position_of_steps(np.arange(signal.size), RPM, TEETH, DT, 0.0)  # up milling
    return detect_breakage(signal, q, scenario.tool_breakage.detector(TEETH)), signal


@pytest.mark.parametrize(
    "settings",
    [{}, {"rule": "first_and_second"}, {"current_signal": "resultant_xy"},
     {"signal": "measured_force"}],
)
def test_closed_loop_alarm_is_the_batch_detectors_on_the_recorded_signal(settings):
    assert (-BREAK_PERIOD) % TEETH == BROKEN
    sc = _scenario(broken_tooth=BROKEN, break_time_s=BREAK_PERIOD * 25 * DT, **settings)
    r = simulate(sc)
    m = r.metrics
    batch, _ = _batch(r, sc)
    assert m["breakage_period"][0] == BREAK_PERIOD
    assert batch.alarm_period >= BREAK_PERIOD  # the batch form finds the breakage...
    assert m["breakage_alarm_period"][0] == batch.alarm_period  # ... where the loop did
    assert m["detection_delay_tooth_periods"][0] == batch.alarm_period - BREAK_PERIOD
    assert m["detection_delay_tooth_periods"][0] <= 2  # the double chip follows at once
    assert m["breakage_detected"][0] and not m["breakage_false_alarm"][0]


def test_no_breakage_no_alarm_in_the_loop_nor_in_the_batch_form():
    sc = _scenario()
    r = simulate(sc)
    batch, _ = _batch(r, sc)
    assert batch.alarm_period == -1
    assert r.metrics["breakage_alarm_period"][0] == -1
    assert r.metrics["breakage_period"][0] == -1
    assert not r.metrics["breakage_false_alarm"][0]
    assert r.metrics["false_alarms_per_m"][0] == 0.0
    assert r.metrics["monitored_healthy_cut_m"][0] > 0


def test_false_alarm_rate_and_healthy_length_from_the_traces():
    # a fixed threshold just above the runout's normalised differences (0.048): the current
    # noise crosses it after a while on the intact tool
    sc = _scenario(threshold_policy="fixed", threshold=0.06, use_absolute=True).with_values(
        {"sensor.current_noise_std_A": 0.05})
    r = simulate(sc)
    batch, _ = _batch(r, sc)
    m = r.metrics
    assert batch.alarm_period > 100 and m["breakage_alarm_period"][0] == batch.alarm_period
    assert m["breakage_false_alarm"][0] and not m["breakage_detected"][0]
    position = r.signal("position_mm")[0]
    closing = dict(zip(batch.period.tolist(), batch.closing_sample.tolist(), strict=True))
    start = position[batch.closing_sample[sc.tool_breakage.settle_periods]]
    end = position[closing[batch.alarm_period]]
    assert m["monitored_healthy_cut_m"][0] == pytest.approx((end - start) / 1000.0, rel=1e-12)
    assert m["false_alarms_per_m"][0] == pytest.approx(1000.0 / (end - start), rel=1e-12)


def test_force_peaks_around_the_break_from_the_force_trace():
    sc = _scenario(broken_tooth=BROKEN, break_time_s=BREAK_PERIOD * 25 * DT,
                   overshoot_window_revolutions=3)
    r = simulate(sc)
    f = r.signal("force_N")[0]
    kb = BREAK_PERIOD * 25
    rev = 100  # plant steps per revolution at 600 rpm
    assert r.metrics["breakage_peak_force_N"][0] == np.max(f[kb : kb + 3 * rev])
    whole = (kb // rev) * rev  # the revolutions completed before the break, and its part
    assert r.metrics["healthy_peak_force_N"][0] == np.max(f[whole - 3 * rev : kb])
    after, before = np.max(f[kb : kb + 3 * rev]), np.max(f[whole - 3 * rev : kb])
    assert r.metrics["breakage_overshoot_pct"][0] == pytest.approx(100 * (after / before - 1))
    assert after > 1.2 * before  # the follower tooth takes the broken one's chip


def test_a_break_at_t0_has_no_healthy_peak_nan_not_minus_infinity():
    r = simulate(_scenario(broken_tooth=BROKEN, break_time_s=0.0,
                           overshoot_window_revolutions=3))
    # tooth 1's first period p has (-p) mod 4 = 1: p = 3
    assert r.metrics["breakage_period"][0] == 3
    assert math.isnan(r.metrics["healthy_peak_force_N"][0])  # no healthy window to measure
    assert math.isnan(r.metrics["breakage_overshoot_pct"][0])
    f = r.signal("force_N")[0]  # the window: 3 revolutions (300 steps) from the break, k = 0
    assert r.metrics["breakage_peak_force_N"][0] == np.max(f[:300])


@pytest.mark.parametrize("switch", ["time", "path"])
def test_faulted_force_in_the_loop_equals_the_batch_fault_model(switch):
    """The force element with faults, stepped at a constant chip load, against
    :func:`faulted_forces_vs_time` (NumPy tooth presence and chip scales)."""
    geo = GeometricProcessParams(enabled=True, tooth_passing=True, component="feed",
                                 spindle_speed_rpm=RPM, teeth=TEETH)
    coef = CuttingCoefficients()
    feed = 150.0  # mm/min, held
    n = 400
    k = np.arange(n)
    position = feed / 60.0 * k * DT
    kb = 237
    faults = CutterFaults(runout_mm=(0.01, -0.005, 0.0, 0.005), missing_teeth=(3,),
                          broken_teeth=(BROKEN,),
                          break_time_s=kb * DT if switch == "time" else math.inf,
                          break_path_mm=position[kb] if switch == "path" else math.inf)
    out = GeometricForceOutput(geo, coef, np.array([[3.0, 0.0]]), np.array([[10.0, 0.0]]), DT)
    pp, ps = out.records(np.array([[3.3, 0.0]]), np.array([[-3.75, -3.75]]), np.array([29.33]),
                         faults)
    ps["chip_load_mm_min"] = feed
    loop = np.array([output_runs(pp, ps, [0], [kk], [position[kk]]) for kk in k])[:, :, 0]
    tool = geo.tool
    cut = MillingCut(3.0, 10.0, feed / (TEETH * RPM), "up", RPM)
    ref = faulted_forces_vs_time(tool, cut, coef, k * DT, faults, feedrate_mm_min=feed)
    np.testing.assert_allclose(loop[:, 1], ref.feed_N, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(loop[:, 2], ref.normal_N, rtol=1e-9, atol=1e-9)
    # the break changes the force from the break on, not before
    intact = faulted_forces_vs_time(tool, cut, coef, k * DT,
                                    CutterFaults(runout_mm=faults.runout_mm, missing_teeth=(3,)))
    np.testing.assert_allclose(loop[:kb, 1], intact.feed_N[:kb], rtol=1e-9, atol=1e-9)
    assert np.max(np.abs(loop[kb:, 1] - intact.feed_N[kb:])) > 10.0


@pytest.mark.parametrize(
    ("values", "key"),
    [
        ({"geometry": {"enabled": True}, "tool_breakage": {"enabled": True,
                                                            "signal": "measured_force"}},
         "tool_breakage.enabled"),
        ({"geometry": {"enabled": True, "tooth_passing": True},
          "tool_breakage": {"enabled": True}}, "tool_breakage.signal"),
        ({"geometry": {"enabled": True, "tooth_passing": True},
          "tool_breakage": {"enabled": True, "signal": "measured_force",
                            "runout_um": [1.0, 2.0]}}, "tool_breakage.runout_um"),
        ({"geometry": {"enabled": True, "tooth_passing": True},
          "tool_breakage": {"enabled": True, "signal": "measured_force",
                            "broken_tooth": 4}}, "tool_breakage.broken_tooth"),
        ({"geometry": {"enabled": True, "tooth_passing": True},
          "tool_breakage": {"enabled": True, "signal": "measured_force",
                            "current_signal": "resultant_xy"}}, "tool_breakage.current_signal"),
        ({"tool_breakage": {"break_at": "noon"}}, "tool_breakage.break_at"),
    ],
)
def test_bad_monitor_settings_are_one_line_errors_naming_the_key(values, key):
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(values, source="s.toml")
    assert "\n" not in str(info.value)
    assert str(info.value).startswith(f"s.toml: {key}:")


def test_resultant_current_uses_the_cross_feed_force_through_the_torque_factor():
    from acc.engine.element import step_runs
    from controllers.monitoring.breakage_monitor import (
        BreakageMonitorParams,
        breakage_monitor_records,
    )
    from plants.axis.servo_axis import ServoAxisParams

    axis = ServoAxisParams()
    factor = axis.force_to_torque_m / axis.torque_constant_Nm_A  # [A/N]
    assert factor == pytest.approx(9.45e-4 / 0.3)
    params = BreakageMonitorParams(enabled=True, current_signal="resultant_xy")
    p, s = breakage_monitor_records(params, 4, RPM, DT, np.zeros(2), factor, np.zeros(2),
                                    np.array([1, 1]), np.array([0, 1]))
    current = np.array([1.5, -0.7])
    cross = np.array([400.0, -250.0])
    value, alarm = step_runs(p, s, [0, 0], [0.0, 0.0], [300.0, 300.0], [310.0, 290.0],
                             current, cross)
    np.testing.assert_allclose(value, np.hypot(current, 9.45e-4 / 0.3 * cross), rtol=1e-15)
    np.testing.assert_array_equal(alarm, [-1, -1])
