"""Lacerda & Belo's elastic axis (spec M1-1): series stiffness, resonance, rigid limit,
Coulomb stick, encoder quantisation.  Every number comes from a closed form or from an
independent computation written here (numpy eig, scipy cont2discrete)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import cont2discrete

from acc.engine.element import output_runs, step_runs
from plants.axis.elastic_axis import ElasticAxisParams, elastic_axis_records, xy_table_defaults

RHO = 5e-3 / (2 * math.pi)  # m/rad, 5 mm lead


def _linear(**kw: object) -> ElasticAxisParams:
    """An axis without friction, current limit or quantisation (its linear part)."""
    base = dict(coulomb_friction_N=0.0, current_limit_A=0.0, encoder_quantisation=False)
    base.update(kw)
    return ElasticAxisParams(**base)


def test_series_stiffness_eq1():
    a = ElasticAxisParams(coupling_stiffness_Nm_rad=1800.0, screw_torsional_stiffness_Nm_rad=600.0,
                          screw_axial_stiffness_N_m=2e8, bearing_axial_stiffness_N_m=4e8)
    expected = 1.0 / (1 / 1800.0 + 1 / 600.0 + 1 / (RHO**2 * 2e8) + 1 / (RHO**2 * 4e8))
    assert a.combined_stiffness_Nm_rad == pytest.approx(expected, rel=1e-12)
    # the [ASSUMED] defaults of spec M1-3 "give K = 62 N m/rad"
    assert ElasticAxisParams().combined_stiffness_Nm_rad == pytest.approx(62.0, abs=0.05)


def _hand_A(a: ElasticAxisParams) -> np.ndarray:
    """Eqs. (2), (4), (5) written out, states [th1, w1, th2, w2, i]."""
    i1, i2 = a.motor_inertia_kg_m2, a.carriage_mass_kg * RHO**2
    k = a.combined_stiffness_Nm_rad
    c, b1 = a.spring_damping_Nm_s_rad, a.motor_viscous_Nm_s_rad
    b2 = a.guideway_viscous_N_s_m * RHO**2
    kt, kb, ra, la = (a.torque_constant_Nm_A, a.back_emf_V_s_rad, a.armature_resistance_ohm,
                      a.armature_inductance_H)
    return np.array([
        [0, 1, 0, 0, 0],
        [-k / i1, -(b1 + c) / i1, k / i1, c / i1, kt / i1],
        [0, 0, 0, 1, 0],
        [k / i2, c / i2, -k / i2, -(b2 + c) / i2, 0],
        [0, -kb / la, 0, 0, -ra / la],
    ])


def test_state_matrix_equals_the_equations():
    a = ElasticAxisParams(spring_damping_Nm_s_rad=0.02, motor_viscous_Nm_s_rad=1e-3)
    A, B = a.continuous_matrices()
    np.testing.assert_allclose(A, _hand_A(a), rtol=1e-14)
    assert B[4, 0] == 1 / a.armature_inductance_H
    assert B[1, 1] == -1 / a.motor_inertia_kg_m2
    assert B[3, 2] == pytest.approx(-1 / (a.carriage_mass_kg * RHO**2), rel=1e-14)


@pytest.mark.parametrize("mass_kg", [30.0, 60.0, 5.0])
def test_two_inertia_resonance_equals_eig(mass_kg):
    a = ElasticAxisParams(carriage_mass_kg=mass_kg)
    i1, i2, k = a.motor_inertia_kg_m2, mass_kg * RHO**2, a.combined_stiffness_Nm_rad
    mech = np.array([[0, 1, 0, 0], [-k / i1, 0, k / i1, 0], [0, 0, 0, 1], [k / i2, 0, -k / i2, 0]])
    w = np.linalg.eigvals(mech)
    assert a.resonance_rad_s == pytest.approx(np.max(np.abs(w.imag)), rel=1e-9)
    assert np.max(np.abs(w.real)) < 1e-6 * a.resonance_rad_s  # undamped pair + rigid mode


def test_spec_resonances_of_the_defaults():
    x, y = xy_table_defaults()
    assert x.resonance_Hz == pytest.approx(305.0, abs=1.0)  # spec M1-3 "~305 Hz (x)"
    assert y.resonance_Hz == pytest.approx(228.0, abs=1.0)  # "228 Hz (y)"


def _open_loop(axis: ElasticAxisParams, commands: np.ndarray, dt: float,
               load_N: float = 0.0) -> np.ndarray:
    """Carriage positions [mm] at the start of each step, commands held per step."""
    p, s = elastic_axis_records(axis, dt)
    out = np.empty(len(commands))
    for k, u in enumerate(commands):
        out[k] = step_runs(p, s, u, load_N)[0][0]
    return out


def _rigid_reference(axis: ElasticAxisParams, commands: np.ndarray, dt: float) -> np.ndarray:
    """The three-state motor with I = I1 + I2, B = B1 + B2 (written here), scipy's ZOH."""
    i = axis.motor_inertia_kg_m2 + axis.carriage_mass_kg * RHO**2
    b = axis.motor_viscous_Nm_s_rad + axis.guideway_viscous_N_s_m * RHO**2
    la = axis.armature_inductance_H
    A = np.array([[0, 1, 0], [0, -b / i, axis.torque_constant_Nm_A / i],
                  [0, -axis.back_emf_V_s_rad / la, -axis.armature_resistance_ohm / la]])
    B = np.array([[0], [0], [axis.amplifier_gain_V_V / la]])
    G, H, *_ = cont2discrete((A, B, np.eye(3), np.zeros((3, 1))), dt, method="zoh")
    x = np.zeros(3)
    out = np.empty(len(commands))
    for k, u in enumerate(commands):
        out[k] = 1e3 * RHO * x[0]
        x = G @ x + H[:, 0] * u
    return out


def test_rigid_limit_equals_three_state_motor():
    dt = 1e-4
    k = np.arange(400)
    commands = 2.0 * np.sin(2 * np.pi * 15 * k * dt) + 0.5
    rigid = _rigid_reference(_linear(), commands, dt)
    errors = []
    for scale in (1.0, 1e2, 1e4):
        stiff = _linear(coupling_stiffness_Nm_rad=2000.0 * scale,
                        screw_torsional_stiffness_Nm_rad=514.0 * scale,
                        screw_axial_stiffness_N_m=1.5e8 * scale,
                        bearing_axial_stiffness_N_m=5e8 * scale)
        x = _open_loop(stiff, commands, dt)
        errors.append(np.max(np.abs(x - rigid)) / np.max(np.abs(rigid)))
    assert errors[0] > 3e-4  # the elastic axis differs visibly from a rigid one
    assert errors[2] < 2e-7  # K -> inf: the three-state motor model
    assert 50 < errors[1] / errors[2] < 200  # and the difference falls as 1/K


def test_coulomb_stick_within_level_closed_form():
    """At rest with no command, a feed force |F| <= F_C is balanced by friction exactly."""
    dt = 1e-4
    for where in ("motor", "carriage"):
        axis = ElasticAxisParams(coulomb_friction_N=20.0, friction_on=where,
                                 encoder_quantisation=False)
        for force in (19.9, -19.9, 20.0, -20.0):
            x = _open_loop(axis, np.zeros(50), dt, load_N=force)
            assert np.all(x == 0.0), (where, force)


def test_coulomb_breakaway_acceleration_closed_form():
    """Above the level the loaded body starts with (rho (F - F_C)) / I against the force."""
    dt = 1e-7
    for where, inertia in (("motor", 1.5e-4), ("carriage", 30.0 * RHO**2)):
        axis = ElasticAxisParams(coulomb_friction_N=20.0, friction_on=where,
                                 encoder_quantisation=False)
        for force in (30.0, -45.0):
            p, s = elastic_axis_records(axis, dt)
            step_runs(p, s, 0.0, force)
            body = 1 if where == "motor" else 3
            w = s["x"][0, body]
            net = force - math.copysign(20.0, force)
            assert w == pytest.approx(-RHO * net / inertia * dt, rel=1e-3), (where, force)


def test_encoder_quantisation_5um():
    axis = ElasticAxisParams(coulomb_friction_N=0.0)
    assert 1 / axis.counts_per_mm == pytest.approx(0.005)  # L270: 1000 pulses on 5 mm
    p, s = elastic_axis_records([axis, replace(axis, encoder_quantisation=False)], 1e-4,
                                initial_position_mm=[1.0123, 1.0123])
    xm = output_runs(p, s, 0.0)[0]
    assert xm[0] == pytest.approx(1.010, abs=1e-12)  # nearest whole count
    assert xm[1] == pytest.approx(1.0123, abs=1e-12)


def test_bad_parameter_names_the_key():
    with pytest.raises(ValueError, match="carriage_mass_kg"):
        ElasticAxisParams(carriage_mass_kg=-1.0)
    with pytest.raises(ValueError, match="friction_on"):
        ElasticAxisParams(friction_on="table")


@pytest.mark.parametrize("where", ["motor", "carriage"])
def test_coulomb_dissipates_and_sticks_without_chatter(where):
    """Spec risk 6: coasting from 50 rad/s with no command and no load, the stored energy
    (kinetic, spring, magnetic) never grows from step to step, and the loaded body comes to
    rest and stays exactly at rest (no chatter of the held friction around zero speed)."""
    axis = ElasticAxisParams(coulomb_friction_N=200.0, friction_on=where,
                             encoder_quantisation=False)
    p, s = elastic_axis_records(axis, 1e-4)
    s["x"][0] = [0.0, 50.0, 0.0, 50.0, 0.0]
    i1, i2 = axis.motor_inertia_kg_m2, axis.load_inertia_kg_m2
    k, la = axis.combined_stiffness_Nm_rad, axis.armature_inductance_H
    body = 1 if where == "motor" else 3
    energy, speed, angle = [], [], []
    for _ in range(3000):
        th1, w1, th2, w2, i = s["x"][0]
        energy.append(0.5 * (i1 * w1**2 + i2 * w2**2 + k * (th1 - th2) ** 2 + la * i**2))
        speed.append(s["x"][0][body])
        angle.append(s["x"][0][body - 1])
        step_runs(p, s, 0.0, 0.0)
    energy = np.array(energy)
    assert np.all(np.diff(energy) <= 1e-12 * energy[0])
    stopped = int(np.argmax(np.array(speed) == 0.0))
    assert 0 < stopped < 1500
    tail = slice(stopped + 200, None)
    assert np.all(np.array(speed)[tail] == 0.0)
    assert np.ptp(np.array(angle)[tail]) == 0.0
