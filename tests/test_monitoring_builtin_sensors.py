"""Built-in-sensor monitoring (Xu et al.): dual feedback, kinematic chain, lead error.

Numbers from: the injected error model (recovered exactly without noise), closed forms of
the HTM algebra and of the CKG6800 chain written here, Eq. 12 as printed, and Table 1 of seed
003 (L154-L158) for the thread identity v_z = L n_C."""

import math

import numpy as np
import pytest

from controllers.monitoring.builtin_sensors import (
    dual_feedback_deviation_mm,
    identify_axis_errors,
    lead_error_metrics,
    lead_error_mm,
    thread_z_feed_mm_min,
)
from controllers.monitoring.machine_kinematics import (
    Body,
    KinematicChain,
    ckg6800_chain,
    inverse,
    machining_error,
    rotation,
    translation,
    xu_eq12_as_printed,
)
from plants.axis.axis_errors import (
    AxisErrorParams,
    builtin_signals,
    motion_direction,
    table_error_mm,
)

KNOTS = np.linspace(0.0, 400.0, 9)
MAP_UM = (0.0, 3.0, -2.0, 4.0, 1.0, -1.0, 5.0, 2.0, 0.0)
AXIS = AxisErrorParams(
    screw_lead_mm=10.0, reduction_ratio=2.0, accumulated_lead_error_um_per_m=25.0,
    periodic_error_um=1.5, pitch_map_positions_mm=tuple(KNOTS), pitch_map_um=MAP_UM,
    backlash_um=6.0, axial_stiffness_N_um=150.0,
)


def _back_and_forth(n=6000):
    s = np.linspace(0, 3, n)
    u = 200.0 - 190.0 * np.cos(2 * np.pi * s)  # 10..390 mm, three cycles
    force = 300.0 * np.sin(7.1 * s) + 150.0 * np.cos(2.3 * s)
    return u / AXIS.travel_per_rev_mm, force


def test_deviation_in_rev_and_rad():
    theta, d = builtin_signals(AXIS, *_back_and_forth())
    a = dual_feedback_deviation_mm(d, theta, 10.0, 2.0)
    b = dual_feedback_deviation_mm(d, 2 * np.pi * theta, 10.0, 2.0, angle_unit="rad")
    np.testing.assert_allclose(a, d - 5.0 * theta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_recovers_the_injected_pitch_map_backlash_and_compliance():
    theta, force = _back_and_forth()
    theta_en, d = builtin_signals(AXIS, theta, force)
    u = AXIS.travel_per_rev_mm * theta_en
    e = dual_feedback_deviation_mm(d, theta_en, 10.0, 2.0)
    res = identify_axis_errors(e, u, motion_direction(u), force, KNOTS, screw_lead_mm=10.0)
    expected_map = 1e-3 * np.asarray(MAP_UM) + 25.0 * 1e-6 * KNOTS  # 25 um/m accumulated
    np.testing.assert_allclose(res.pitch_map_mm, expected_map, rtol=0, atol=1e-9)
    assert res.backlash_mm == pytest.approx(6e-3, abs=1e-10)
    assert res.compliance_mm_N == pytest.approx(1e-3 / 150.0, rel=1e-7)
    assert res.periodic_amplitude_mm == pytest.approx(1.5e-3, abs=1e-10)
    assert np.max(np.abs(res.residual_mm)) < 1e-10
    assert sum(res.shares.values()) > 0.5 and set(res.shares) == {
        "pitch", "periodic", "backlash", "elastic"}


def test_semi_and_full_closed_loop_with_pitch_compensation():
    x = np.linspace(10, 390, 200)
    semi = table_error_mm(AXIS, x)
    np.testing.assert_allclose(semi, AXIS.pitch_error_mm(x) - 3e-3, atol=1e-12)  # moving +
    comp = -AXIS.pitch_error_mm(x)
    compensated = table_error_mm(AXIS, x, compensation_mm=comp)
    # what remains is the pitch error's change over the compensation plus backlash
    residual = AXIS.pitch_error_mm(x + comp) - AXIS.pitch_error_mm(x)
    np.testing.assert_allclose(compensated, residual - 3e-3, atol=1e-12)
    assert np.all(table_error_mm(AXIS, x, mode="full_closed") == 0.0)


def test_htm_algebra():
    rng = np.random.default_rng(1)
    for _ in range(5):
        t = rotation(rng.normal(size=3), rng.normal()) @ translation(rng.normal(size=3))
        np.testing.assert_allclose(t @ inverse(t), np.eye(4), atol=1e-12)
        np.testing.assert_allclose(inverse(t) @ t, np.eye(4), atol=1e-12)
        np.testing.assert_allclose(inverse(t), np.linalg.inv(t), atol=1e-12)
    # rotation about z by 90 deg takes x to y
    np.testing.assert_allclose(rotation((0, 0, 1), math.pi / 2) @ [1, 0, 0, 1], [0, 1, 0, 1],
                               atol=1e-15)


def test_ckg6800_chains_and_eq12():
    rng = np.random.default_rng(2)
    c = rng.uniform(-10, 10, 50)
    x = rng.uniform(-50, 50, 50)
    z = rng.uniform(2500, 3200, 50)
    q = {"C": c, "X": x, "Z": z}
    printed = xu_eq12_as_printed(c, x, z, 120.0, -30.0)
    as_printed = ckg6800_chain(120.0, -30.0, chain="as_printed").tool_in_workpiece(q)
    np.testing.assert_allclose(as_printed, printed, atol=1e-9)
    consistent = ckg6800_chain(120.0, -30.0).tool_in_workpiece(q)
    tip = np.array([0.3, -0.2, 1.5, 1.0])  # a tool point off the tool origin
    pc, pp = consistent @ tip, printed @ tip
    np.testing.assert_allclose(pc[:, 2], pp[:, 2], atol=1e-9)  # z agrees (lead error)
    # consistent cutter point at the tool origin: R_z(-C) (X + W_x, 0, Z + W_z)
    origin = consistent[:, :3, 3]
    expected = np.column_stack([np.cos(c) * (x + 120), -np.sin(c) * (x + 120), z - 30])
    np.testing.assert_allclose(origin, expected, atol=1e-9)


def test_machining_error_vectors():
    z_err, ey = 0.004, 1e-4
    chain = KinematicChain(
        (Body("Z", "prismatic", (0, 0, 1), error=(0, 0, z_err, 0, ey, 0)),
         Body("X", "prismatic", (1, 0, 0))), ())
    q_ideal = {"Z": np.array([10.0, 20.0]), "X": np.array([5.0, 6.0])}
    q_real = {"Z": q_ideal["Z"] + 0.001, "X": q_ideal["X"]}
    e_m, e_v, path = machining_error(chain, q_real, q_ideal, (0, 0, 0), (0, 0, 1))
    # the error rotation ey about y tilts z to (sin ey, 0, cos ey) and moves the X offset
    np.testing.assert_allclose(e_v, [[ey, 0, 0], [ey, 0, 0]], atol=1e-15)
    expected_z = 0.001 + z_err - ey * q_ideal["X"]  # first-order HTM: z_x = -ey x
    np.testing.assert_allclose(e_m[:, 2], expected_z, atol=1e-12)
    np.testing.assert_allclose(path[:, 0], q_ideal["X"], atol=1e-12)


def test_thread_kinematics_table_1():
    # seed 003 L154-L158: Z feed [mm/min], lead [mm], C speed [r/min]
    rows = [(250, 10, 25), (400, 16, 25), (500, 10, 50), (1000, 40, 25), (1250, 50, 25)]
    for vz, lead, nc in rows:
        assert thread_z_feed_mm_min(lead, nc) == vz


def test_lead_error_and_its_metrics():
    lead = 40.0
    c = np.linspace(0, 2 * np.pi * 17.5, 7001)  # 700 mm of thread
    z_ideal = 2500.0 + lead * c / (2 * np.pi)
    ripple = 0.004 * np.sin(2 * np.pi * (z_ideal - 2500) / 93.0)
    z = z_ideal + 2e-5 * (z_ideal - 2500) + ripple  # 20 um/m accumulated
    e = lead_error_mm(z, c, lead, 2500.0)
    np.testing.assert_allclose(e, 2e-5 * (z_ideal - 2500) + ripple, atol=1e-10)
    m = lead_error_metrics(z, e)
    slope, icpt = np.polyfit(z, e, 1)  # independent line fit
    assert m.slope_mm_per_mm == pytest.approx(slope, rel=1e-9)
    assert m.fluctuation_mm == pytest.approx(np.ptp(e - (slope * z + icpt)), rel=1e-9)
    pure = lead_error_metrics(z_ideal, 2e-5 * (z_ideal - 2500))
    assert pure.accumulated_mm == pytest.approx(2e-5 * 700, rel=1e-9)
    assert pure.fluctuation_mm == pytest.approx(0.0, abs=1e-12)
    assert lead_error_metrics(z, e, fluctuation_definition="raw_ptp").fluctuation_mm == (
        pytest.approx(np.ptp(e)))
