"""The XY-table loop: uncoupled axes equal their single-axis runs bit for bit; the linear
loop equals a reference loop written here from the equations (scipy's ZOH, a plain PID)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import cont2discrete

from acc.engine.axis_simulate import simulate_axis
from acc.engine.xy_simulate import XYReference, simulate_xy
from controllers.axis.pid import AxisPIDParams
from controllers.contouring.cross_coupled import CrossCoupledParams
from controllers.contouring.interpolator import PathParams, interpolate
from plants.axis.constant_angle_force import ConstantAngleForceParams
from plants.axis.elastic_axis import ElasticAxisParams, xy_table_defaults
from plants.axis.servo_axis import ServoAxisParams

DT = 1e-4
PERIOD = 1e-3


def _circle(radius_mm: float = 10.0, feed_mm_s: float = 100.0) -> XYReference:
    path = interpolate(PathParams(kind="circle", radius_mm=radius_mm, feed_mm_s=feed_mm_s,
                                  direction="ccw", revolutions=0.5), DT)
    return XYReference.from_path(path)


PID_X = AxisPIDParams(p_gain_per_mm=5.0, i_gain_per_mm_s=10.0, d_gain_s_per_mm=0.01,
                      max_output=10.0)
PID_Y = AxisPIDParams(p_gain_per_mm=4.0, i_gain_per_mm_s=15.0, d_gain_s_per_mm=0.012,
                      max_output=10.0)


@pytest.mark.parametrize("axis_kind", ["elastic", "servo"])
def test_uncoupled_axes_equal_single_axis_runs_bit_for_bit(axis_kind):
    ref = _circle()
    n = ref.samples
    if axis_kind == "elastic":
        ax, ay = xy_table_defaults()
        force = ConstantAngleForceParams(force_N=40.0, angle_deg=30.0)
        speed = np.hypot(ref.velocity_x_mm_s, ref.velocity_y_mm_s)
        fx, fy = force.loads(ref.tangent_angle_rad, speed)
    else:
        ax = ServoAxisParams()
        ay = ServoAxisParams(viscous_friction_Nm_s_rad=0.3)  # Peng's mismatched y
        fx = fy = None
    # CEC present but disabled, and with zero gains: both must leave the axes independent
    for cec in (None, CrossCoupledParams(enable=False, kp_V_per_mm=50.0),
                CrossCoupledParams(kp_V_per_mm=0.0)):
        xy = simulate_xy(ax, ay, PID_X, PID_Y, ref, cec=cec, load_x_N=fx, load_y_N=fy,
                         plant_step_s=DT, control_period_s=PERIOD, threads=1)
        for axis, pid, ref_row, load, name in ((ax, PID_X, ref.x_mm, fx, "x"),
                                               (ay, PID_Y, ref.y_mm, fy, "y")):
            single = simulate_axis(axis, pid, reference_samples_mm=ref_row,
                                   load_samples_N=load, duration_s=n * DT, plant_step_s=DT,
                                   control_period_s=PERIOD, threads=1)
            np.testing.assert_array_equal(xy.signal(f"{name}_mm")[0], single.signal("x_mm")[0])
            np.testing.assert_array_equal(xy.signal(f"{name}_meas_mm")[0],
                                          single.signal("x_meas_mm")[0])
            np.testing.assert_array_equal(xy.signal(f"command_{name}_V")[0],
                                          single.signal("command_V")[0])


def _pid_reference(kp: float, ki: float, kd: float, T: float):  # noqa: ANN202
    """A parallel PID written from A1-1 (backward-Euler integral, derivative of the error
    on the measurement and reference differences), state kept in a closure."""
    st = {"i": 0.0, "r": 0.0, "y": 0.0}

    def pid(r: float, y: float) -> float:
        e = r - y
        st["i"] += e * T
        d = ((r - st["r"]) - (y - st["y"])) / T
        st["r"], st["y"] = r, y
        return kp * e + ki * st["i"] + kd * d

    return pid


def _discrete_axis(a: ElasticAxisParams, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (6) written out with the command [V] as input, ZOH by scipy."""
    rho = a.screw_lead_mm * 1e-3 / (2 * math.pi)
    i1, i2, k = a.motor_inertia_kg_m2, a.carriage_mass_kg * rho**2, a.combined_stiffness_Nm_rad
    b2 = a.guideway_viscous_N_s_m * rho**2
    la = a.armature_inductance_H
    A = np.array([
        [0, 1, 0, 0, 0],
        [-k / i1, 0, k / i1, 0, a.torque_constant_Nm_A / i1],
        [0, 0, 0, 1, 0],
        [k / i2, 0, -k / i2, -b2 / i2, 0],
        [0, -a.back_emf_V_s_rad / la, 0, 0, -a.armature_resistance_ohm / la],
    ])
    B = np.array([[0], [0], [0], [0], [a.amplifier_gain_V_V / la]])
    G, H, *_ = cont2discrete((A, B, np.eye(5), np.zeros((5, 1))), dt, method="zoh")
    return G, H[:, 0]


@pytest.mark.parametrize("delays", ["none", "constant", "jitter"])
def test_linear_xy_loop_with_cec_equals_reference_loop(delays):
    """Linear axes (no friction, limits or quantisation), PID axes and a linear-model CEC:
    the compiled loop against the equations, sample by sample; also with the control
    instants delayed within their periods (sampling jitter, E1-4)."""
    lin = dict(coulomb_friction_N=0.0, current_limit_A=0.0, encoder_quantisation=False)
    ax = ElasticAxisParams(carriage_mass_kg=30.0, **lin)
    ay = ElasticAxisParams(carriage_mass_kg=60.0, guideway_viscous_N_s_m=350.0, **lin)
    px = AxisPIDParams(p_gain_per_mm=5.0, i_gain_per_mm_s=10.0, d_gain_s_per_mm=0.01)
    py = AxisPIDParams(p_gain_per_mm=4.0, i_gain_per_mm_s=15.0, d_gain_s_per_mm=0.012)
    cec = CrossCoupledParams(model="linear", kp_V_per_mm=3.0, ki_V_per_mm_s=10.0,
                             kd_V_s_per_mm=0.005)
    ref = _circle(radius_mm=5.0, feed_mm_s=50.0)
    m = round(PERIOD / DT)
    n_periods = -(-ref.samples // m)
    d = {"none": np.zeros(n_periods, int), "constant": np.full(n_periods, 3),
         "jitter": np.random.default_rng(7).integers(0, m, n_periods)}[delays]
    xy = simulate_xy(ax, ay, px, py, ref, cec=cec, plant_step_s=DT, control_period_s=PERIOD,
                     command_limit_V=0.0, threads=1,
                     control_delays_steps=None if delays == "none" else d)

    Gx, Hx = _discrete_axis(ax, DT)
    Gy, Hy = _discrete_axis(ay, DT)
    mpr = ax.screw_lead_mm / (2 * math.pi)  # mm per rad
    sx = np.zeros(5)
    sy = np.zeros(5)
    sx[0] = sx[2] = ref.x_mm[0] / mpr
    sy[0] = sy[2] = ref.y_mm[0] / mpr
    pid_x = _pid_reference(5.0, 10.0, 0.01, PERIOD)
    pid_y = _pid_reference(4.0, 15.0, 0.012, PERIOD)
    pid_c = _pid_reference(3.0, 10.0, 0.005, PERIOD)
    ux = uy = 0.0
    xs, ys = [], []
    for k in range(ref.samples):
        xr, yr, a = ref.x_mm[k], ref.y_mm[k], ref.tangent_angle_rad[k]
        xm, ym = sx[0] * mpr, sy[0] * mpr  # motor encoder, continuous
        if k % m == d[k // m]:
            eps = (xr - xm) * math.sin(a) - (yr - ym) * math.cos(a)  # Eq. (11)
            uc = pid_c(eps, 0.0)
            ux = pid_x(xr, xm) + uc * math.sin(a)
            uy = pid_y(yr, ym) - uc * math.cos(a)
        xs.append(sx[2] * mpr)
        ys.append(sy[2] * mpr)
        sx = Gx @ sx + Hx * ux
        sy = Gy @ sy + Hy * uy
    scale = np.max(np.abs(ref.x_mm))
    assert np.max(np.abs(np.array(xs) - ref.x_mm)) < 0.5  # a stable loop that tracks
    np.testing.assert_allclose(xy.signal("x_mm")[0], xs, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(xy.signal("y_mm")[0], ys, rtol=0, atol=1e-9 * scale)
    # the CEC acts: without it the paths differ by far more than the agreement above
    off = simulate_xy(ax, ay, px, py, ref, plant_step_s=DT, control_period_s=PERIOD,
                      command_limit_V=0.0, threads=1)
    assert np.max(np.abs(off.signal("y_mm")[0] - ys)) > 1e-4


def test_exact_contour_error_trace_equals_radial_deviation():
    """On a counter-clockwise circle the traced exact error is |P - C| - r (Eq. 17)."""
    ax, ay = xy_table_defaults()
    xy = simulate_xy(ax, ay, PID_X, PID_Y, _circle(), plant_step_s=DT, control_period_s=PERIOD)
    radial = np.hypot(xy.signal("x_mm")[0], xy.signal("y_mm")[0]) - 10.0
    np.testing.assert_allclose(xy.signal("contour_error_mm")[0], radial, atol=1e-12)
    iae = np.sum(np.abs(radial)) * DT
    assert xy.metrics["iae_contour_mm_s"][0] == pytest.approx(iae, rel=1e-9)


def test_mismatch_is_swept_per_run():
    """Per-run axes in one batch equal the same runs one at a time."""
    ax, ay = xy_table_defaults()
    ys = [ElasticAxisParams(carriage_mass_kg=m, coulomb_friction_N=35.0) for m in (40.0, 60.0,
                                                                                   90.0)]
    ref = _circle()
    batch = simulate_xy(ax, ys, PID_X, PID_Y, ref, cec=CrossCoupledParams(kp_V_per_mm=10.0),
                        plant_step_s=DT, control_period_s=PERIOD, record_every_steps=None)
    for r, y in enumerate(ys):
        one = simulate_xy(ax, y, PID_X, PID_Y, ref, cec=CrossCoupledParams(kp_V_per_mm=10.0),
                          plant_step_s=DT, control_period_s=PERIOD, record_every_steps=None)
        assert one.metrics["iae_contour_mm_s"][0] == batch.metrics["iae_contour_mm_s"][r]
    assert len(set(batch.metrics["iae_contour_mm_s"])) == 3


def test_sampling_jitter_draws_per_run_and_changes_the_run():
    ax, ay = xy_table_defaults()
    ref = _circle()
    kw = dict(plant_step_s=DT, control_period_s=PERIOD, record_every_steps=None)
    plain = simulate_xy(ax, ay, PID_X, PID_Y, ref, **kw)
    periods = -(-ref.samples // round(PERIOD / DT))
    zero = simulate_xy(ax, ay, PID_X, PID_Y, ref, control_delays_steps=np.zeros(periods, int),
                       **kw)
    assert zero.metrics["iae_contour_mm_s"][0] == plain.metrics["iae_contour_mm_s"][0]
    both = simulate_xy(ax, ay, PID_X, PID_Y, ref, sampling_jitter_steps=5, seed=3, runs=2, **kw)
    one = simulate_xy(ax, ay, PID_X, PID_Y, ref, sampling_jitter_steps=5, seed=3, **kw)
    assert both.metrics["iae_contour_mm_s"][0] == one.metrics["iae_contour_mm_s"][0]
    assert both.metrics["iae_contour_mm_s"][1] != one.metrics["iae_contour_mm_s"][0]
    assert one.metrics["iae_contour_mm_s"][0] != plain.metrics["iae_contour_mm_s"][0]


def test_bad_input_names_the_key():
    ax, ay = xy_table_defaults()
    with pytest.raises(ValueError, match="sampling_jitter_steps"):
        simulate_xy(ax, ay, PID_X, PID_Y, _circle(), sampling_jitter_steps=10)
    with pytest.raises(ValueError, match="control_period_s"):
        simulate_xy(ax, ay, PID_X, PID_Y, _circle(), plant_step_s=DT, control_period_s=1.5e-4)
    with pytest.raises(ValueError, match="axis_y"):
        simulate_xy(ax, [ay, ay], PID_X, PID_Y, _circle(), runs=3)


def test_constant_angle_cutting_force_eq10():
    """Eq. (10) [RECON]: the force makes the angle phi with the tangent; at phi = 0 it
    opposes the feed, at 90 deg it is normal to it; none at rest.  Eq. (8) as printed."""
    from plants.axis.constant_angle_force import ber_cutting_force_N

    alpha = np.array([0.3, 2.0, -1.0, 0.5])
    speed = np.array([10.0, 10.0, 10.0, 0.0])
    fx, fy = ConstantAngleForceParams(force_N=80.0, angle_deg=0.0).loads(alpha, speed)
    along = fx * np.cos(alpha) + fy * np.sin(alpha)  # loads are + against positive motion
    np.testing.assert_allclose(along, [80.0, 80.0, 80.0, 0.0], rtol=1e-14)
    fx, fy = ConstantAngleForceParams(force_N=80.0, angle_deg=90.0).loads(alpha, speed)
    np.testing.assert_allclose(fx * np.cos(alpha) + fy * np.sin(alpha), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.hypot(fx, fy), [80.0, 80.0, 80.0, 0.0], rtol=1e-14)
    assert ber_cutting_force_N(2e9, 1e-4, 2e-3, 0.8, 1.0) == pytest.approx(
        2e9 * 1e-4**0.8 * 2e-3, rel=1e-14)


def test_reference_from_path_circumcircle_matches_the_circle():
    """The paper's three-point curvature (spec M1-4) on a sampled circle: the circle's own
    centre and radius; the path's rows land in the right places."""
    path = interpolate(PathParams(kind="circle", radius_mm=12.0, feed_mm_s=50.0,
                                  centre_mm=(3.0, -4.0), revolutions=0.25), DT)
    for mode in ("circumcircle", "circumcircle_lookahead"):
        ref = XYReference.from_path(path, curvature=mode)
        np.testing.assert_allclose(ref.radius_mm, 12.0, rtol=1e-6)
        np.testing.assert_allclose(ref.centre_x_mm, 3.0, atol=1e-5)
        np.testing.assert_allclose(ref.centre_y_mm, -4.0, atol=1e-5)
        np.testing.assert_array_equal(ref.y_mm, path.position_mm[:, 1])
        np.testing.assert_array_equal(ref.velocity_x_mm_s, path.velocity_mm_s[:, 0])
    with pytest.raises(ValueError, match="curvature"):
        XYReference.from_path(path, curvature="spline")
