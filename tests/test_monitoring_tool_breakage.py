"""Tool-breakage detection (Peng 3.68-3.69) and cutter faults in the geometric model.

Numbers come from closed forms written here (chip scales ``c m + r_j - r_l``, tooth-average
integrals), an independent bin-edge computation, or constructed sequences."""

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from controllers.monitoring.tool_breakage import (  # noqa: E402
    ToolBreakageParams,
    breakage_metrics,
    detect_breakage,
    period_tooth,
    plot_tool_breakage,
    predicted_runout_threshold,
    stream_breakage,
    tooth_period_average_fractional,
)
from plants.cutter_faults import CutterFaults, faulted_forces_vs_time  # noqa: E402
from plants.cutting_coefficients import CuttingCoefficients  # noqa: E402
from plants.end_mill_geometry import EndMill, MillingCut, forces_vs_time  # noqa: E402

SPT = 50  # samples per tooth period
RPM = 600.0
TOOL = EndMill(diameter_mm=16.0, teeth=4, helix_angle_deg=0.0)
CUT = MillingCut(radial_depth_mm=4.0, axial_depth_mm=5.0, feed_per_tooth_mm=0.1, mode="up",
                 spindle_speed_rpm=RPM)  # engagement 60 deg < pitch 90 deg
NO_EDGE = CuttingCoefficients(tangential_edge_N_mm=0.0, radial_edge_N_mm=0.0,
                              axial_edge_N_mm=0.0)
TOOTH_S = 60.0 / (RPM * TOOL.teeth)


def _cut_signal(faults, periods=80, coefficients=NO_EDGE, cut=CUT):
    """Feed force sampled SPT times per tooth period, bins aligned to tooth entry (phi_st = 0
    for up-milling); tooth position k / SPT exactly."""
    k = np.arange(periods * SPT)
    t = k * (TOOTH_S / SPT)
    f = faulted_forces_vs_time(TOOL, cut, coefficients, t, faults).feed_N
    return f, k / SPT


def test_no_fault_equals_the_geometric_model():
    t = np.arange(1000) * 1e-4
    tool = EndMill()
    a = faulted_forces_vs_time(tool, MillingCut(), CuttingCoefficients(), t, CutterFaults())
    b = forces_vs_time(tool, MillingCut(), CuttingCoefficients(), t)
    assert np.array_equal(a.feed_N, b.feed_N) and np.array_equal(a.tangential_N, b.tangential_N)


def test_one_missing_tooth_gives_1_1_0_2_and_the_closed_form_average():
    f, q = _cut_signal(CutterFaults(missing_teeth=(2,)), periods=8)
    period, avg, _ = tooth_period_average_fractional(f, q)
    teeth = period_tooth(period, 4)
    intact = avg[teeth == 0][0]
    expected = {0: 1.0, 3: 1.0, 2: 0.0, 1: 2.0}  # tooth 1 follows the missing tooth 2
    assert np.allclose(avg / intact, [expected[j] for j in teeth], rtol=1e-9, atol=1e-12)
    # closed form of one tooth's mean feed force over a period, edge forces off:
    # a c [K_tc (sin^2 ex - sin^2 st)/2 + K_rc ((ex - st)/2 - (sin 2ex - sin 2st)/4)] / pitch
    ex = math.acos(1 - 4.0 / 8.0)
    closed = 5.0 * 0.1 * (767.0 * math.sin(ex) ** 2 / 2
                          + 168.8 * (ex / 2 - math.sin(2 * ex) / 4)) / (math.pi / 2)
    fine = np.arange(4000) / 4000  # one period, midpoint rule with 4000 samples
    one = faulted_forces_vs_time(TOOL, CUT, NO_EDGE, (fine + 0.5 / 4000) * TOOTH_S,
                                 CutterFaults()).feed_N
    assert one.mean() == pytest.approx(closed, rel=1e-3)  # force jumps at exit: O(1/n)
    assert intact == pytest.approx(closed, rel=2e-2)  # 50 samples, left rectangle rule


def test_runout_chip_scales_follow_the_closed_form():
    r = (0.004, -0.003, 0.002, 0.0)
    f, q = _cut_signal(CutterFaults(runout_mm=r), periods=8)
    period, avg, _ = tooth_period_average_fractional(f, q)
    teeth = period_tooth(period, 4)
    chip = np.array([0.1 + r[j] - r[(j + 1) % 4] for j in range(4)])  # tooth j+1 cut before j
    assert np.allclose(avg / chip[teeth], (avg / chip[teeth])[0], rtol=1e-9)
    # predicted run-out threshold (margin 1) = max |chip_next / chip_prev - 1| in cutting order
    order = [0, 3, 2, 1]
    ratios = [abs(chip[order[(i + 1) % 4]] / chip[order[i]] - 1) for i in range(4)]
    thr = predicted_runout_threshold(TOOL, CUT, NO_EDGE, r, margin=1.0, samples_per_tooth=SPT)
    assert thr == pytest.approx(max(ratios), rel=1e-9)


def test_threshold_depends_on_immersion():
    r = (0.004, -0.003, 0.002, 0.0)
    narrow = predicted_runout_threshold(TOOL, CUT, CuttingCoefficients(), r)
    slot = MillingCut(radial_depth_mm=16.0, axial_depth_mm=5.0, feed_per_tooth_mm=0.1,
                      spindle_speed_rpm=RPM)
    full = predicted_runout_threshold(TOOL, slot, CuttingCoefficients(), r)
    # the feed-force average of a slot is small (up and down halves cancel), so the same
    # runout moves it by a larger fraction: the threshold must follow the immersion
    assert full > 1.5 * narrow > 0


@pytest.mark.parametrize(
    ("rule", "absolute", "alarm"),
    [("first", False, 43), ("first", True, 42), ("first_and_second", False, 44)],
)
def test_alarm_at_the_expected_period_and_not_before(rule, absolute, alarm):
    # tooth 2 breaks while tooth 3 cuts (period 41.5): its next turn, period 42, is empty
    # and tooth 1 doubles in period 43 (periods n are cut by tooth (-n) mod 4)
    faults = CutterFaults(runout_mm=(0.004, -0.003, 0.002, 0.0), broken_teeth=(2,),
                          break_time_s=41.5 * TOOTH_S)
    f, q = _cut_signal(faults)
    params = ToolBreakageParams(threshold=0.5, rule=rule, use_absolute=absolute)
    res = detect_breakage(f, q, params)
    assert res.alarm_period == alarm
    assert np.all(~(res.normalised_difference[res.period < 42] > 0.5))
    if not absolute:
        assert res.suspect_tooth == 1 and (res.suspect_tooth + 1) % 4 == 2  # broken tooth
    again = detect_breakage(3.7 * f, q, params)  # a constant gain changes nothing
    assert again.alarm_period == alarm
    assert np.allclose(again.normalised_difference, res.normalised_difference,
                       rtol=1e-12, equal_nan=True)


def test_intact_cutter_with_runout_and_noise_stays_quiet():
    rng = np.random.default_rng(7)
    f, q = _cut_signal(CutterFaults(runout_mm=(0.004, -0.003, 0.002, 0.0)), periods=400,
                       coefficients=CuttingCoefficients())
    f = f + 5.0 * rng.standard_normal(f.size)  # 1.2 % of the 230 N average per sample
    thr = predicted_runout_threshold(TOOL, CUT, CuttingCoefficients(),
                                     (0.004, -0.003, 0.002, 0.0))
    for params in (ToolBreakageParams(threshold=thr),
                   ToolBreakageParams(threshold_policy="learned", threshold=0.05),
                   ToolBreakageParams(threshold=thr, rule="first_and_second")):
        assert not detect_breakage(f, q, params).alarm


def test_second_difference_separates_breakage_from_a_step():
    step = np.repeat(np.r_[np.ones(20), 1.5 * np.ones(20)], 10)
    pulse = np.repeat(np.r_[np.ones(20), [0.0, 2.0], np.tile([1, 1, 0, 2], 4)], 10)
    for sig, first, confirmed in ((step, 20, -1), (pulse, 21, 22)):
        q = np.arange(sig.size) / 10
        assert detect_breakage(sig, q, ToolBreakageParams(threshold=0.3)).alarm_period == first
        res = detect_breakage(sig, q, ToolBreakageParams(threshold=0.3, rule="first_and_second"))
        assert res.alarm_period == confirmed


def test_fractional_bins_match_independent_edges():
    rng = np.random.default_rng(3)
    spt = 7.3
    x = rng.standard_normal(1000)
    q = np.arange(x.size) / spt + 0.4  # starts inside a period: that period is dropped
    period, avg, closing = tooth_period_average_fractional(x, q)
    k = np.arange(x.size)
    for n, a, c in zip(period, avg, closing, strict=True):
        lo = math.ceil((n - 0.4) * spt - 1e-9)
        hi = math.ceil((n + 1 - 0.4) * spt - 1e-9)
        members = k[(k >= lo) & (k < hi)]
        assert a == pytest.approx(x[members].mean(), rel=1e-12, abs=1e-15)
        assert c == hi
    assert period[0] == 1 and period[-1] == math.floor(q[-1]) - 1


def test_learned_threshold_is_k_sigma_times_the_window_maximum():
    rng = np.random.default_rng(5)
    sig = np.repeat(1 + 0.02 * rng.standard_normal(100), 8)
    q = np.arange(sig.size) / 8
    params = ToolBreakageParams(threshold_policy="learned", settle_periods=3, learn_periods=20,
                                k_sigma=3.0, threshold=0.0)
    res = detect_breakage(sig, q, params)
    avg = sig[::8][:-1]
    window = np.abs(np.diff(avg)[2:22] / avg[2:22])  # periods 3..22 of d'I
    assert np.all(np.isnan(res.threshold[:23]))
    assert res.threshold[23] == pytest.approx(3.0 * window.max(), rel=1e-12)


@pytest.mark.parametrize("policy", ["fixed", "learned", "relative_to_revolution_mean"])
@pytest.mark.parametrize("rule", ["first", "first_and_second"])
def test_streaming_equals_batch_sample_for_sample(policy, rule):
    rng = np.random.default_rng(11)
    spt = 7.3
    q = np.arange(3000) / spt + 0.25
    x = 1 + 0.01 * rng.standard_normal(q.size)
    x[q >= 200] += 0.5 * (np.floor(q[q >= 200]) % 4 == 1)
    params = ToolBreakageParams(threshold=0.2, threshold_policy=policy, rule=rule,
                                learn_periods=20, settle_periods=2)
    res = detect_breakage(x, q, params)
    out = stream_breakage(x, q, params)
    closed = out["closed_period"][0]
    k = np.flatnonzero(closed >= 0)
    assert np.array_equal(k, res.closing_sample)
    assert np.array_equal(closed[k], res.period)
    assert np.array_equal(out["average"][0, k], res.average)
    assert np.array_equal(out["normalised_difference"][0, k], res.normalised_difference,
                          equal_nan=True)
    assert np.array_equal(out["threshold"][0, k], res.threshold, equal_nan=True)
    expected_alarm = np.where(np.arange(q.size) >= (res.closing_sample[res.period
                              == res.alarm_period][0]), res.alarm_period, -1)
    assert np.array_equal(out["alarm_period"][0], expected_alarm)
    assert res.alarm_period == (201 if rule == "first" else 202)


def test_metrics_on_constructed_runs():
    # run 0 detected 2 late; run 1 false alarm before its breakage; run 2 missed;
    # run 3 intact and quiet; run 4 intact with a false alarm
    m = breakage_metrics([52, 30, -1, -1, 90], [50, 60, 40, -1, -1], 0, 199, 0.4,
                         max_delay_periods=4)
    assert np.array_equal(m.detected, [True, False, False, False, False])
    assert np.array_equal(m.false_alarm, [False, True, False, False, True])
    assert np.array_equal(m.missed, [False, False, True, False, False])
    assert m.detection_delay_periods[0] == 2 and np.isnan(m.detection_delay_periods[1:]).all()
    healthy_periods = 50 + 31 + 40 + 200 + 91
    assert m.healthy_cut_m == pytest.approx(healthy_periods * 0.4e-3)
    assert m.false_alarms_per_m == pytest.approx(2 / (healthy_periods * 0.4e-3))


def test_plot_draws_on_the_given_axes():
    pulse = np.repeat(np.r_[np.ones(20), [0.0, 2.0], np.ones(6)], 10)
    res = detect_breakage(pulse, np.arange(pulse.size) / 10, ToolBreakageParams())
    fig, ax = plt.subplots()
    twin = plot_tool_breakage(ax, res, breakage_period=20)
    assert len(ax.lines) == 4 and len(twin.lines) == 1  # diff, threshold, alarm, breakage
    plt.close(fig)
