"""Path references and spline corners (spec A0-5, M0-13, §5.8).

* B*^-1 of (4.135) is the exact inverse; A* = R* B*^-1 solves the boundary conditions of
  Peng's presets; the two-segment spline is C1 at its joint;
* the accel/decel corner's velocity is continuous (steps of at most a dt) and zero at the
  vertex; the sharp corner steps by the feed;
* the circle reference is (4.104)/(4.105) sample by sample, with speed f and radius R;
* curvature from the analytic derivatives (sinusoid crest radius 1/(A k^2)).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from controllers.contouring import spline_corner as sc
from controllers.contouring.interpolator import PathParams, interpolate

DT = 0.001


def test_b_star_inverse_is_exact():
    np.testing.assert_array_equal(sc.B_STAR @ sc.B_STAR_INVERSE, np.eye(4))
    # and B* is built from b*(s) = [s^3, s^2, s, 1] and its derivative at s = 0 and 1
    b = lambda s: np.array([s**3, s**2, s, 1.0])  # noqa: E731
    db = lambda s: np.array([3 * s**2, 2 * s, 1.0, 0.0])  # noqa: E731
    np.testing.assert_array_equal(np.stack([b(0), db(0), b(1), db(1)], axis=1), sc.B_STAR)


@pytest.mark.parametrize("segments", [1, 2])
def test_preset_coefficients_solve_the_boundary_conditions(segments):
    segs = sc.diamond_corner_splines((150.0, 150.0), 1.0, 20.0, segments)
    f, d = 20.0, 1.0
    points = [(149.0, 149.0), (151.0, 149.0)] if segments == 1 else [
        (149.0, 149.0), (150.0, 149.99), (151.0, 149.0)]
    speeds = [(f, f), (f, -f)] if segments == 1 else [(f, f), (f, 0.0), (f, -f)]
    assert sum(s.duration_s for s in segs) == pytest.approx(2 * d / f)
    for i, seg in enumerate(segs):
        dt_i = seg.duration_s
        r_star = np.stack([points[i], np.array(speeds[i]) * dt_i, points[i + 1],
                           np.array(speeds[i + 1]) * dt_i], axis=1)
        # A* R* relation solved independently: A* B* = R*
        np.testing.assert_allclose(seg.coefficients, np.linalg.solve(sc.B_STAR.T, r_star.T).T,
                                   atol=1e-12)
        a = seg.coefficients
        np.testing.assert_allclose(a @ [0, 0, 0, 1], points[i], atol=1e-12)
        np.testing.assert_allclose(a @ [1, 1, 1, 1], points[i + 1], atol=1e-12)
        np.testing.assert_allclose(a @ [0, 0, 1, 0] / dt_i, speeds[i], atol=1e-9)
        np.testing.assert_allclose(a @ [3, 2, 1, 0] / dt_i, speeds[i + 1], atol=1e-9)


def _max_velocity_step(ref) -> float:
    return float(np.abs(np.diff(ref.velocity_mm_s, axis=0)).max())


@pytest.mark.parametrize("corner", ["spline_1", "spline_2"])
def test_spline_corner_reference_is_c1(corner):
    ref = interpolate(PathParams(kind="diamond", corner=corner), DT)
    a_max = float(np.abs(ref.acceleration_mm_s2).max())
    jerk = 6 * 2.0 / (0.05 if corner == "spline_2" else 0.1) ** 3  # |A*_{s^3}| 6/dt^3 bound
    # a velocity step per sample no larger than a dt + jerk dt^2 / 2 (a sharp corner: 40 mm/s)
    assert _max_velocity_step(ref) <= a_max * DT + jerk * DT**2
    # position continuity at the joints: steps no larger than the speed times dt
    speed = np.hypot(*ref.velocity_mm_s.T).max()
    assert np.abs(np.diff(ref.position_mm, axis=0)).max() <= speed * DT * (1 + 1e-9)


def test_accel_decel_corner_is_velocity_continuous_and_stops_at_the_vertex():
    p = PathParams(kind="diamond", corner="accel_decel", accel_time_s=0.1)
    ref = interpolate(p, DT)
    a = p.feed_per_axis_mm_s / p.accel_time_s
    assert _max_velocity_step(ref) == pytest.approx(a * DT, rel=1e-9)
    k = int(round(ref.vertex_time_s / DT))
    np.testing.assert_allclose(ref.position_mm[k], p.vertex_mm, atol=1e-12)
    np.testing.assert_allclose(ref.velocity_mm_s[k], 0.0, atol=1e-12)
    assert ref.tangent_angle_rad[k - 1] == pytest.approx(math.pi / 4)
    assert ref.tangent_angle_rad[k + 1] == pytest.approx(-math.pi / 4)
    sharp = interpolate(PathParams(kind="diamond"), DT)
    assert _max_velocity_step(sharp) == pytest.approx(2 * p.feed_per_axis_mm_s)


@pytest.mark.parametrize("direction", ["cw", "ccw"])
def test_circle_reference_is_pengs_4_104_4_105(direction):
    r, f = 10.0, 20.0
    ref = interpolate(PathParams(kind="circle", radius_mm=r, feed_mm_s=f, direction=direction,
                                 centre_mm=(5.0, -3.0)), DT)
    k = np.arange(ref.samples)
    w = f / r
    sign = 1.0 if direction == "cw" else -1.0
    np.testing.assert_allclose(ref.position_mm[:, 0], 5.0 + sign * r * np.sin(w * k * DT),
                               atol=1e-12)
    np.testing.assert_allclose(ref.position_mm[:, 1], -3.0 + r * np.cos(w * k * DT), atol=1e-12)
    np.testing.assert_allclose(np.hypot(*ref.velocity_mm_s.T), f, rtol=1e-12)
    np.testing.assert_array_equal(ref.radius_mm, r)
    assert ref.circle[2] == (-1.0 if direction == "cw" else 1.0)
    assert ref.samples == round(2 * math.pi * r / f / DT) + 1


def test_sinusoid_curvature_from_the_derivatives():
    amp, lam = 1.0, 20.0
    ref = interpolate(PathParams(kind="sinusoid", amplitude_mm=amp, wavelength_mm=lam,
                                 feed_mm_s=20.0, duration_s=1.0), DT)
    k = int(round(lam / 4 / 20.0 / DT))  # a crest
    assert ref.radius_mm[k] == pytest.approx(1.0 / (amp * (2 * math.pi / lam) ** 2), rel=1e-9)
    np.testing.assert_allclose(ref.centre_mm[k], ref.position_mm[k] - [0, ref.radius_mm[k]],
                               atol=1e-9)
    assert np.isinf(interpolate(PathParams(kind="line"), DT).radius_mm).all()


def test_bad_input_names_the_key():
    with pytest.raises(ValueError, match="kind"):
        PathParams(kind="spiral")
    with pytest.raises(ValueError, match="corner"):
        PathParams(kind="square", corner="spline_1")
    with pytest.raises(ValueError, match="accel_time_s"):
        interpolate(PathParams(corner="accel_decel", accel_time_s=0.1005), DT)


def test_axis_limits_of_4_139_to_4_142():
    # the one-segment spline decelerates y from +20 to -20 mm/s in 0.1 s: |y''| = 400 mm/s^2
    # at the ends (A* y row -2 s^2 + 2 s: y'' = -4 / 0.1^2), x stays at 20 mm/s
    p = PathParams(kind="diamond", corner="spline_1", max_axis_acceleration_mm_s2=400.0,
                   max_axis_speed_mm_s=20.0)
    interpolate(p, DT)
    with pytest.raises(ValueError, match="max_axis_acceleration_mm_s2"):
        interpolate(replace(p, max_axis_acceleration_mm_s2=399.0), DT)
    with pytest.raises(ValueError, match="max_axis_speed_mm_s"):
        interpolate(replace(p, max_axis_speed_mm_s=19.9), DT)
