"""Circular-test metrics on constructed paths with known G, F and H (spec §6.3, §5.8).

* an offset circle: F_max = +d, F_min = -d about the nominal centre, G = 0 (the
  least-squares centre finds the offset);
* an ellipse with semi-axes a > b: G = a - b, F_max = a - R, F_min = b - R;
* two circles offset by +-d along x as the CW and CCW paths: H = 2d, G(b) = 2d;
* a bump of known height at 90 deg is the only reversal glitch.
"""

from __future__ import annotations

import numpy as np
import pytest

from controllers.monitoring import circular_test as ct

R = 10.0
C = np.array([3.0, -2.0])


def _circle(centre, radius, n=3600, phase=0.0):
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False) + phase
    return np.asarray(centre) + radius * np.stack([np.cos(t), np.sin(t)], axis=1)


def test_offset_circle():
    d = np.array([0.012, -0.005])
    m = ct.evaluate_circle(_circle(C + d, R), C, R)
    assert m.f_max_mm == pytest.approx(np.hypot(*d), rel=1e-5)
    assert m.f_min_mm == pytest.approx(-np.hypot(*d), rel=1e-5)
    assert m.g_mm == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(m.lsq_centre_mm, C + d, atol=1e-12)
    assert m.lsq_radius_mm == pytest.approx(R, rel=1e-14)
    # F about the least-squares centre is then zero
    m_lsq = ct.evaluate_circle(_circle(C + d, R), C, R, f_centre="lsq")
    assert abs(m_lsq.f_max_mm) < 1e-12 and abs(m_lsq.f_min_mm) < 1e-12


def test_ellipse():
    a, b = R + 0.02, R - 0.01
    t = np.linspace(0.0, 2 * np.pi, 3600, endpoint=False)
    pts = C + np.stack([a * np.cos(t), b * np.sin(t)], axis=1)
    m = ct.evaluate_circle(pts, C, R)
    np.testing.assert_allclose(m.lsq_centre_mm, C, atol=1e-12)  # symmetry
    assert m.g_mm == pytest.approx(a - b, rel=1e-9)
    assert m.f_max_mm == pytest.approx(a - R, rel=1e-9)
    assert m.f_min_mm == pytest.approx(b - R, rel=1e-9)


def test_hysteresis_of_two_offset_paths():
    d = 0.004
    cw = _circle(C + [d, 0.0], R)[::-1]
    ccw = _circle(C - [d, 0.0], R, phase=0.0007)
    g_b, h = ct.bidirectional(cw, ccw, grid_deg=0.05)
    # r(theta) = +-d cos(theta) + sqrt(R^2 - d^2 sin^2 theta) about C: difference 2 d cos
    assert h == pytest.approx(2 * d, rel=1e-4)
    assert g_b == pytest.approx(2 * d, rel=1e-4)


def test_single_reversal_glitch():
    t = np.linspace(0.0, 2 * np.pi, 7200, endpoint=False)
    height = 0.003
    bump = height * np.exp(-(((np.degrees(t) - 90.0) / 1.0) ** 2))
    r = R + 0.001 + bump
    pts = C + r[:, None] * np.stack([np.cos(t), np.sin(t)], axis=1)
    m = ct.evaluate_circle(pts, C, R, contour_error_mm=r - R, plant_step_s=0.001)
    assert m.glitch_height_mm[1] == pytest.approx(height, rel=1e-3)
    assert m.glitch_angle_deg[1] == pytest.approx(90.0, abs=0.05)
    np.testing.assert_allclose(m.glitch_height_mm[[0, 2, 3]], 0.0, atol=1e-9)
    assert m.max_abs_error_mm == pytest.approx(0.001 + height, rel=1e-6)
    assert m.iae_mm_s == pytest.approx(np.sum(r - R) * 0.001, rel=1e-12)
    assert m.normalised_iae_mm == pytest.approx(np.mean(r - R), rel=1e-12)


def test_ballbar_magnification_keeps_the_deviation_within_the_stated_fraction():
    from controllers.contouring.plots import ballbar_magnification

    # 0.3 R / max|dev|: 6.56 -> 5, 42.9 -> 20, 3.0e4 -> 2e4, below 1 -> 1
    assert ballbar_magnification(0.915, 20.0) == 5.0
    assert ballbar_magnification(0.140, 20.0) == 20.0
    assert ballbar_magnification(1e-4, 10.0) == 2e4
    assert ballbar_magnification(30.0, 20.0) == 1.0
    assert ballbar_magnification(0.0, 20.0) == 1.0
    for dev in np.geomspace(1e-5, 5.0, 37):
        m = ballbar_magnification(dev, 20.0)
        assert m * dev <= 0.3 * 20.0 * (1 + 1e-12) or m == 1.0
        assert 2.5 * m * dev > 0.3 * 20.0 or m == 1.0  # the next 1-2-5 step would not fit
