"""Corner metrics M1-M4 and the segment error on synthetic paths with known distances
(spec A0-6, §5.8).

The diamond corner (a 90 deg right turn) rounded by a fillet of radius rho, sampled so that
the arc's midpoint is a sample: M1 = M4 = rho (sqrt 2 - 1) (vertex to arc midpoint), M2 =
rho (1 - 1/sqrt 2) (the midpoint's distance to either line), + on the inside (right).  An
incoming line shifted outwards (left) by delta: segment error -delta.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from controllers.contouring.interpolator import PathParams, interpolate
from controllers.monitoring import contour_metrics as cm

DT = 0.001


def _filleted_diamond(rho: float, half: int = 10):
    ref = interpolate(PathParams(kind="diamond", feed_per_axis_mm_s=20.0), DT)
    k_v = int(round(ref.vertex_time_s / DT))
    v = np.asarray(ref.vertex_mm)
    centre = v + [0.0, -rho * math.sqrt(2)]
    ang = np.radians(np.linspace(135.0, 45.0, 2 * half + 1))  # clockwise, midpoint at 90 deg
    p = ref.position_mm.copy()
    p[k_v - half:k_v + half + 1] = centre + rho * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    return ref, p, k_v


def test_fillet_corner_metrics():
    rho = 0.3
    ref, p, k_v = _filleted_diamond(rho)
    # the samples next to the arc lie on the lines beyond the tangent points
    assert np.hypot(*(p[k_v - 11] - ref.vertex_mm)) > rho
    est = np.zeros(ref.samples)
    est[k_v + 3] = -0.123
    est[0] = 5.0  # outside the window
    m = cm.corner_metrics(ref, p, linear_estimate_mm=est, window_s=0.1)
    assert m.vertex_distance_mm == pytest.approx(rho * (math.sqrt(2) - 1), rel=1e-12)
    assert m.bisector_distance_mm == pytest.approx(rho * (math.sqrt(2) - 1), rel=1e-12)
    assert m.max_path_distance_mm == pytest.approx(rho * (1 - 1 / math.sqrt(2)), rel=1e-12)
    assert m.max_linear_estimate_mm == pytest.approx(0.123)
    assert m.linear_segment_error_mm > 0  # the fillet starts inside the window, on the right


def test_segment_error_of_a_shifted_incoming_line():
    ref = interpolate(PathParams(kind="diamond", feed_per_axis_mm_s=20.0), DT)
    k_v = int(round(ref.vertex_time_s / DT))
    delta = 0.034
    p = ref.position_mm.copy()
    left = np.array([-1.0, 1.0]) / math.sqrt(2)  # left of the up-right motion
    p[:k_v] += delta * left
    m = cm.corner_metrics(ref, p)
    assert m.linear_segment_error_mm == pytest.approx(-delta, rel=1e-12)
    assert m.vertex_distance_mm == pytest.approx(0.0, abs=1e-12)  # passes the vertex


def test_iae_and_ratio():
    e = np.array([0.1, -0.2, 0.3])
    assert cm.iae_mm_s(e, 0.5) == pytest.approx(0.3)
    assert cm.iae_ratio(e, e / 20, 0.5) == pytest.approx(20.0)


def test_vertex_distance_is_to_the_polyline_not_its_samples():
    # nearest point is the middle of a chord: 1, not the sample distance sqrt(2)
    assert cm.vertex_distance((0.0, 0.0), [[-1.0, 1.0], [1.0, 1.0]]) == pytest.approx(1.0)
