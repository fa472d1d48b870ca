"""Peng's current sensor (3.52) and force estimators (3.39)-(3.40), (3.60)-(3.62).

Numbers from: python-control's conversion of the closed-loop state-space model, the closed
forms (3.54)/(3.58) and c1 + c3 = K_t, c2 + c4 = -B, and an independent sampled simulation
written here (scipy ``cont2discrete`` plant and Peng's (2.29)/(2.30) controller)."""

import math

import control
import numpy as np
import pytest
from scipy.signal import cont2discrete

from acc.engine.element import step_runs
from controllers.axis.lead_lag import LeadLagParams
from controllers.monitoring.servo_force_sensing import (
    ServoForceEstimatorParams,
    closed_loop_state_space,
    current_sensor_coefficients,
    current_sensor_tf,
    gain_bandwidth_rad_s,
    interpolate_coefficients,
    inverse_model_coefficient_table,
    inverse_model_coefficients,
    inverse_model_records,
    steady_currents_A,
    steady_state_records,
)
from plants.axis.servo_axis import ServoAxisParams

T = 1e-3
AXIS = ServoAxisParams()
LL = LeadLagParams()


def _sampled_loop(axis, xr_counts, tc_Nm):
    """Independent sampled loop: exact ZOH plant (scipy) + (2.29)/(2.30), states in counts."""
    A, B = axis.continuous_matrices("counts")
    phi, gam, *_ = cont2discrete((A, B, np.eye(3), np.zeros((3, 2))), T, method="zoh")
    kpkd = LL.gain * LL.dac_gain_V_per_count
    a, b = LL.zero, LL.pole
    x = np.zeros(3)
    vd = 0.0
    out = np.zeros((len(xr_counts), 3))
    for k, (xr, tc) in enumerate(zip(xr_counts, tc_Nm, strict=True)):
        e = xr - x[2]
        vc = kpkd * e + vd
        vd = -b * vd + kpkd * (a - b) * e
        out[k] = x
        x = phi @ x + gam @ np.array([vc, tc])
    return out


def test_transfer_functions_equal_the_state_space_model():
    ss = closed_loop_state_space(AXIS, LL, T)
    w = np.logspace(0, 4.5, 25)
    for j, name in enumerate(("reference", "torque")):
        formula = current_sensor_tf(AXIS, LL, T, name)
        converted = control.ss2tf(ss[0, j])
        np.testing.assert_allclose(formula(1j * w), converted(1j * w), rtol=1e-8)
    poles = np.sort_complex(current_sensor_tf(AXIS, LL, T).poles())
    np.testing.assert_allclose(poles, np.sort_complex(np.linalg.eigvals(ss.A)), rtol=1e-9)


def test_dc_gain_and_bandwidth():
    tf = current_sensor_tf(AXIS, LL, T)
    assert control.dcgain(tf) == pytest.approx(1.0 / AXIS.torque_constant_Nm_A, rel=1e-12)
    assert gain_bandwidth_rad_s(tf) == pytest.approx(float(control.bandwidth(tf)), rel=1e-9)
    # the bandwidth is where |I_a/T_c| is 3 dB below 1/K_t, by definition
    wb = gain_bandwidth_rad_s(tf)
    assert abs(tf(1j * wb)) == pytest.approx(10 ** (-3 / 20) / 0.3, rel=1e-9)


@pytest.mark.parametrize("b_visc", [0.09, 0.196, 0.3])
def test_current_sensor_steady_values_from_a_sampled_simulation(b_visc):
    axis = ServoAxisParams(viscous_friction_Nm_s_rad=b_visc)
    n = 3000
    fc = 1000.0  # counts/s (Fig. 3.15 ramp, spec O-19)
    ramp = _sampled_loop(axis, fc * T * np.arange(n), np.zeros(n))
    step = _sampled_loop(axis, np.zeros(n), np.full(n, 1.0))
    i_ar, i_ac = steady_currents_A(axis, fc, 1.0)
    assert i_ar == pytest.approx(fc * b_visc / (636.6197723675814 * 0.3), rel=1e-12)
    assert ramp[-1, 0] == pytest.approx(i_ar, rel=1e-9)
    assert step[-1, 0] == pytest.approx(i_ac, rel=1e-9) and i_ac == pytest.approx(1 / 0.3)
    # and the continuous (3.52) gives the same finals: s I(s) at s -> 0
    c = current_sensor_coefficients(axis, LL, T)
    assert fc * c["beta1"] / c["alpha0"] == pytest.approx(i_ar, rel=1e-12)
    assert c["gamma0"] / c["alpha0"] == pytest.approx(i_ac, rel=1e-12)


@pytest.mark.parametrize("b_visc", [0.05, 0.09, 0.2379])
def test_inverse_model_invariants(b_visc):
    axis = ServoAxisParams(viscous_friction_Nm_s_rad=b_visc)
    c = inverse_model_coefficients(axis.velocity_loop, T)
    assert c[0] + c[2] == pytest.approx(0.3, rel=1e-9)
    assert c[1] + c[3] == pytest.approx(-b_visc, rel=1e-7)


def test_inverse_model_reconstructs_the_torque_one_sample_late():
    rng = np.random.default_rng(2)
    av, bv = AXIS.state_matrices()
    phi, gam, *_ = cont2discrete((av, bv, np.eye(2), np.zeros((2, 2))), T, method="zoh")
    n = 400
    vc = rng.normal(0, 1.0, n)
    tc = 0.5 + 0.3 * rng.standard_normal(n)
    x = np.zeros((n + 1, 2))
    for k in range(n):
        x[k + 1] = phi @ x[k] + gam @ np.array([vc[k], tc[k]])
    params, state = inverse_model_records([AXIS], T)
    out = np.array([step_runs(params, state, x[k, 0], x[k, 1]) for k in range(n + 1)])[:, :, 0]
    np.testing.assert_allclose(out[1:, 0], tc, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(out[1:, 1], tc / 9.45e-4, rtol=1e-7, atol=1e-6)
    assert out[0, 0] == 0.0


def test_lowpass_is_the_exact_first_order_step():
    params, state = inverse_model_records(
        [AXIS], T, ServoForceEstimatorParams(lowpass_cutoff_Hz=50.0))
    a = math.exp(-2 * math.pi * 50 * T)
    ws = 2.0 / 0.3  # constant speed with K_t I = B W + T_c, T_c = 0.4 N m
    ia = (0.09 * ws + 0.4) / 0.3
    y = [step_runs(params, state, ia, ws)[0][0] for _ in range(30)]
    expected = [0.0] + [0.4 * (1 - a**k) for k in range(1, 30)]
    np.testing.assert_allclose(y, expected, rtol=1e-9, atol=1e-12)


def test_coefficient_table_over_feed():
    axis = ServoAxisParams(friction_model="speed_dependent_linear")
    feeds = np.array([2.0, 3.175, 10.0, 20.0])
    table = inverse_model_coefficient_table(axis, T, feeds)
    for f, row in zip(feeds, table, strict=True):
        b = 450.0 / (f * 4000 / 5.08)  # B = K_c / f_c (3.55)
        assert row[1] + row[3] == pytest.approx(-b, rel=1e-7)
    np.testing.assert_array_equal(interpolate_coefficients(table, feeds, 10.0), table[2])


def test_steady_state_estimator_returns_the_applied_torque():
    # B = K_c / f_c at the commanded feed makes the tare exactly K_c / K_e (3.62)
    feed_mm_s = 3.175
    axis = ServoAxisParams(friction_model="speed_dependent_linear")
    fc = axis.feed_counts_s(feed_mm_s)
    eff = axis.with_effective_friction(feed_mm_s)
    n = 2000
    x = _sampled_loop(eff, fc * T * np.arange(n), np.full(n, 0.6))
    params, state = steady_state_records([axis], T, ServoForceEstimatorParams(settle_time_s=0.05))
    out = np.array([step_runs(params, state, x[k, 0], x[k, 1]) for k in range(n)])[:, :, 0]
    assert np.all(out[:50, 0] == 0.0)
    assert out[-1, 0] == pytest.approx(0.6, rel=1e-9)
    measured, st2 = steady_state_records(
        [axis], T, ServoForceEstimatorParams(tare_model="measured_current", tare_current_A=2.5))
    assert measured[0]["tare_torque_Nm"] == pytest.approx(0.75)
