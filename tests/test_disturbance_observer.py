"""Disturbance observer: Routh boundary, simulation on both sides, Q = 0 equivalence,
anti-windup with the observer in the loop."""

import dataclasses

import numpy as np
import pytest

from acc.design.analysis import loop_spec, max_gain_ratio
from acc.engine.element import call_runs, step_runs
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario
from controllers.disturbance_observer import advance, estimate, observer_records
from controllers.pi import pi_records
from controllers.q_filter import q_filter_denominator
from controllers.robust_force_controller import robust_records

#: Observer loop alone (no PI), no dead time, one 3 mm segment: P = k Pn exactly.
NO_DELAY = {
    "controller.kind": "dob_pi",
    "controller.kp_per_N": 0.0,
    "controller.ki_per_N_s": 0.0,
    "controller.dob_tau_s": 0.3,
    "controller.override_min": 0.0,
    "controller.override_max": 1000.0,
    "feed_drive.dead_time_s": 0.0,
    "nominal_plant.dead_time_s": 0.0,
    "workpiece.segment_length_mm": [200.0],
    "workpiece.radial_depth_mm": [3.0],
    "workpiece.axial_depth_mm": [10.0],
    "sensor.noise_std_N": 0.0,
    "sensor.lowpass_cutoff_hz": 0.0,
    "simulation.plant_step_s": 0.005,
    "simulation.time_limit_s": 12.0,
}


def _verdict(result, i):
    """'stable': the oscillation shrinks (last 2 s vs 4 s earlier, ratio < 0.6) and never
    touches the clamp; 'unstable': the override sits on its lower clamp in the last 2 s (the
    linear loop diverges and only the clamp holds it in a limit cycle); else 'unclear'."""
    t, f, o = result.time_s, result.signal("force_N")[i], result.signal("override")[i]
    late, early = t >= 10.0, (t >= 6.0) & (t < 8.0)
    if o[late].min() <= 0.0:
        return "unstable"
    if np.ptp(f[late]) < 0.6 * np.ptp(f[early]):
        return "stable"
    return "unclear"


def test_routh_boundary_is_nine_without_dead_time():
    # (tau s + 1)^3 + k - 1: Routh row 3 tau^2 * 3 tau > tau^3 k  <=>  k < 9 (any tau)
    spec = loop_spec(Scenario().with_values(NO_DELAY))
    for tau in (0.05, 0.3):
        s = dataclasses.replace(spec, dob_tau_s=tau, control_period_s=0.0)
        k = max_gain_ratio(s, "continuous", with_pi=False, rtol=1e-6)
        assert k == pytest.approx(9.0, rel=1e-5)  # bisection bracket 1e-6


def test_simulation_agrees_on_both_sides_of_the_boundary():
    base = Scenario().with_values(NO_DELAY)
    k_sampled = max_gain_ratio(loop_spec(base), "sampled", with_pi=False, rtol=1e-4)
    # the sampled boundary is below Routh's 9 by the hold's phase lag, close to it for tau >> Tc
    assert 8.0 < k_sampled < 9.0
    # both sides of the sampled boundary (+-20 %) and of Routh's 9 (7.5, 10.5); closer to the
    # boundary the decay is too slow to judge in a short run (damping -> 0 at the boundary)
    ks = [0.8 * k_sampled, 7.5, 10.5, 1.2 * k_sampled]
    res = simulate([base.with_values({"force_process.gain_multiplier": k}) for k in ks])
    verdicts = [_verdict(res, i) for i in range(4)]
    assert verdicts == ["stable", "stable", "unstable", "unstable"]


def _robust(runs, observer, Tc=0.01):
    ones = np.ones(runs)
    return robust_records(
        500.0 * ones,
        2.5e-3 * ones,
        9.4e-3 * ones,
        0.1 * ones,
        2.0 * ones,
        1.0 * ones,
        120.0 * ones,
        29.33 * ones,
        12.57 * ones,
        -3.75 * ones,
        Tc,
        observer=observer,
    )


def test_q_zero_equals_bare_pi_sample_by_sample():
    runs, Tc = 3, 0.01
    zero = observer_records([([0.0], [1.0])] * runs, 10, Tc)
    dob_p, dob_s = _robust(runs, zero)
    pi_p, pi_s = pi_records(500.0, 2.5e-3, 9.4e-3, 0.1, 2.0, 1.0, Tc)
    pi_p, pi_s = np.repeat(pi_p, runs), np.repeat(pi_s, runs)
    diag = np.full(7, np.nan)
    rng = np.random.default_rng(1)
    for _ in range(300):
        y = rng.uniform(0, 1200, runs)
        od = step_runs(dob_p, dob_s, y, shared=(diag,))
        op = step_runs(pi_p, pi_s, y, shared=(diag,))
        np.testing.assert_array_equal(od, op)  # exact: same arithmetic, zero offset


def test_constant_feed_disturbance_is_estimated_exactly_at_steady_state():
    # plant = nominal, constant command u and a constant feed disturbance d at the plant
    # input: force = Gn (u + d); the observer's DC gains are exact, so d_hat -> d.
    Tc, N = 0.01, 10
    p, s = observer_records([([1.0], q_filter_denominator(0.1))], N, Tc)
    u, d, g = 100.0, 15.0, 12.57 / 3.75
    f = g * (u + d)
    for _ in range(2000):
        dh = call_runs(estimate, p, s, f, 29.33, 12.57, -3.75)
        call_runs(advance, p, s, f, u)
    assert dh[0] == pytest.approx(d, rel=1e-9)


def test_anti_windup_holds_with_the_observer():
    # an air cut first (no force: override at its clamp), then the cut.  The integrator must
    # not move while clamped, and the time to leave the clamp after entering the material must
    # not depend on how long the air cut lasted (1 vs 4 s): within one control period.
    common = {
        "controller.kind": "dob_pi",
        "sensor.noise_std_N": 0.0,
        "sensor.lowpass_cutoff_hz": 0.0,
        "simulation.plant_step_s": 0.002,
        "simulation.time_limit_s": 10.0,
        "workpiece.radial_depth_mm": [0.0, 3.0],
        "workpiece.axial_depth_mm": [10.0, 10.0],
    }
    sc = [
        Scenario().with_values({**common, "workpiece.segment_length_mm": [air, 10.0]})
        for air in (4.0, 16.0)  # 1 s and 4 s at the 2.0 override (240 mm/min)
    ]
    res = simulate(sc)
    t = res.time_s
    exits = []
    for i in range(2):
        depth = res.signal("radial_depth_mm")[i]
        ov = res.signal("override")[i]
        enter = np.flatnonzero(depth > 0)[0]
        assert np.all(ov[50:enter] == 2.0)  # clamped through the air cut
        leave = enter + np.flatnonzero(ov[enter:] < 2.0)[0]
        exits.append(t[leave] - t[enter])
    assert exits[0] == pytest.approx(exits[1], abs=0.01 + 1e-9)


def test_observer_transient_equals_eqs_10_11_written_with_python_control():
    """d_hat = Q P_n0^-1 f - Q e^{-L_n s} u, written here from Eqs. (10)-(11): the force
    path by python-control's first-order-hold c2d (the force is continuous), the command
    path by its zero-order hold after a delay of N = L_n / T_c periods (the command is held).
    Random force and command sequences; every sample, not only the steady state."""
    import control

    a, k2, p2, tau, tc, n_delay = 29.33, 12.57, -3.75, 0.1, 0.01, 10
    q_den = np.poly([-1 / tau] * 3) * tau**3  # (tau s + 1)^3
    q = control.tf([1.0], q_den)
    pn0_inv = control.tf([1.0, a - p2, -a * p2], [a * k2])
    force_path = control.c2d(q * pn0_inv, tc, method="foh")
    command_path = control.c2d(q, tc, method="zoh")
    rng = np.random.default_rng(7)
    n = 300
    f = 500.0 + np.cumsum(rng.normal(0.0, 5.0, n))
    u = 120.0 + np.cumsum(rng.normal(0.0, 2.0, n))
    t = np.arange(n) * tc
    delayed = np.concatenate([np.zeros(n_delay), u[: n - n_delay]])
    expected = (
        control.forced_response(force_path, T=t, U=f).outputs
        - control.forced_response(command_path, T=t, U=delayed).outputs
    )
    params, state = observer_records([(np.array([1.0]), q_den)], n_delay, tc)
    got = np.empty(n)
    for k in range(n):
        got[k] = call_runs(estimate, params, state, f[k], a, k2, p2)[0]
        call_runs(advance, params, state, f[k], u[k])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    assert np.ptp(expected[n_delay:]) > 10.0  # a transient, not a constant


@pytest.mark.parametrize("cutoff_hz", [0.0, 20.0])
@pytest.mark.parametrize("tau_s", [0.02, 0.05])
def test_hold_discretisation_is_scipys_cont2discrete_bit_for_bit(tau_s, cutoff_hz):
    """The observer's filters discretised without scipy.signal are exactly what
    scipy.signal.cont2discrete gives for the same realisations (first-order hold for the
    force bank, zero-order hold for the input filter), and an unknown method is refused."""
    from scipy.signal import cont2discrete

    from controllers.discretisation import hold_discretisation
    from controllers.disturbance_observer import _BANK_POWERS, _companion, sensor_inverse

    den = q_filter_denominator(tau_s, 3)
    num = np.array([1.0])
    systems = [(_companion(np.polymul(num, sensor_inverse(cutoff_hz)), den, _BANK_POWERS), "foh"),
               (_companion(num, den, (0,)), "zoh")]
    for system, method in systems:
        got = hold_discretisation(system, 0.01, method)
        want = cont2discrete(system, 0.01, method=method)[:4]
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)
    with pytest.raises(ValueError, match="zoh"):
        hold_discretisation(systems[1][0], 0.01, "tustin")


@pytest.mark.parametrize("order", [2, 3, 4, 5, 6])
def test_each_filter_order_steps_as_its_state_space_recurrence(order):
    # the observer's banks stepped with the order as a constant for 2 to 4, the run-time
    # order otherwise: each must be
    # the plain recurrence x+ = A x + B w, outputs C x + D w on the run's own matrices (the
    # first `order` states of the records), computed here with numpy
    Tc, N = 0.01, 3
    p, s = observer_records([([1.0], q_filter_denominator(0.05, order))], N, Tc)
    n = int(p["order"][0])
    assert n == order
    A, B = p["bank_A"][0, :n, :n], p["bank_B"][0, :n]
    C, D = p["bank_C"][0, :, :n], p["bank_D"][0]
    Ai, Bi, Ci = p["input_A"][0, :n, :n], p["input_B"][0, :n], p["input_C"][0, :n]
    x, xi = np.zeros(n), np.zeros(n)
    commands = [0.0] * (N + 1)  # u[k - N] reaches the input filter
    a, k2, p2 = 29.33, 12.57, -3.75
    rng = np.random.default_rng(order)
    for _ in range(60):
        f, u = rng.uniform(200.0, 800.0), rng.uniform(50.0, 150.0)
        m0, m1, m2 = C @ x + D * f
        expected = (m0 + (a - p2) * m1 - a * p2 * m2) / (a * k2) - Ci @ xi
        got = call_runs(estimate, p, s, f, a, k2, p2)[0]
        assert got == pytest.approx(expected, rel=1e-12, abs=1e-9)
        call_runs(advance, p, s, f, u)
        commands.append(u)
        x, xi = A @ x + B * f, Ai @ xi + Bi * commands[-1 - N]
        np.testing.assert_allclose(s["force_bank"][0, :n], x, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(s["input_filter"][0, :n], xi, rtol=1e-12, atol=1e-9)
