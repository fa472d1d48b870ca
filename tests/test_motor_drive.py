"""Tests of the feed-screw and spindle motor drive models (plants.motor_drive)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from plants.motor_drive import (
    DEFAULT_SPINDLE_MOTOR,
    BallScrew,
    ServoMotor,
    SpeedControlledDrive,
    SpindleTransmission,
)

DT = 1e-4


def test_ball_screw_reflection_matches_peng():
    # Peng (UBC thesis, Sec. 3.2): lead 5.08 mm, efficiency 0.89 -> reflected torque
    # "approximately 9.0e-4" of the feed force; exact value p / (2 pi eta).
    screw = BallScrew()
    assert screw.torque_per_force_m == pytest.approx(9.0e-4, rel=0.01)
    assert screw.torque_per_force_m == pytest.approx(5.08e-3 / (2 * math.pi * 0.89), rel=1e-15)
    np.testing.assert_allclose(screw.force_N(screw.motor_torque_Nm([1.0, 500.0])), [1.0, 500.0],
                               rtol=1e-15)
    # 60 s * speed / (2 pi) turns per minute times lead = feedrate
    assert screw.feedrate_mm_min(screw.motor_speed_rad_s(140.0)) == pytest.approx(140.0)


def test_spindle_transmission_round_trip():
    tr = SpindleTransmission(ratio=2.5, efficiency=0.9)
    assert tr.spindle_torque_Nm(tr.motor_torque_Nm(4.0)) == pytest.approx(4.0, rel=1e-15)
    assert tr.motor_speed_rad_s(600.0) == pytest.approx(2.5 * 600 * 2 * math.pi / 60)


@pytest.mark.parametrize("motor", [ServoMotor(), DEFAULT_SPINDLE_MOTOR])
def test_step_is_exact_zero_order_hold(motor):
    # One step against the matrix exponential of the augmented system
    # [w; u]' = [[-B/J, 1/J], [0, 0]] [w; u] with u = K_t I - T_f sign(w) - T_d held.
    drive = SpeedControlledDrive(motor, 300.0, DT, runs=3)
    state = drive.init(np.array([10.0, -4.0, 0.5]))
    state["integral_A"] = [1.0, -2.0, 0.3]
    ref = np.array([12.0, -3.0, 0.0])
    load = np.array([0.4, -0.2, 0.1])
    new, out = drive.step(state, ref, load)
    a = np.array([[-motor.viscous_friction_Nm_s_rad / motor.inertia_kg_m2,
                   1 / motor.inertia_kg_m2], [0.0, 0.0]])
    phi = expm(a * DT)
    u = (motor.torque_constant_Nm_A * out.current_A
         - motor.coulomb_friction_Nm * np.sign(state["speed_rad_s"]) - load)
    expected = phi[0, 0] * state["speed_rad_s"] + phi[0, 1] * u
    np.testing.assert_allclose(new["speed_rad_s"], expected, rtol=1e-12, atol=1e-12)


def test_steady_state_current_balances_eq5():
    # With the PI integrator, at constant speed and load: K_t I = B w + T_f + T_d (Eq. 5).
    motor = ServoMotor()
    drive = SpeedControlledDrive(motor, 200.0, DT, runs=2)
    w_ref = np.array([5.0, 20.0])
    load = np.array([0.3, 0.8])
    _, out = drive.simulate(np.repeat(w_ref[:, None], 20000, axis=1),
                            np.repeat(load[:, None], 20000, axis=1),
                            state=drive.init(0.1))
    expected = (motor.viscous_friction_Nm_s_rad * w_ref + motor.coulomb_friction_Nm
                + load) / motor.torque_constant_Nm_A
    np.testing.assert_allclose(out.current_A[:, -1], expected, rtol=1e-9)
    np.testing.assert_allclose(out.speed_rad_s[:, -1], w_ref, rtol=1e-9)


def test_batch_equals_single_runs_and_inputs_not_mutated():
    drive3 = SpeedControlledDrive(ServoMotor(), 200.0, DT, runs=3)
    drive1 = SpeedControlledDrive(ServoMotor(), 200.0, DT, runs=1)
    rng = np.random.default_rng(7)
    ref = rng.uniform(-10, 10, (3, 200))
    load = rng.uniform(-1, 1, (3, 200))
    ref_copy, load_copy = ref.copy(), load.copy()
    _, batch = drive3.simulate(ref, load)
    for i in range(3):
        _, single = drive1.simulate(ref[i:i + 1], load[i:i + 1])
        np.testing.assert_array_equal(batch.current_A[i], single.current_A[0])
    np.testing.assert_array_equal(ref, ref_copy)
    np.testing.assert_array_equal(load, load_copy)


@pytest.mark.parametrize(
    "factory,match",
    [
        (lambda: ServoMotor(inertia_kg_m2=0.0), "inertia_kg_m2"),
        (lambda: ServoMotor(coulomb_friction_Nm=-1.0), "coulomb_friction_Nm"),
        (lambda: BallScrew(efficiency=1.2), "efficiency"),
        (lambda: BallScrew(lead_mm=0.0), "lead_mm"),
        (lambda: SpeedControlledDrive(ServoMotor(), 1e4, DT, 1), "speed_loop_bandwidth_rad_s"),
    ],
)
def test_bad_parameters_raise(factory, match):
    with pytest.raises(ValueError, match=match):
        factory()
