"""Peng's servo axis and its digital position loop, against computations written here.

Every reference below is built in this module from the thesis' equations (seed 000,
Eqs. 2.1-2.4, 2.14, 2.24, 2.29-2.30) with scipy, or is a steady-state balance solved by
hand; nothing is taken from the code under test except the parameter values (Peng's
Appendix A, the dataclass defaults).
"""

from __future__ import annotations

import math

import control
import numpy as np
import pytest
from scipy.signal import cont2discrete, ss2tf

from acc.design import axis_analysis as aa
from acc.engine.axis_simulate import simulate_axis
from controllers.axis.lead_lag import LeadLagParams
from controllers.axis.trajectory import TrajectoryParams
from plants.axis.servo_axis import ServoAxisParams

T = 0.001  # Peng's sampling period [s] (plant step = control period)
AXIS = ServoAxisParams()
LEAD_LAG = LeadLagParams()  # D(z) = 2.5 (z - 0.8825)/z, K_d = 0.078125 V/count


def thesis_matrices(ax: ServoAxisParams) -> tuple[np.ndarray, np.ndarray]:
    """(2.1)-(2.4) and (2.24) written out: states [I_a, W, x_mm], inputs [V_c, T_c]."""
    Ra, La, Kb = ax.armature_resistance_ohm, ax.armature_inductance_H, ax.back_emf_V_s_rad
    Kt, J, B = ax.torque_constant_Nm_A, ax.inertia_kg_m2, ax.viscous_friction_Nm_s_rad
    Kv, KI, Ka = ax.pwm_gain_V_A, ax.current_amp_gain_A_V, ax.current_feedback_gain
    Sg, Tg, Hg = ax.command_gain, ax.tacho_constant_V_s_rad, ax.tacho_gain
    # L dI/dt = V_a - R I - K_b W,  V_a = K_v [K_I (S_g V_c - T_g H_g W) - K_a I]
    A = np.array(
        [
            [-(Ra + Kv * Ka) / La, -(Kb + Kv * KI * Tg * Hg) / La, 0.0],
            [Kt / J, -B / J, 0.0],
            [0.0, ax.screw_pitch_mm / (2 * math.pi), 0.0],  # x = p/(2 pi) * angle
        ]
    )
    Bm = np.array([[Kv * KI * Sg / La, 0.0], [0.0, -1.0 / J], [0.0, 0.0]])
    return A, Bm


def k123(ax: ServoAxisParams) -> tuple[float, float, float]:
    """(2.14) from the printed parameters."""
    Ra, La, Kb = ax.armature_resistance_ohm, ax.armature_inductance_H, ax.back_emf_V_s_rad
    Kt, J, B = ax.torque_constant_Nm_A, ax.inertia_kg_m2, ax.viscous_friction_Nm_s_rad
    Kv, KI, Ka = ax.pwm_gain_V_A, ax.current_amp_gain_A_V, ax.current_feedback_gain
    Sg, Tg, Hg = ax.command_gain, ax.tacho_constant_V_s_rad, ax.tacho_gain
    k1 = Kt * Sg * KI * Kv / (La * J)
    k2 = B / J + (Ra + Kv * Ka) / La
    k3 = (B * (Ra + Kv * Ka) + Kt * (Kb + Hg * Tg * Kv * KI)) / (J * La)
    return k1, k2, k3


def reference_loop(ax, ll, reference_mm, load_torque_Nm=None):  # noqa: ANN001, ANN201
    """The sampled loop by hand: scipy's ZOH of the thesis block, (2.29)/(2.30) in mm."""
    A, Bm = thesis_matrices(ax)
    phi, gam, *_ = cont2discrete((A, Bm, np.eye(3), np.zeros((3, 2))), T, method="zoh")
    counts_per_mm = ax.encoder_counts_per_rev / ax.screw_pitch_mm
    kpkd = ll.gain * ll.dac_gain_V_per_count * counts_per_mm  # V per mm of error
    a, b = ll.zero, ll.pole  # D(z) = K_p (z + a)/(z + b): zero = a = -0.8825
    n = len(reference_mm)
    tc = np.zeros(n) if load_torque_Nm is None else load_torque_Nm
    x = np.zeros(3)
    vd = 0.0
    out = np.zeros((3, n))
    for k in range(n):
        e = reference_mm[k] - x[2]
        vc = kpkd * e + vd  # (2.30)
        vd = -b * vd + kpkd * (a - b) * e  # (2.29)
        out[:, k] = x[2], vc, x[0]
        x = phi @ x + gam @ np.array([vc, tc[k]])
    return out


def test_velocity_loop_transfer_function_is_k1_over_quadratic():
    A, Bm = thesis_matrices(AXIS)
    num, den = ss2tf(A[:2, :2], Bm[:2, :1], np.array([[0.0, 1.0]]), np.zeros((1, 1)))
    k1, k2, k3 = k123(AXIS)
    np.testing.assert_allclose(den, [1.0, k2, k3], rtol=1e-9)
    np.testing.assert_allclose(np.trim_zeros(num[0], "f"), [k1], rtol=1e-9)
    tf = AXIS.velocity_loop.transfer_function()
    np.testing.assert_allclose(tf.den[0][0], [1.0, k2, k3], rtol=1e-9)
    np.testing.assert_allclose(tf.num[0][0], [k1], rtol=1e-9)
    # the model's own state space converts to the same polynomial
    ss = AXIS.velocity_loop.state_space()
    g = control.ss2tf(ss[1, 0])
    np.testing.assert_allclose(np.array(g.den[0][0]) / g.den[0][0][0], [1.0, k2, k3], rtol=1e-9)


def test_zoh_of_the_block_equals_scipy():
    A, Bm = thesis_matrices(AXIS)
    phi, gam, *_ = cont2discrete((A, Bm, np.eye(3), np.zeros((3, 2))), T, method="zoh")
    p, h = AXIS.discretise_block(T)
    np.testing.assert_allclose(p, phi, rtol=0, atol=1e-12 * np.abs(phi).max())
    np.testing.assert_allclose(h, gam, rtol=0, atol=1e-12 * np.abs(gam).max())


def _step_reference(n: int, start: int = 10, height_mm: float = 1.0) -> np.ndarray:
    r = np.zeros(n)
    r[start:] = height_mm
    return r


def test_position_loop_step_equals_the_loop_written_from_the_thesis():
    n = 400
    res = simulate_axis(
        AXIS, LEAD_LAG, TrajectoryParams(kind="step", step_mm=1.0, start_s=10 * T),
        duration_s=n * T, plant_step_s=T,
    )
    ref = reference_loop(AXIS, LEAD_LAG, _step_reference(n))
    m = res.time_s.size
    np.testing.assert_allclose(res.signals["x_ref_mm"][0], _step_reference(n)[:m], atol=0)
    for i, name in enumerate(("x_mm", "command_V", "current_A")):
        scale = np.abs(ref[i]).max()
        np.testing.assert_allclose(res.signals[name][0], ref[i, :m], rtol=0, atol=1e-12 * scale)
    # and the analysis's (2.31) object gives the same response through python-control
    cl = aa.sampled_position_loop(AXIS, LEAD_LAG, T, "mm")
    u = np.zeros((2, m))
    u[0] = _step_reference(n)[:m]
    y = control.forced_response(cl, T=res.time_s, U=u).outputs
    np.testing.assert_allclose(y[3], ref[0, :m], rtol=0, atol=1e-12)
    assert cl.input_labels == ["reference_mm", "load_torque_Nm"]
    assert np.ptp(ref[0]) > 0.99  # the response covers the step


def _steady_following_error_mm(feed_mm_s: float) -> float:
    """Ramp at constant speed, Type-1 loop: W = v/(p/2pi); V_c = W K_3/K_1 (the velocity
    loop's DC gain); V_c = K_d D(1) E at rest of the lead state, E in counts."""
    k1, _, k3 = k123(AXIS)
    speed = feed_mm_s / (AXIS.screw_pitch_mm / (2 * math.pi))
    vc = speed * k3 / k1
    d1 = LEAD_LAG.gain * (1 - 0.8825) / 1.0  # D(1) of 2.5 (z - 0.8825)/z
    counts = vc / (LEAD_LAG.dac_gain_V_per_count * d1)
    return counts * AXIS.screw_pitch_mm / AXIS.encoder_counts_per_rev


def test_ramp_following_error_equals_the_steady_state_balance():
    feed = 25.0  # mm/s (1.5 m/min)
    res = simulate_axis(
        AXIS, LEAD_LAG, TrajectoryParams(kind="ramp", feed_mm_s=feed, start_s=0.01),
        duration_s=1.0, plant_step_s=T,
    )
    e_end = res.signals["following_error_mm"][0, -1]
    expected = _steady_following_error_mm(feed)
    assert e_end == pytest.approx(expected, rel=1e-6)
    # the analysis's velocity constant: e = v / K_vel
    k_vel = aa.velocity_constant_1_s(AXIS, LEAD_LAG, T)
    assert feed / k_vel == pytest.approx(expected, rel=1e-9)


def test_type_2_loop_follows_a_parabola_with_the_constant_error_of_the_balance():
    # b = -1 puts an integrator in D(z) = K_p (z + a)/(z - 1) (Sec. 4.2.1, Case 2). On a
    # parabola the axis accelerates at A: W' = A/(p/2pi), so V_c ramps at (K_3/K_1) W'; the
    # integrator supplies it, K_d K_p (1 + a) E per period T, with a constant error E.
    k_p, a = 0.5, -0.95
    type2 = LeadLagParams(gain=k_p, zero=a, pole=-1.0)
    acc_mm_s2 = 50.0
    res = simulate_axis(
        AXIS, type2, TrajectoryParams(kind="parabola", acceleration_mm_s2=acc_mm_s2),
        duration_s=1.0, plant_step_s=T,
    )
    k1, _, k3 = k123(AXIS)
    ramp_V_s = k3 / k1 * acc_mm_s2 / (AXIS.screw_pitch_mm / (2 * math.pi))
    counts = ramp_V_s * T / (type2.dac_gain_V_per_count * k_p * (1 + a))
    expected_mm = counts * AXIS.screw_pitch_mm / AXIS.encoder_counts_per_rev
    e = res.signals["following_error_mm"][0]
    assert e[-1] == pytest.approx(expected_mm, rel=1e-6)
    assert np.ptp(e[-200:]) < 1e-6 * abs(expected_mm)  # settled: bounded, constant
    # the Type-1 loop on the same parabola: the error grows as v(t)/K_vel
    res1 = simulate_axis(
        AXIS, LEAD_LAG, TrajectoryParams(kind="parabola", acceleration_mm_s2=acc_mm_s2),
        duration_s=1.0, plant_step_s=T,
    )
    e1 = res1.signals["following_error_mm"][0]
    assert e1[-1] > 50 * abs(expected_mm)
    assert np.all(np.diff(e1[-200:]) > 0)


def test_stiffness_against_cutting_torque_equals_the_static_balance():
    # at rest under a constant load torque: K_t I_a = T_c; the amplifier holds
    # R_a I_a = K_v K_I S_g V_c - K_v K_a I_a; V_c = K_d D(1) E
    torque = 0.5  # N m
    n = 3000
    load_N = np.full(n, torque / AXIS.force_to_torque_m)
    res = simulate_axis(
        AXIS, LEAD_LAG, reference_samples_mm=np.zeros(n), load_samples_N=load_N,
        duration_s=n * T, plant_step_s=T,
    )
    ia = torque / AXIS.torque_constant_Nm_A
    vc = (AXIS.armature_resistance_ohm + AXIS.pwm_gain_V_A * AXIS.current_feedback_gain) * ia / (
        AXIS.pwm_gain_V_A * AXIS.current_amp_gain_A_V * AXIS.command_gain
    )
    counts = vc / (LEAD_LAG.dac_gain_V_per_count * LEAD_LAG.gain * (1 - 0.8825))
    x_expected = -counts * AXIS.screw_pitch_mm / AXIS.encoder_counts_per_rev  # pushed back
    assert res.signals["x_mm"][0, -1] == pytest.approx(x_expected, rel=1e-6)
    assert res.signals["current_A"][0, -1] == pytest.approx(ia, rel=1e-6)
    # the independent sampled loop under the same torque
    ref = reference_loop(AXIS, LEAD_LAG, np.zeros(n), np.full(n, torque))
    np.testing.assert_allclose(res.signals["x_mm"][0], ref[0], rtol=0, atol=1e-12)


def test_force_loop_on_the_servo_axis_equals_a_loop_written_here():
    """``feed_drive.kind = "servo_axis"``: the PI's override through the 0.1 s NC delay,
    the interpolator, Peng's position loop and the axis loaded by the cutting force; the
    chip load follows the table velocity held over each step (x+ = phi x + (1 - phi) v)."""
    from acc.engine.simulate import simulate
    from acc.scenarios.force import Scenario

    depth = 3.0
    sc = Scenario().with_values(
        {
            "feed_drive.kind": "servo_axis",
            "workpiece.segment_length_mm": [10_000.0],
            "workpiece.radial_depth_mm": [depth],
            "workpiece.axial_depth_mm": [10.0],
            "simulation.time_limit_s": 3.0,
            "sensor.noise_std_N": 0.0,
            "controller.initial_override": 0.0,
            "controller.override_min": 0.0,
            "controller.override_max": 100.0,
        }
    )
    res = simulate(sc)
    row = res.summary_rows()[0]
    kp, ki = float(row["kp_per_N"]), float(row["ki_per_N_s"])
    k2, p2 = 12.57, -3.75  # Table 1 at 3 mm
    gain = k2 / -p2  # N per mm/min
    dt, m, n_delay = 0.001, 10, 100
    feed = sc.controller.programmed_feed_mm_min
    A, Bm = thesis_matrices(AXIS)
    phi_ax, gam, *_ = cont2discrete((A, Bm, np.eye(3), np.zeros((3, 2))), dt, method="zoh")
    kpkd = LEAD_LAG.gain * LEAD_LAG.dac_gain_V_per_count * AXIS.encoder_counts_per_rev / (
        AXIS.screw_pitch_mm
    )
    phi_chip = math.exp(p2 * dt)
    n = res.time_s.size
    f_ref = np.zeros(n)
    x = 0.0  # chip load [mm/min]
    axis = np.zeros(3)  # I_a, W, x_table
    vd = xr = integral = u = 0.0
    history = np.zeros(n + n_delay)
    for k in range(n):
        f = gain * x
        f_ref[k] = f
        if k % m == 0:
            e = sc.controller.reference_force_N - f
            override = kp * e + integral
            integral += ki * 0.01 * e
            u = override * feed
        history[k + n_delay] = u
        delayed = history[k]
        v = axis[1] * AXIS.screw_pitch_mm / (2 * math.pi) * 60.0
        err = xr - axis[2]
        vc = kpkd * err + vd
        vd = -LEAD_LAG.pole * vd + kpkd * (LEAD_LAG.zero - LEAD_LAG.pole) * err
        axis = phi_ax @ axis + gam @ np.array([vc, AXIS.force_to_torque_m * f])
        xr += delayed * dt / 60.0
        x = phi_chip * x + (1 - phi_chip) * v
    force = res.signal("force_N")[0]
    np.testing.assert_allclose(force, f_ref, rtol=0, atol=1e-9 * 500.0)
    assert force[-1] == pytest.approx(500.0, rel=0.01)  # the loop regulates on the axis
