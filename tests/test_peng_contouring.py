"""Peng's two-axis contouring simulation against his closed forms (spec §5.8, M0-11).

* the simulated contour error of a straight segment equals (4.87)/(4.91), written out here
  from the velocity-loop constants and the Tustin filter; it vanishes when the axes are
  matched or the segment is at 0 or 90 degrees;
* the mismatched diamond's incoming line shows the same value (45 degrees, f = 20 mm/s per
  axis), and the exact error equals the linear estimate there;
* the switched integrator turns off and on at the given path distances from the vertex.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from acc.engine.contour_simulate import simulate_contouring, switched_integrator
from controllers.axis.lead_lag import LeadLagParams
from controllers.contouring.interpolator import PathParams, interpolate
from plants.axis.servo_axis import ServoAxisParams

T = 0.001
AX = ServoAxisParams()  # B = 0.09
AY = replace(AX, viscous_friction_Nm_s_rad=0.3)
CTRL = LeadLagParams()


def _closed_form_4_91(feed_mm_s: float, angle_rad: float, ax, ay) -> float:
    """(4.91) in mm: (f sin 2theta / 2) b'/(K_d K'_p K_e a') [K_3y/K_1y - K_3x/K_1x]."""
    kp, a, b = CTRL.gain, CTRL.zero, CTRL.pole
    kpp = kp * (1 - a) / (1 - b)  # Tustin (3.44)
    ap = 2 / T * (1 + a) / (1 - a)
    bp = 2 / T * (1 + b) / (1 - b)

    def k13(axis):
        v = axis.velocity_loop
        la, je = v.armature_inductance_H, v.inertia_kg_m2
        k1 = v.torque_constant_Nm_A * v.command_gain * v.current_amp_gain_A_V * v.pwm_gain_V_A \
            / (la * je)
        r = v.armature_resistance_ohm + v.pwm_gain_V_A * v.current_feedback_gain
        kb = v.back_emf_V_s_rad + v.pwm_gain_V_A * v.current_amp_gain_A_V * v.tacho_gain \
            * v.tacho_constant_V_s_rad
        k3 = (v.viscous_friction_Nm_s_rad * r + v.torque_constant_Nm_A * kb) / (je * la)
        return k1, k3

    (k1x, k3x), (k1y, k3y) = k13(ax), k13(ay)
    ke = AX.encoder_counts_per_rev / (2 * math.pi)
    counts_per_mm = AX.encoder_counts_per_rev / AX.screw_pitch_mm
    f = feed_mm_s * counts_per_mm
    e = f * math.sin(2 * angle_rad) / 2 * bp / (CTRL.dac_gain_V_per_count * kpp * ke * ap) \
        * (k3y / k1y - k3x / k1x)
    return e / counts_per_mm


def test_line_contour_error_equals_4_91_and_vanishes_when_matched_or_axis_parallel():
    angles = [30.0, 0.0, 90.0, 30.0]
    refs = [interpolate(PathParams(kind="line", line_angle_deg=a, feed_mm_s=20.0,
                                   duration_s=1.0), T) for a in angles]
    res = simulate_contouring(refs, AX, [AY, AY, AY, AX], CTRL)
    steady = res.signals["contour_error_mm"][:, -1]
    expected = _closed_form_4_91(20.0, math.radians(30.0), AX, AY)
    assert expected > 0.02  # y lags more: the tool is right of the up-right line
    assert steady[0] == pytest.approx(expected, rel=1e-6)
    np.testing.assert_allclose(steady[1:], 0.0, atol=1e-9)
    # on a straight path the linear estimate is the exact error, sample by sample
    np.testing.assert_allclose(res.signals["linear_estimate_mm"], res.signals["contour_error_mm"],
                               atol=1e-9)


def test_mismatched_diamond_incoming_line_has_the_closed_form_error():
    ref = interpolate(PathParams(kind="diamond", feed_per_axis_mm_s=20.0), T)
    res = simulate_contouring([ref, ref], AX, [AY, AX], CTRL)
    k_v = int(round(ref.vertex_time_s / T))
    before = res.signals["contour_error_mm"][:, k_v - 5]
    expected = _closed_form_4_91(20.0 * math.sqrt(2), math.radians(45.0), AX, AY)
    assert before[0] == pytest.approx(expected, rel=1e-5)
    assert abs(before[1]) < 1e-9
    # the corner error is larger than the line error and peaks after the vertex
    e = np.abs(res.signals["contour_error_mm"][0])
    assert e.max() > 3 * expected and e.argmax() > k_v


def test_switched_integrator_times_follow_the_path_distances():
    ref = interpolate(PathParams(kind="diamond", feed_per_axis_mm_s=20.0), T)
    ctrl = replace(CTRL, integrator_form="discrete_parallel", integrator_gain_per_sample=1e-3)
    sw = switched_integrator(ctrl, ref, off_before_vertex_mm=2.0, on_after_vertex_mm=4.0)
    speed = 20.0 * math.sqrt(2)
    assert sw.integrator_off_from_s == pytest.approx(ref.vertex_time_s - 2.0 / speed, abs=T)
    assert sw.integrator_on_from_s == pytest.approx(ref.vertex_time_s + 4.0 / speed, abs=T)
    with pytest.raises(ValueError, match="integrator_form"):
        switched_integrator(CTRL, ref, 1.0, 1.0)


def test_circle_radial_error_equals_the_closed_loop_gain():
    """Steady radial error of a circle R (|G_cl(e^{j w T})| - 1), w = f/R (spec A0-2), with
    G_cl written here from the sampled loop's state space by python-control."""
    import control

    from acc.design.axis_analysis import sampled_position_loop

    r, f = 5.0, 20.0
    ref = interpolate(PathParams(kind="circle", radius_mm=r, feed_mm_s=f, revolutions=1.0), T)
    res = simulate_contouring(ref, AX, AX, CTRL)
    loop = sampled_position_loop(AX, CTRL, T, "counts")  # (2.31): x = [V_d, I_a, W, X_a]
    g = control.ss(loop.A, loop.B[:, :1], np.array([[0.0, 0.0, 0.0, 1.0]]), 0.0, T)
    w = f / r
    expected = r * (abs(complex(np.squeeze(g(np.exp(1j * w * T))))) - 1.0)
    rho = np.hypot(res.signals["x_mm"][0], res.signals["y_mm"][0]) - r
    half = rho.size // 2
    assert expected < -1e-3  # the loop shrinks the circle
    np.testing.assert_allclose(rho[half:], expected, rtol=1e-4)
    # clockwise: the inside is to the right, so the exact contour error is -rho
    np.testing.assert_allclose(res.signals["contour_error_mm"][0], -rho, atol=1e-12)


def test_velocity_feedforward_removes_the_ramp_error_of_its_own_axis():
    from acc.design.axis_analysis import ramp_following_error_mm
    from acc.engine.axis_simulate import simulate_axis
    from controllers.axis.trajectory import TrajectoryParams
    from controllers.contouring.feedforward import velocity_feedforward_pid

    ff = velocity_feedforward_pid(AX, CTRL)
    p_only = replace(ff, ff1_s_per_mm=0.0)
    ramp = TrajectoryParams(kind="ramp", feed_mm_s=20.0, start_s=0.01)
    res = simulate_axis([AX, AX, AY], [ff, p_only, ff], ramp, duration_s=1.0, plant_step_s=T)
    e = res.signals["following_error_mm"][:, -1]
    assert abs(e[0]) < 1e-9
    # P only with the lead-lag's DC gain: the lead-lag's steady error (4.85)
    assert e[1] == pytest.approx(ramp_following_error_mm(AX, CTRL, T, 20.0), rel=1e-6)
    # the y axis (B = 0.3) keeps the difference of the two axes' errors
    diff = ramp_following_error_mm(AY, CTRL, T, 20.0) - ramp_following_error_mm(AX, CTRL, T, 20.0)
    assert e[2] == pytest.approx(diff, rel=1e-6)


def test_coulomb_friction_gives_reversal_glitches_at_the_quadrants():
    """Coulomb friction flips at each axis reversal: x reverses at 90 and 270 deg, y at 0 and
    180 deg of Peng's circle, so the glitches sit there, equal by symmetry; the linear axes
    draw a clean circle (no glitch)."""
    from controllers.monitoring.circular_test import evaluate_circle

    coulomb = replace(AX, friction_model="coulomb_viscous", coulomb_friction_Nm=0.75)
    ref = interpolate(PathParams(kind="circle", radius_mm=10.0, feed_mm_s=20.0,
                                 revolutions=1.25), T)
    res = simulate_contouring([ref, ref], [AX, coulomb], [AX, coulomb], CTRL)
    k0 = ref.samples // 5  # after the start from rest
    clean, glitchy = (evaluate_circle(res.position_mm(i)[k0:], (0.0, 0.0), 10.0) for i in (0, 1))
    np.testing.assert_allclose(clean.glitch_height_mm, 0.0, atol=1e-9)
    gap = (glitchy.glitch_angle_deg - [0.0, 90.0, 180.0, 270.0] + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(gap, 0.0, atol=0.5)
    h = glitchy.glitch_height_mm
    assert h.min() > 1e-3  # micrometres, against 1e-9 for the linear axes
    np.testing.assert_allclose(h, h.mean(), rtol=0.01)
