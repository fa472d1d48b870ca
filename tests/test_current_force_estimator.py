"""Tests of air-cut identification and force estimation from motor currents."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.current_force_estimator import (
    CurrentLoadEstimator,
    feed_force_from_current,
    identify_drive_from_air_cuts,
    load_torque_from_current,
    tangential_force_from_current,
    tooth_period_average,
)
from plants.cutting_coefficients import CuttingCoefficients
from plants.end_mill_geometry import EndMill, MillingCut, forces_vs_time, tooth_period_s
from plants.motor_drive import (
    DEFAULT_SPINDLE_MOTOR,
    BallScrew,
    ServoMotor,
    SpeedControlledDrive,
    SpindleTransmission,
)

DT = 1e-4
SIGMA_A = 0.05  # current-sensor noise [A]
TOOL = EndMill()
SCREW = BallScrew()
SPINDLE = SpindleTransmission()
FEED_MOTOR = ServoMotor()


def _air_cut(motor, speeds_rad_s, hold=2000):
    drive = SpeedControlledDrive(motor, 200.0, DT, runs=1)
    _, out = drive.simulate(np.repeat(speeds_rad_s, hold)[None, :], 0.0)
    return out.current_A, out.speed_rad_s


FEED_SPEEDS = SCREW.motor_speed_rad_s(np.array([50, 200, 800, 2000, -50, -200, -800, -2000.0]))


def test_air_cut_identification_is_exact_without_noise():
    # The regression is the exact discrete form of Eq. 5: recovery to round-off.
    current, speed = _air_cut(FEED_MOTOR, FEED_SPEEDS)
    ident = identify_drive_from_air_cuts(current, speed, 0.3, DT)
    assert ident.inertia_kg_m2 == pytest.approx(FEED_MOTOR.inertia_kg_m2, rel=1e-8)
    assert ident.viscous_friction_Nm_s_rad == pytest.approx(0.09, rel=1e-9)
    assert ident.coulomb_friction_Nm == pytest.approx(0.75, rel=1e-9)


def test_air_cut_identification_with_noise_within_four_standard_errors():
    # Noise only on the left side (current), so OLS is unbiased with covariance
    # (K_t sigma)^2 (X^T X)^-1; 4 standard errors per parameter.
    current, speed = _air_cut(FEED_MOTOR, FEED_SPEEDS)
    rng = np.random.default_rng(11)
    noisy = current + SIGMA_A * rng.standard_normal(current.shape)
    ident = identify_drive_from_air_cuts(noisy, speed, 0.3, DT)
    exact = identify_drive_from_air_cuts(current, speed, 0.3, DT)
    w = speed[0, :-1]
    x = np.column_stack([np.diff(speed[0]) / DT, w, np.sign(w)])
    se = 0.3 * SIGMA_A * np.sqrt(np.diag(np.linalg.inv(x.T @ x)))
    found = [ident.effective_inertia_kg_m2, ident.viscous_friction_Nm_s_rad,
             ident.coulomb_friction_Nm]
    true = [exact.effective_inertia_kg_m2, 0.09, 0.75]
    assert np.all(np.abs(np.subtract(found, true)) < 4 * se)


def _cut_currents(rng, sigma):
    """Feed and spindle currents over a 1 s cut (a_e 3 mm, a 10 mm, 120 mm/min)."""
    n = 10000
    t = np.arange(n) * DT
    cut = MillingCut(radial_depth_mm=3.0, axial_depth_mm=10.0)
    forces = forces_vs_time(TOOL, cut, CuttingCoefficients(), t, feedrate_mm_min=120.0)
    feed = SpeedControlledDrive(FEED_MOTOR, 200.0, DT, 1)
    _, fo = feed.simulate(SCREW.motor_speed_rad_s(120.0), SCREW.motor_torque_Nm(forces.feed_N))
    spindle = SpeedControlledDrive(DEFAULT_SPINDLE_MOTOR, 200.0, DT, 1)
    torque = SPINDLE.motor_torque_Nm(forces.spindle_torque_Nm(TOOL))
    _, so = spindle.simulate(SPINDLE.motor_speed_rad_s(600.0), torque)
    noisy_f = fo.current_A + sigma * rng.standard_normal(fo.current_A.shape)
    noisy_s = so.current_A + sigma * rng.standard_normal(so.current_A.shape)
    return forces, (noisy_f, fo.speed_rad_s), (noisy_s, so.speed_rad_s)


def _identify(motor, speeds, rng, sigma):
    current, speed = _air_cut(motor, speeds)
    noisy = current + sigma * rng.standard_normal(current.shape)
    return identify_drive_from_air_cuts(noisy, speed, motor.torque_constant_Nm_A, DT)


@pytest.mark.parametrize("sigma", [0.0, SIGMA_A])
def test_estimator_recovers_feed_and_tangential_force(sigma):
    # Noise-free: the inverse of the exact discrete drive recovers each sample's force
    # (1e-7 relative: round-off amplified by J_e dw/dt).  With current noise: the error of
    # a tooth-period average is dominated by the noise, sigma_F = K_t sigma / (g sqrt(m))
    # (g: torque per force, m: samples per tooth period); parameter errors from the noisy
    # air cuts add ~10 %; bound 1.5 sigma_F on the RMS over 40 tooth periods.
    rng = np.random.default_rng(2024)
    spindle_speeds = SPINDLE.motor_speed_rad_s(np.array([300, 600, 1200, 2400, -600.0]))
    feed_id = _identify(FEED_MOTOR, FEED_SPEEDS, rng, sigma)
    spindle_id = _identify(DEFAULT_SPINDLE_MOTOR, spindle_speeds, rng, sigma)
    forces, (fi, fw), (si, sw) = _cut_currents(rng, sigma)
    feed_est = feed_force_from_current(feed_id, SCREW, fi, fw)[0]
    tang_est = tangential_force_from_current(spindle_id, SPINDLE, TOOL, si, sw)[0]
    m = round(tooth_period_s(TOOL, 600.0) / DT)
    true_feed, true_tang = forces.feed_N[:-1], forces.tangential_N[:-1]
    if sigma == 0:
        np.testing.assert_allclose(feed_est, true_feed, atol=1e-7 * np.abs(true_feed).max())
        np.testing.assert_allclose(tang_est, true_tang, atol=1e-7 * np.abs(true_tang).max())
        return
    g_feed = SCREW.torque_per_force_m
    g_tang = TOOL.radius_mm * 1e-3 / (SPINDLE.ratio * SPINDLE.efficiency)
    for est, true, motor, g in ((feed_est, true_feed, FEED_MOTOR, g_feed),
                                (tang_est, true_tang, DEFAULT_SPINDLE_MOTOR, g_tang)):
        err = tooth_period_average(est, m) - tooth_period_average(true, m)
        predicted = motor.torque_constant_Nm_A * sigma / (g * np.sqrt(m))
        assert np.sqrt(np.mean(err**2)) < 1.5 * predicted


def test_step_estimator_equals_array_estimator():
    rng = np.random.default_rng(5)
    current, speed = _air_cut(FEED_MOTOR, FEED_SPEEDS[:3], hold=100)
    ident = identify_drive_from_air_cuts(current + 0.01 * rng.standard_normal(current.shape),
                                         speed, 0.3, DT)
    est = CurrentLoadEstimator(ident, runs=1)
    state = est.init()
    outputs = []
    for k in range(current.shape[1]):
        state, torque = est.step(state, current[:, k], speed[:, k])
        outputs.append(torque[0])
    np.testing.assert_allclose(outputs[1:], load_torque_from_current(ident, current, speed)[0],
                               rtol=1e-12, atol=1e-12)
    assert outputs[0] == 0.0


def test_identification_needs_two_speeds():
    with pytest.raises(ValueError, match="speed_rad_s"):
        identify_drive_from_air_cuts(np.ones(10), np.full(10, 3.0), 0.3, DT)
