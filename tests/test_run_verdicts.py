"""Per-run verdicts of the force loop one can trust: oscillation (sustained, per stretch
between known events, no revolution average without a spindle-periodic force), held
overload, and the metrics that measure control (peak ratios, excess IAE over the causal
bound).

The synthetic tests step the compiled metrics element on force traces built here; the
others simulate ``pi`` scenarios (the compiled kind the rest of the suite uses).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from acc.design.iae_bound import unavoidable_iae_N_s
from acc.engine.element import step_runs
from acc.engine.metrics import metrics_records, metrics_result, revolution_steps
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[1]
R = 500.0  # reference [N]
DT = 0.01  # plant step of the synthetic traces [s] (the element takes it as a parameter)
W = 2.0  # oscillation window [s]
THRESHOLD = 50.0  # AC amplitude threshold [N]
RHO = 0.5  # oscillation_decay_ratio


def _verdicts(forces: np.ndarray, *, events=None, positions=None, rho: float = RHO,
              tolerance_pct: float = 10.0) -> dict[str, np.ndarray]:
    """Step the metrics element over force traces ``forces`` (runs, n), one cutting segment
    of a part finished at the last sample; ``positions`` (n,) the tool position [mm]."""
    runs, n = forces.shape
    params, state = metrics_records(
        np.full(runs, R), np.array([[True, False]] * runs), np.full(runs, 2.0),
        np.full(runs, 100.0), DT, W, np.inf, THRESHOLD, n, 1, rho, tolerance_pct, events,
    )
    for k in range(n):
        inputs = [np.full(runs, k), forces[:, k], np.zeros(runs, np.int64),
                  np.full(runs, k == n - 1)]
        if positions is not None:
            inputs.append(np.full(runs, positions[k]))
        step_runs(params, state, *inputs)
    return metrics_result(params, state, 1)


def _amplitude(e: np.ndarray) -> float:
    """AC amplitude sqrt(2 var) of a window of samples [N] (the verdict's definition)."""
    return math.sqrt(2.0 * np.var(e))


# --- a. a transient that decays is not an oscillation ------------------------------------


@pytest.mark.parametrize("factor", [0.8, 1.25])
def test_damped_sinusoid_flagged_iff_decay_rate_below_the_boundary(factor):
    """e = A_end exp(sigma (T - t)) sin(w t): the amplitude at the end is A_end > threshold,
    so only the decay rule decides.  Windows of W with w W a multiple of pi hold
    A_last / A_before = exp(-sigma W) (checked on the samples), so the boundary is
    sigma* = ln(1 / rho) / W; factor 0.8 (ratio rho^0.8 = 0.57) is flagged, 1.25 (ratio
    rho^1.25 = 0.42) is not.  Without the decay rule (rho -> 0) both are flagged."""
    sigma = factor * math.log(1.0 / RHO) / W
    T, w, a_end = 8.0, 2 * math.pi * 5.0, 150.0
    t = np.arange(int(round(T / DT)) + 1) * DT
    e = a_end * np.exp(sigma * (T - t)) * np.sin(w * t)
    m = int(round(W / DT))
    ratio = _amplitude(e[-m:]) / _amplitude(e[-2 * m:-m])
    assert ratio == pytest.approx(math.exp(-sigma * W), rel=0.02)  # the closed form holds
    got = _verdicts(np.vstack([R + e, R + e]), rho=RHO)
    assert bool(got["oscillating"][0]) == (factor < 1.0)
    no_rule = _verdicts((R + e)[None, :], rho=1e-9)
    assert bool(no_rule["oscillating"][0])


@pytest.mark.parametrize("sigma", [0.0, -0.2])
def test_sustained_or_growing_cycle_is_flagged(sigma):
    """A limit cycle (sigma = 0) and a growing oscillation are flagged; the amplitude
    reported is the smaller window's, sqrt(2 var) computed here on the same windows to
    within the blocks' few-sample offset (2 %)."""
    T, w, a0 = 8.0, 2 * math.pi * 3.0, 120.0
    t = np.arange(int(round(T / DT)) + 1) * DT
    e = a0 * np.exp(-sigma * t) * np.sin(w * t)
    got = _verdicts((R + e)[None, :])
    m = int(round(W / DT))
    want = min(_amplitude(e[-m:]), _amplitude(e[-2 * m:-m]))
    assert bool(got["oscillating"][0])
    assert got["limit_cycle_amplitude_N"][0] == pytest.approx(want, rel=0.02)


def test_known_event_restarts_the_judgement():
    """A slow transient (sigma = 0.5 1/s, 1.5 Hz) started by a zone exit 2.4 s before the
    end of the part: the window before holds 0.4 s of it, so its amplitude is no larger than
    the last window's and, judged on the last two windows, it would be flagged (checked on
    the samples with the rule's own definition).  Told of the event (the tool position of
    the zone's end), the metrics judge the stretch before it (quiet) and not the 2.4 s after
    it (less than three windows)."""
    T, t_event, sigma, w, a0 = 10.0, 7.6, 0.5, 2 * math.pi * 1.5, 200.0
    t = np.arange(int(round(T / DT)) + 1) * DT
    e = np.where(t >= t_event, a0 * np.exp(-sigma * (t - t_event))
                 * np.sin(w * (t - t_event)), 0.0)
    m = int(round(W / DT))
    last, before = _amplitude(e[-m:]), _amplitude(e[-2 * m:-m])
    assert last > THRESHOLD and before > THRESHOLD and last >= RHO * before
    position = 2.0 * t  # 2 mm/s: the event at 15.2 mm
    blind = _verdicts((R + e)[None, :], positions=position)
    assert bool(blind["oscillating"][0])
    told = _verdicts((R + e)[None, :], positions=position, events=[([2.0 * t_event], [])])
    assert not bool(told["oscillating"][0])
    # the same event given as a plant step
    timed = _verdicts((R + e)[None, :], events=[([], [int(round(t_event / DT))])])
    assert not bool(timed["oscillating"][0])


def test_a_limit_cycle_before_an_event_is_still_flagged():
    """A limit cycle of 6.5 s (more than three windows) that stops at an event (the force
    then at the reference) is judged when the event comes: flagged."""
    T, t_event, w, a0 = 10.0, 6.5, 2 * math.pi * 2.0, 120.0
    t = np.arange(int(round(T / DT)) + 1) * DT
    e = np.where(t < t_event, a0 * np.sin(w * t), 0.0)
    assert not bool(_verdicts((R + e)[None, :])["oscillating"][0])  # blind: the end is quiet
    told = _verdicts((R + e)[None, :], events=[([], [int(round(t_event / DT))])])
    assert bool(told["oscillating"][0])


@pytest.mark.parametrize("revolution", [1, 7])
def test_the_first_block_is_judged_after_a_window_and_a_revolution_of_cutting(revolution):
    """The first window after entering a segment is its entry transient, and a spindle
    average needs a revolution of errors first (module docstring): with blocks of
    ``B = W / 4`` steps, the first block is complete after ``4 B + revolution + B`` cutting
    steps, and not one step before."""
    b = int(round(W / DT / 4))
    n = 4 * b + revolution + b
    params, state = metrics_records(
        np.full(1, R), np.array([[True, False]]), np.full(1, 2.0), np.full(1, 100.0), DT, W,
        np.inf, THRESHOLD, 10 * n, revolution,
    )
    for k in range(n):
        assert state["blocks"][0] == 0
        step_runs(params, state, np.full(1, k), np.full(1, R + 1.0), np.zeros(1, np.int64),
                  np.full(1, False))
    assert state["blocks"][0] == 1


# --- c. a force held above the reference is an overload ----------------------------------


@pytest.mark.parametrize("delta_pct", [1.0, -1.0])
def test_held_force_above_the_tolerance_is_an_overload(delta_pct):
    """A force held at r (1 + (tol + delta) / 100) after the entry window, with a ripple of
    zero mean over every window: held overload iff delta > 0; held_force_ratio is the held
    level over r."""
    tol, T = 10.0, 6.0
    t = np.arange(int(round(T / DT)) + 1) * DT
    level = R * (1 + (tol + delta_pct) / 100.0)
    force = np.where(t < W, R, level) + 5.0 * np.sin(2 * math.pi * 2.0 * t)
    got = _verdicts(force[None, :], tolerance_pct=tol)
    assert bool(got["held_overload"][0]) == (delta_pct > 0)
    assert bool(got["overload"][0]) == (delta_pct > 0)
    assert got["held_force_ratio"][0] == pytest.approx(level / R, abs=1e-3)


# --- scenarios -----------------------------------------------------------------------------


def _hard_part(**values) -> Scenario:
    """One 4 mm depth, material three times the table's: the fixed PI limit-cycles."""
    return Scenario().with_values({
        "workpiece.radial_depth_mm": [4.0], "workpiece.segment_length_mm": [15.0],
        "workpiece.axial_depth_mm": [10.0], "force_process.gain_multiplier": 3.0,
        "controller.override_max": 4.0, "simulation.time_limit_s": 40.0, **values,
    })


def test_limit_cycle_verdict_does_not_depend_on_a_disabled_spindle():
    """Geometry disabled and no spindle harmonic: no revolution average, so the verdict and
    amplitude are the same at 100 and 10000 rpm (at 100 rpm a 0.6 s average would hide the
    cycle).  A spindle harmonic disturbance brings the average back: one revolution."""
    slow, fast = _hard_part(**{"geometry.spindle_speed_rpm": 100.0}), _hard_part(
        **{"geometry.spindle_speed_rpm": 10000.0})
    assert revolution_steps(slow) == revolution_steps(fast) == 1
    res = simulate([slow, fast], record_every_steps=None)
    osc, amp = res.metrics["oscillating"], res.metrics["limit_cycle_amplitude_N"]
    assert bool(osc[0]) and bool(osc[1])
    assert amp[0] == amp[1]
    runout = slow.with_values({"disturbance": [{"name": "r", "kind": "force",
                                                "shape": "sinusoid", "amplitude_N": 10.0,
                                                "harmonic_of": "spindle"}]})
    dt = slow.simulation.plant_step_s
    assert revolution_steps(runout) == round(60.0 / (100.0 * dt))


def test_dead_time_overload_gets_no_productivity():
    """Kim & Chung's part with 5 s of dead time: the force sits far above the reference
    for seconds.  Held overload, overload, no productivity; the recorded trace has a window
    of W whose mean force exceeds r (1 + tol); peak ratios are the peaks over r."""
    sc = load_scenario(ROOT / "experiments" / "kim_chung_2001.toml").with_values(
        {"feed_drive.dead_time_s": 5.0, "nominal_plant.dead_time_s": 5.0})
    res = simulate(sc, record_every_steps=1)
    m = res.metrics
    assert bool(m["held_overload"][0]) and bool(m["overload"][0])
    assert math.isnan(m["productivity_gain_pct"][0])
    f = res.signal("force_N")[0]
    f = f[np.isfinite(f) & (res.signal("radial_depth_mm")[0] > 0)]
    n = int(round(W / sc.simulation.plant_step_s))
    means = np.convolve(f, np.ones(n) / n, mode="valid")
    tol = sc.metrics.overload_tolerance_pct / 100.0
    assert means.max() > R * (1 + tol)
    assert 1 + tol < m["held_force_ratio"][0] <= means.max() / R + 1e-9
    assert m["peak_force_ratio"][0] == pytest.approx(f.max() / R, rel=1e-12)
    assert m["entry_peak_ratio_seg1"][0] == pytest.approx(m["peak_force_N_seg1"][0] / R,
                                                           rel=1e-12)


# --- excess IAE over the causal bound ------------------------------------------------------

A, K2, B, L = 29.33, 12.57, 3.75, 0.1  # drive, the 3 mm row, dead time


def _g(tau: float) -> float:
    """Closed-form unit step response of K2 a / ((s + a)(s + b)) from rest."""
    return K2 / B * (1.0 - (A * math.exp(-B * tau) - B * math.exp(-A * tau)) / (A - B))


def _entry_bound(u_max: float, window: float) -> float:
    """r L + int_0^{window - L} max(0, r - u_max g) (test_robust_design's closed form)."""
    tau = min(brentq(lambda x: u_max * _g(x) - R, 0.0, 5.0), window - L)
    return R * L + quad(lambda x: R - u_max * _g(x), 0.0, tau)[0]


def _part(**values) -> Scenario:
    return Scenario().with_values({
        "workpiece.radial_depth_mm": [3.0], "workpiece.segment_length_mm": [30.0],
        "workpiece.axial_depth_mm": [10.0], "metrics.excess_iae": True, **values,
    })


def test_excess_iae_is_the_iae_above_the_closed_form_bound():
    """A force step of 100 N at 10 mm: the entry's window ends at the step (10 mm at the
    fastest feed, u_max / 60), the step's after 5 s; the unavoidable IAE is the two closed
    forms (the step: d L + int max(0, d - (u_s - u_min) g)); excess = IAE - that, to r dt
    per event (sum against integral)."""
    sc = _part(disturbance=[{"name": "s", "kind": "force", "amplitude_N": 100.0,
                             "start_mm": 10.0}])
    c = sc.controller
    u_max, u_min = c.override_max * c.programmed_feed_mm_min, (
        c.override_min * c.programmed_feed_mm_min)
    u_s, d = R * B / K2, 100.0
    tau = brentq(lambda x: (u_s - u_min) * _g(x) - d, 0.0, 4.0)
    step = d * L + quad(lambda x: d - (u_s - u_min) * _g(x), 0.0, tau)[0]
    want = _entry_bound(u_max, 10.0 / (u_max / 60.0)) + step
    tolerance = 2 * R * sc.simulation.plant_step_s
    assert unavoidable_iae_N_s(sc) == pytest.approx(want, abs=tolerance)
    m = simulate(sc, record_every_steps=None).metrics
    assert m["excess_iae_N_s"][0] == pytest.approx(m["iae_N_s"][0] - want, abs=tolerance)
    assert m["excess_iae_N_s"][0] > 0


def test_held_force_floor_counts_only_with_integral_action():
    """A sensor bias b = 50 N from 10 mm (not an event of the bound): the entry's window is
    5 s; a kind with integral action holds the measured force at r, so the true force sits
    at r - b for the 20 mm left at u_b = (r - b) b_pole / K2: floor b 20 / (u_b / 60).
    The constant feed holds nothing: its unavoidable IAE is the entry's alone."""
    sc = _part(disturbance=[{"name": "b", "kind": "measurement", "bias_N": 50.0,
                             "start_mm": 10.0}])
    c = sc.controller
    entry = _entry_bound(c.override_max * c.programmed_feed_mm_min, 5.0)
    u_b = (R - 50.0) * B / K2
    floor = 50.0 * 20.0 / (u_b / 60.0)
    tolerance = R * sc.simulation.plant_step_s
    assert unavoidable_iae_N_s(sc) == pytest.approx(entry + floor, abs=tolerance)
    constant = sc.with_values({"controller.kind": "constant"})
    assert unavoidable_iae_N_s(constant) == pytest.approx(entry, abs=tolerance)


def test_excess_iae_only_when_asked_and_nan_where_the_bound_does_not_reach():
    """Off by default (no column); on a part of several depths (Kim & Chung's) NaN."""
    plain = simulate(_part(**{"metrics.excess_iae": False}), record_every_steps=None)
    assert "excess_iae_N_s" not in plain.metrics
    stepped = load_scenario(ROOT / "experiments" / "kim_chung_2001.toml").with_values(
        {"metrics.excess_iae": True})
    assert math.isnan(simulate(stepped, record_every_steps=None).metrics["excess_iae_N_s"][0])


def test_spindle_averaged_iae_is_the_iae_of_the_revolution_moving_average():
    """``iae_spindle_averaged_N_s`` = sum over the cut of |moving sum of the last N errors| / N
    dt, N the steps of one revolution (the sum starts empty at the entry), computed here with
    numpy on the recorded force; a 50 N runout at the spindle frequency then leaves almost
    nothing of its |e| (its revolution mean is zero), while the plain IAE grows by ~2/pi A t."""
    sc = Scenario().with_values({
        "controller.kind": "pi", "workpiece.radial_depth_mm": [3.0],
        "workpiece.segment_length_mm": [10.0], "workpiece.axial_depth_mm": [10.0],
        "disturbance": [{"name": "runout", "kind": "force", "shape": "sinusoid",
                         "amplitude_N": 50.0, "harmonic_of": "spindle"}],
    })
    res = simulate(sc, record_every_steps=1)
    dt = sc.simulation.plant_step_s
    n_rev = round(60.0 / (sc.geometry.spindle_speed_rpm * dt))
    assert revolution_steps(sc) == n_rev
    f = res.signal("force_N")[0]
    cut = np.isfinite(f) & (res.signal("radial_depth_mm")[0] > 0)
    finish = int(round(float(res.metrics["machining_time_s"][0]) / dt))
    e = f[: finish + 1][cut[: finish + 1]] - 500.0
    averaged = np.convolve(e, np.ones(n_rev))[: e.size] / n_rev
    want = np.sum(np.abs(averaged)) * dt
    got = float(res.metrics["iae_spindle_averaged_N_s"][0])
    assert got == pytest.approx(want, rel=1e-6)
    plain = float(res.metrics["iae_N_s"][0])
    assert plain - got > 0.5 * (2 / math.pi) * 50.0 * e.size * dt


def test_overshoot_of_a_peak_equal_to_the_reference_up_to_rounding_reads_zero():
    from acc.engine.metrics import percent_over

    r = np.array([500.0, 500.0, 500.0, 500.0])
    peak = np.array([500.0 * (1 - 2**-52), 525.0, 499.0, np.nan])
    pct = percent_over(peak, r)
    assert pct[0] == 0.0 and not np.signbit(pct[0]) and f"{pct[0]:.4g}" == "0"
    assert pct[1] == pytest.approx(5.0, abs=1e-9)
    assert pct[2] == pytest.approx(-0.2, abs=1e-9)
    assert np.isnan(pct[3])
