"""The causal IAE bound of the robust design study: closed forms, and below every simulation."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from acc.design.iae_bound import Event, event_iae_bound, iae_lower_bound, unit_step_response

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

A, K2, P2 = 29.33, 12.57, -3.75  # drive bandwidth, the 3 mm row
B = -P2
L = 0.1


def g(tau):
    """Closed-form unit step response of a K2 / ((s + a)(s + b)) from rest, tau >= 0."""
    return K2 / B * (1.0 - (A * np.exp(-B * tau) - B * np.exp(-A * tau)) / (A - B))


def integral_g(tau):
    """int_0^tau g."""
    return K2 / B * (tau - (A * (1 - np.exp(-B * tau)) / B - B * (1 - np.exp(-A * tau)) / A)
                     / (A - B))


def test_step_response_is_the_closed_form():
    t = np.arange(2000) * 1e-3
    assert np.allclose(unit_step_response(A, K2, P2, 1e-3, 2000), g(t), rtol=1e-9, atol=1e-12)


def test_entry_bound_equals_the_closed_form():
    """From rest, nothing reaches the process before L (error r), then at most u_max:
    bound = r L + int_0^tau* (r - u_max g), tau* where u_max g = r.  The sum at dt = 1e-4 s
    is within r dt of the integral; a bound that ignored the dead time (50 N s less) or the
    drive's lag would be far off."""
    r, u_max, dt = 500.0, 480.0, 1e-4
    tau_star = brentq(lambda tau: u_max * g(tau) - r, 0.0, 5.0)
    want = r * L + r * tau_star - u_max * integral_g(tau_star)
    got = event_iae_bound(Event(at_rest=True), r, A, K2, P2, L, (12.0, u_max), dt, 3.0)
    assert got == pytest.approx(want, abs=r * dt)
    assert want > r * L + 10.0  # the lag's share is not negligible


def test_force_step_bound_equals_the_closed_form():
    """Settled at the reference, a force step d: error d until the first reaction arrives
    (L), then at best the command drops to u_min: d - (u_s - u_min) g until it vanishes."""
    r, d, u_min, dt = 500.0, 100.0, 12.0, 1e-4
    u_s = r * B / K2
    tau_star = brentq(lambda tau: (u_s - u_min) * g(tau) - d, 0.0, 5.0)
    want = d * L + d * tau_star - (u_s - u_min) * integral_g(tau_star)
    event = Event(force_after_N=d)
    got = event_iae_bound(event, r, A, K2, P2, L, (u_min, 480.0), dt, 3.0)
    assert got == pytest.approx(want, abs=r * dt)


def test_feed_step_is_seen_one_dead_time_late():
    """A feed step at the drive's input reaches the process after L; the first reaction to it
    after 2 L: over [L, 2 L] the error is |d_u| g(t - L), fixed; closed form as above."""
    r, du, dt = 500.0, -20.0, 1e-4
    u_s = r * B / K2
    got = event_iae_bound(Event(feed_step_mm_min=du), r, A, K2, P2, L, (u_s, u_s), dt, 3.0)
    # command limits pinned at u_s: no reaction possible, error |du| g(t - L) to the window
    want = -du * integral_g(3.0 - L)
    assert got == pytest.approx(want, abs=r * dt)


def test_feed_step_reaction_starts_two_dead_times_after_the_step():
    """Free limits: |d_u| g(t - L) fixed until 2 L, then the command may rise to u_max:
    error >= |d_u| g(t - L) - (u_max - u_s) g(t - 2 L) while positive (closed form)."""
    r, du, dt, u_max = 500.0, -20.0, 1e-4, 480.0
    u_s = r * B / K2
    tau_star = brentq(lambda tau: -du * g(tau + L) - (u_max - u_s) * g(tau), 1e-9, 5.0)
    want = -du * integral_g(L) + (-du * (integral_g(tau_star + L) - integral_g(L))
                                  - (u_max - u_s) * integral_g(tau_star))
    got = event_iae_bound(Event(feed_step_mm_min=du), r, A, K2, P2, L, (12.0, u_max), dt, 3.0)
    assert got == pytest.approx(want, abs=r * dt)


def test_bound_of_a_scenario_counts_the_hardness_zone_twice():
    from acc.scenarios.force import Scenario

    sc = Scenario().with_values({
        "workpiece.radial_depth_mm": [3.0], "workpiece.segment_length_mm": [30.0],
        "workpiece.axial_depth_mm": [10.0], "controller.override_max": 4.0,
    })
    plain = iae_lower_bound(sc)
    zone = sc.with_values({"disturbance": [{"name": "h", "kind": "hardness",
                                            "gain_multiplier": 1.5, "start_mm": 10.0,
                                            "end_mm": 20.0}]})
    c = sc.controller
    limits = (c.override_min * c.programmed_feed_mm_min, 4.0 * c.programmed_feed_mm_min)
    enter = event_iae_bound(Event(1.0, 1.5), 500.0, A, K2, P2, L, limits, 1e-3)
    leave = event_iae_bound(Event(1.5, 1.0), 500.0, A, K2, P2, L, limits, 1e-3)
    assert iae_lower_bound(zone) == pytest.approx(plain + enter + leave, rel=1e-12)
    assert enter >= 250.0 * L  # the force jumps by r / 2 and nothing can answer for L
    with pytest.raises(ValueError, match="one depth"):
        iae_lower_bound(sc.with_values({"workpiece.radial_depth_mm": [2.0, 3.0],
                                        "workpiece.segment_length_mm": [10.0, 10.0],
                                        "workpiece.axial_depth_mm": [10.0, 10.0]}))


def test_held_force_floor_closed_forms():
    """Sensor bias b from 10 mm of a 30 mm part: b times 20 mm at the feed that makes the
    true force r - b, (r - b)|p2|/K2 [mm/min].  Runout of amplitude A at the spindle
    frequency: (A - (4/pi)|P(jw)| min(u_r - u_min, u_max - u_r)) / 2 for the cut's time at
    u_r = r|p2|/K2 less the entry's window, |P(jw)| from python-control here."""
    import control

    from acc.design.iae_bound import WINDOW_S, held_force_floor
    from acc.scenarios.force import Scenario

    sc = Scenario().with_values({
        "workpiece.radial_depth_mm": [3.0], "workpiece.segment_length_mm": [30.0],
        "workpiece.axial_depth_mm": [10.0], "controller.override_max": 4.0,
    })
    assert held_force_floor(sc) == 0.0
    bias = sc.with_values({"disturbance": [{"name": "b", "kind": "measurement",
                                            "bias_N": 50.0, "start_mm": 10.0}]})
    u_b = (500.0 - 50.0) * B / K2
    assert held_force_floor(bias) == pytest.approx(50.0 * 20.0 / (u_b / 60.0), rel=1e-12)
    runout = sc.with_values({"disturbance": [{"name": "r", "kind": "force",
                                              "shape": "sinusoid", "amplitude_N": 50.0,
                                              "harmonic_of": "spindle"}]})
    w = 2 * math.pi * sc.geometry.spindle_speed_rpm / 60.0
    plant = control.tf([A * K2], np.polymul([1, A], [1, B]))
    gain = abs(complex(control.frequency_response(plant, [w]).complex.ravel()[0]))
    u_r = 500.0 * B / K2
    c = sc.controller
    half = min(u_r - c.override_min * c.programmed_feed_mm_min,
               4.0 * c.programmed_feed_mm_min - u_r)
    left = 50.0 - 4 / math.pi * gain * half
    assert 0 < left < 50.0
    want = left / 2 * (30.0 / (u_r / 60.0) - WINDOW_S)
    assert held_force_floor(runout) == pytest.approx(want, rel=1e-9)


def test_no_simulated_kind_beats_the_bound():
    """Every registered kind (shipped options) on one seed of every cell of the disturbance
    campaign on the soft material (where the bound is tightest: the slowest force rise; the
    other materials' runs are longer and further above it): each run's IAE is at least its
    bound (a bound a simulation beats is a bug)."""
    from robust_design import CAMPAIGN, base_runs, default_kinds, simulate_design

    from acc.campaigns.campaign import load_campaign

    campaign = load_campaign(CAMPAIGN)
    runs = [r for r in base_runs(campaign, 1)
            if campaign.values(r)["force_process.gain_multiplier"] == 0.5]
    bounds = np.array([iae_lower_bound(campaign.scenario(r)) for r in runs])
    assert np.all(bounds > 50.0 - 1e-9)  # at least r L from the entry
    tightest = math.inf
    for kind in default_kinds():
        iae = simulate_design(campaign, runs, {"controller.kind": kind})["iae_N_s"]
        ratio = iae / bounds
        assert np.all(ratio >= 1.0), (kind, float(ratio.min()))
        tightest = min(tightest, float(ratio.min()))
    assert tightest < 2.0  # and not a bound far below every run


def test_pareto_front():
    from robust_design import pareto_front

    robust = np.array([3.0, 2.0, 2.5, 4.0, math.nan])
    p95 = np.array([100.0, 90.0, 95.0, 120.0, 10.0])
    ok = np.array([True, True, False, True, True])
    # design 2 oscillates, 4 is not analysable; 0, 1 and 3 trade robustness for IAE
    assert pareto_front(robust, p95, ok).tolist() == [True, True, False, True, False]
    assert pareto_front(robust, np.array([100.0, 110.0, 95.0, 120.0, 10.0]), ok).tolist() == [
        True, False, False, True, False]


def test_verdict_follows_the_target_and_the_bound():
    """Reached: an adaptive design without oscillation at <= 70 % of the fixed PI's p95;
    impossible: the bound's p95 above 70 %; otherwise not reached."""
    from robust_design import verdict

    def row(design, kind, p95, osc=0):
        return {"design": design, "kind": kind, "p95_iae_N_s": p95, "oscillating_runs": osc}

    rows = [row("pi (co-design)", "pi", 1000.0), row("a", "adaptive_pi", 690.0, osc=1),
            row("b", "adaptive_pi", 710.0)]
    assert "not reached" in verdict(rows, "pi (co-design)", 100.0, 200.0)[-1]
    assert "impossible for any causal" in verdict(rows, "pi (co-design)", 701.0, 800.0)[-1]
    assert "holds the mean" in verdict(rows, "pi (co-design)", 100.0, 701.0)[-1]
    rows[2]["p95_iae_N_s"] = 700.0
    assert "reached by b" in verdict(rows, "pi (co-design)", 100.0, 200.0)[-1]


def test_study_quick_run_writes_its_outputs(tmp_path, capsys):
    from robust_design import main

    assert main(["--out", str(tmp_path), "--quick", "--kinds", "pi", "adaptive_pi"]) == 0
    for name in ("designs.csv", "designs.md", "runs.csv", "verdict.txt", "pareto.png"):
        assert (tmp_path / name).stat().st_size > 0
    text = (tmp_path / "verdict.txt").read_text()
    assert "causal bound: p95" in text and "verdict:" in text


def test_bound_window_ends_with_the_part():
    """A part shorter than the window at the fastest feed: the entry's window is the time
    the part takes at u_max (a window past the part's end counted error after the cut; the
    bound then exceeded the simulated IAE on a soft plant)."""
    from acc.scenarios.force import Scenario

    sc = Scenario().with_values({
        "workpiece.radial_depth_mm": [3.0], "workpiece.segment_length_mm": [24.0],
        "workpiece.axial_depth_mm": [10.0], "controller.override_max": 4.0,
        "force_process.gain_multiplier": 0.2,
    })
    u_max = 4.0 * sc.controller.programmed_feed_mm_min
    window = 24.0 / (u_max / 60.0)
    assert window < 5.0
    limits = (sc.controller.override_min * sc.controller.programmed_feed_mm_min, u_max)
    want = event_iae_bound(Event(at_rest=True), 500.0, A, 0.2 * K2, P2, L, limits, 1e-3, window)
    assert iae_lower_bound(sc) == pytest.approx(want, rel=1e-12)


def test_held_force_floor_of_an_unreachable_reference():
    """A 1.5x hardness zone (8-14 mm) on a plant 10x the nominal static gain: at the lowest
    override the force is 1.5 * 10 G u_min > r, held for the 6 mm at u_min, less the zone
    entry's window (6 mm at u_max); nothing outside the zone (reachable there)."""
    from acc.design.iae_bound import held_force_floor
    from acc.scenarios.force import Scenario

    sc = Scenario().with_values({
        "workpiece.radial_depth_mm": [3.0], "workpiece.segment_length_mm": [24.0],
        "workpiece.axial_depth_mm": [10.0], "controller.override_max": 4.0,
        "force_process.gain_multiplier": 10.0,
    })
    assert held_force_floor(sc) == 0.0
    zone = sc.with_values({"disturbance": [{"name": "h", "kind": "hardness",
                                            "gain_multiplier": 1.5, "start_mm": 8.0,
                                            "end_mm": 14.0}]})
    c = zone.controller
    u_min, u_max = c.override_min * c.programmed_feed_mm_min, 4.0 * c.programmed_feed_mm_min
    held = 1.5 * 10.0 * K2 / B * u_min - 500.0
    assert held > 0
    want = held * (6.0 / (u_min / 60.0) - min(5.0, 6.0 / (u_max / 60.0)))
    assert held_force_floor(zone) == pytest.approx(want, rel=1e-12)
