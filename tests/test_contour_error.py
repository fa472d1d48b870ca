"""Contour-error estimates against geometry written in the test (spec §5.8, M1-4, O-21).

* straight path: the linear estimate (4.78) equals the exact signed distance to the line, and
  Lacerda's Eq. 11 is its negative;
* a tool lagging a circle by phi: the exact error is 0, the linear estimate is off by
  r (1 - cos phi) and the chord Eq. 16 by r |cos(2 sin(phi/2)) - cos phi| (closed form);
  the tangent-lag reading is exact;
* the circumcircle of three points of a known circle;
* the polyline distance on an L-shaped path with distances known by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from controllers.contouring import contour_error as ce


def _line_case(rng: np.random.Generator, n: int = 50):
    alpha = rng.uniform(-math.pi, math.pi, n)
    ref = rng.uniform(-100, 100, (n, 2))
    tool = ref + rng.normal(0, 0.05, (n, 2))
    return alpha, ref, tool


def test_linear_estimate_is_the_exact_distance_on_a_straight_path():
    rng = np.random.default_rng(4)
    alpha, ref, tool = _line_case(rng)
    e = ref - tool
    est = ce.linear_estimate(e[:, 0], e[:, 1], alpha)
    for i in range(alpha.size):
        t = np.array([math.cos(alpha[i]), math.sin(alpha[i])])
        line = np.stack([ref[i] - 1e3 * t, ref[i] + 1e3 * t])
        d, _, _ = ce.distance_to_polyline(tool[i][None], line)
        # independent: the z component of t x (P - R) is + to the left of the motion
        cross = t[0] * (tool[i, 1] - ref[i, 1]) - t[1] * (tool[i, 0] - ref[i, 0])
        assert est[i] == pytest.approx(-cross, abs=1e-12)
        assert est[i] == pytest.approx(d[0], abs=1e-10)
    np.testing.assert_array_equal(ce.lacerda_eq11(e[:, 0], e[:, 1], alpha), -est)
    # Eq. 16 on a straight part (r = inf, no centre) is the linear estimate
    e16 = ce.curvature_corrected_estimate(e[:, 0], e[:, 1], alpha, ref,
                                          np.full_like(ref, np.nan), np.full(alpha.size, np.inf))
    np.testing.assert_array_equal(e16, est)


def test_sign_convention_on_pengs_mismatched_diamond():
    # up-right 45 deg line; y lags more than x: the tool is below the line, i.e. to the right
    alpha = math.radians(45.0)
    e_x, e_y = 0.1, 0.3
    assert ce.linear_estimate_at(e_x, e_y, alpha) == pytest.approx(0.2 / math.sqrt(2), rel=1e-12)
    assert ce.lacerda_eq11_at(e_x, e_y, alpha) < 0


@pytest.mark.parametrize("turn", [1.0, -1.0])
def test_curvature_correction_on_a_circle_with_pure_lag(turn):
    r, centre = 20.0, np.array([3.0, -7.0])
    theta = np.linspace(0.1, 6.0, 9)  # reference angles on the circle
    phi = np.linspace(0.01, 0.6, 9)  # lag angles [rad]
    ref = centre + r * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    tool_angle = theta - turn * phi  # behind the reference in the direction of motion
    tool = centre + r * np.stack([np.cos(tool_angle), np.sin(tool_angle)], axis=1)
    alpha = theta + turn * math.pi / 2  # tangent in the direction of motion
    e = ref - tool
    cen = np.broadcast_to(centre, ref.shape)
    radius = np.full(theta.size, r)
    exact = ce.exact_circle_error(tool, centre, r, turn)
    np.testing.assert_allclose(exact, 0.0, atol=1e-12)
    lin = ce.linear_estimate(e[:, 0], e[:, 1], alpha)
    # the lagging tool lies inside the tangent line by r (1 - cos phi), on the centre's side
    np.testing.assert_allclose(lin, -turn * r * (1 - np.cos(phi)), rtol=1e-9)
    chord = ce.curvature_corrected_estimate(e[:, 0], e[:, 1], alpha, ref, cen, radius)
    closed = r * np.abs(np.cos(2 * np.sin(phi / 2)) - np.cos(phi))
    np.testing.assert_allclose(np.abs(chord - exact), closed, rtol=1e-6, atol=1e-15)
    assert np.all(np.abs(chord) < np.abs(lin))  # the correction helps
    lag = ce.curvature_corrected_estimate(e[:, 0], e[:, 1], alpha, ref, cen, radius,
                                          "tangent_lag")
    np.testing.assert_allclose(lag, 0.0, atol=1e-11)


def test_exact_circle_error_sign_follows_the_side_of_the_motion():
    # counter-clockwise: outside is to the right, so +; clockwise: outside is to the left
    tool = np.array([[0.0, 10.5]])
    assert ce.exact_circle_error(tool, [0.0, 0.0], 10.0, 1.0)[0] == pytest.approx(0.5)
    assert ce.exact_circle_error(tool, [0.0, 0.0], 10.0, -1.0)[0] == pytest.approx(-0.5)


def test_circumcircle_of_three_points_on_a_known_circle():
    centre, r = np.array([150.0, -42.0]), 7.5
    ang = np.array([[0.3, 0.31, 0.32], [1.0, 2.5, 4.0], [5.0, 5.000001, 5.000002]])
    pts = centre + r * np.stack([np.cos(ang), np.sin(ang)], axis=-1)  # (3, 3, 2)
    c, rad = ce.circumcircle(pts[:, 0], pts[:, 1], pts[:, 2])
    np.testing.assert_allclose(c[:2], np.broadcast_to(centre, (2, 2)), atol=1e-8)
    np.testing.assert_allclose(rad[:2], r, rtol=1e-9)
    assert rad[2] == pytest.approx(r, rel=1e-3)  # 7.5 um chords still resolved
    # collinear: straight
    c, rad = ce.circumcircle([0.0, 0.0], [1.0, 1.0], [2.0, 2.0])
    assert math.isinf(rad) and np.all(np.isnan(c))


def test_distance_to_an_l_shaped_polyline():
    path = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])  # +x, then +y (a left turn)
    pts = np.array([[5.0, -3.0], [11.0, 5.0], [8.0, 2.0], [12.0, -2.0], [5.0, 1.0], [9.0, 11.0]])
    d, seg, frac = ce.distance_to_polyline(pts, path)
    expected = [3.0, 1.0, -2.0, math.sqrt(8.0), -1.0, -math.sqrt(2.0)]
    np.testing.assert_allclose(d, expected, rtol=1e-12)
    assert seg[0] == 0 and frac[0] == pytest.approx(0.5)
    assert seg[1] == 1 and frac[1] == pytest.approx(0.5)


def test_sign_beyond_a_sharp_vertex_comes_from_both_segments():
    # +x, then back up-left (a turn of 153 deg): (12, 3) is nearest to the vertex and lies
    # outside the corner, to the right of both segments; segment 0's normal alone says left
    path = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 5.0]])
    d, _, _ = ce.distance_to_polyline([[12.0, 3.0]], path)
    assert d[0] == pytest.approx(math.sqrt(13.0), rel=1e-12)


def test_circumcircles_of_a_sampled_circle_reference():
    from controllers.contouring.interpolator import PathParams, interpolate

    ref = interpolate(PathParams(kind="circle", radius_mm=10.0, centre_mm=(150.0, 20.0),
                                 feed_mm_s=20.0), 0.001)
    for lookahead in (False, True):
        centre, radius = ce.path_circumcircles(ref.position_mm, lookahead=lookahead)
        np.testing.assert_allclose(radius, 10.0, rtol=1e-6)
        np.testing.assert_allclose(centre, np.broadcast_to([150.0, 20.0], centre.shape),
                                   atol=1e-5)


def test_bad_input_names_the_key():
    with pytest.raises(ValueError, match="curvature_angle"):
        ce.curvature_corrected_estimate(0.0, 0.0, 0.0, [0.0, 0.0], [0.0, 1.0], 1.0, "arc")
    with pytest.raises(ValueError, match="path_mm"):
        ce.distance_to_polyline([[0.0, 0.0]], [[0.0, 0.0]])


def test_the_package_docstring_lists_every_module_and_names_real_objects():
    """The contouring package's docstring lists each of its modules, and every function or
    module it points to exists (a renamed or added module shows)."""
    import importlib
    import pkgutil
    import re

    import controllers.contouring as pkg

    doc = pkg.__doc__
    modules = [m.name for m in pkgutil.iter_modules(pkg.__path__)]
    assert "cross_coupled" in modules
    for name in modules:
        assert f"``{name}``" in doc, name
    refs = re.findall(r":(?:func|mod):`([\w.]+)`", doc)
    assert len(refs) >= 4
    for ref in refs:
        try:
            importlib.import_module(ref)
        except ModuleNotFoundError:
            module, _, attr = ref.rpartition(".")
            assert hasattr(importlib.import_module(module), attr), ref
    assert "independent" in doc and "elastic" in doc
