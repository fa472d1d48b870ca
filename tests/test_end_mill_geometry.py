"""Tests of the geometric end-milling force model (plants.end_mill_geometry)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from plants.cutting_coefficients import CuttingCoefficients
from plants.end_mill_geometry import (
    EndMill,
    MillingCut,
    average_forces,
    average_forces_numerical,
    force_process_static_gain_N_per_mm_min,
    forces_vs_time,
    instantaneous_forces,
    instantaneous_forces_sliced,
    tooth_period_s,
)

TOOL = EndMill()
COEFFS = CuttingCoefficients()
COMPONENTS = ("feed_N", "normal_N", "tangential_N", "axial_N")
CASES = [(mode, ae) for mode in ("up", "down") for ae in (0.5, 3.0, 8.0, 13.0, 16.0)]


def _vec(forces):
    return np.array([float(getattr(forces, n)) for n in COMPONENTS])


@pytest.mark.parametrize("mode,ae", CASES)
@pytest.mark.parametrize("exponent", [0.0, 0.3])
def test_closed_form_average_equals_numerical_integration(mode, ae, exponent):
    # Numerical path: Eq. 2 summed over 32 axial slices and 4 teeth, integrated over a tooth
    # period by adaptive Gauss-Kronrod (quad_vec) with every entry/exit angle as a break
    # point, so each piece is a smooth trigonometric polynomial and the quadrature is
    # accurate to ~1e-13; slicing adds no error to a full-period average.  Tolerance 1e-9
    # of the largest component leaves room for round-off over ~130 pieces.
    k = replace(COEFFS, chip_thickness_exponent=exponent)
    cut = MillingCut(radial_depth_mm=ae, axial_depth_mm=10.0, feed_per_tooth_mm=0.05, mode=mode)
    closed = _vec(average_forces(TOOL, cut, k))
    numerical = _vec(average_forces_numerical(TOOL, cut, k))
    np.testing.assert_allclose(numerical, closed, rtol=0, atol=1e-9 * np.max(np.abs(closed)))


@pytest.mark.parametrize("mode,ae", [("up", 3.0), ("down", 13.0), ("up", 16.0)])
def test_mean_of_instantaneous_closed_form_equals_average(mode, ae):
    # With a helix the instantaneous force is continuous and piecewise smooth (kinks where
    # an edge end enters or leaves the arc), so the periodic rectangle rule over 4000
    # angles has error O(h^2 * sum of slope jumps) ~ 1e-4 N; 1e-6 relative bounds it.
    cut = MillingCut(radial_depth_mm=ae, axial_depth_mm=10.0, feed_per_tooth_mm=0.05, mode=mode)
    phi = np.arange(4000) * TOOL.pitch_angle_rad / 4000
    inst = instantaneous_forces(TOOL, cut, COEFFS, phi)
    mean = np.array([np.mean(getattr(inst, n)) for n in COMPONENTS])
    closed = _vec(average_forces(TOOL, cut, COEFFS))
    np.testing.assert_allclose(mean, closed, rtol=0, atol=1e-6 * np.max(np.abs(closed)))


@pytest.mark.parametrize("mode,ae,axial", [("up", 3.0, 10.0), ("down", 8.0, 120.0)])
def test_instantaneous_closed_form_equals_axial_slices(mode, ae, axial):
    # 120 mm axial depth exceeds the helix lead (87 mm): an edge covers the arc twice.
    # Midpoint slicing errs only on the <= 2 partly engaged slices per tooth and wrap
    # (each off by at most dz * max|dF/dz|) plus an O(dz^2) smooth-part term.
    n_slices = 4000
    c = 0.05
    cut = MillingCut(radial_depth_mm=ae, axial_depth_mm=axial, feed_per_tooth_mm=c, mode=mode)
    phi = np.linspace(0.0, 2 * math.pi, 721)
    closed = instantaneous_forces(TOOL, cut, COEFFS, phi)
    sliced = instantaneous_forces_sliced(TOOL, cut, COEFFS, phi, n_slices=n_slices)
    k = COEFFS
    f_max = (k.tangential_cutting_N_mm2 * c + k.tangential_edge_N_mm) + (
        k.radial_cutting_N_mm2 * c + k.radial_edge_N_mm
    )
    wraps = math.ceil(axial * TOOL.helix_lag_rad_per_mm / (2 * math.pi)) + 1
    bound = 1.1 * 2 * TOOL.teeth * wraps * (axial / n_slices) * f_max
    for name in COMPONENTS:
        np.testing.assert_allclose(getattr(sliced, name), getattr(closed, name), atol=bound)


@pytest.mark.parametrize("mode", ["up", "down"])
def test_average_forces_scale_exactly_with_axial_depth(mode):
    # Exact identity mean F(a) = a * mean F(1): checked on the closed form (1e-13, round-off)
    # and on the brute-force path beyond one helix lead (1e-9, quadrature tolerance).
    depths = np.array([0.5, 2.5, 7.0, 40.0, 100.0])
    cut = MillingCut(radial_depth_mm=5.0, axial_depth_mm=depths, feed_per_tooth_mm=0.07, mode=mode)
    unit = _vec(average_forces(TOOL, replace(cut, axial_depth_mm=1.0), COEFFS))
    forces = average_forces(TOOL, cut, COEFFS)
    for i, name in enumerate(COMPONENTS):
        np.testing.assert_allclose(getattr(forces, name), depths * unit[i], rtol=1e-13)
    deep = _vec(average_forces_numerical(TOOL, replace(cut, axial_depth_mm=100.0), COEFFS))
    np.testing.assert_allclose(deep, 100.0 * unit, rtol=0, atol=1e-9 * 100 * np.abs(unit).max())


@pytest.mark.parametrize("helix_deg", [0.0, 10.0, 30.0, 45.0, 60.0])
def test_helix_angle_does_not_change_average_forces(helix_deg):
    # Brute-force averages of helical tools against the helix-free closed form (tolerance
    # as in the closed-form/numerical test).
    tool = replace(TOOL, helix_angle_deg=helix_deg)
    cut = MillingCut(radial_depth_mm=6.0, axial_depth_mm=12.0, feed_per_tooth_mm=0.04, mode="down")
    closed = _vec(average_forces(EndMill(helix_angle_deg=0.0), cut, COEFFS))
    numerical = _vec(average_forces_numerical(tool, cut, COEFFS))
    np.testing.assert_allclose(numerical, closed, rtol=0, atol=1e-9 * np.abs(closed).max())


def test_slot_averages_match_hand_derived_closed_form():
    # Slot [0, pi]: mean Fx = N a (Krc c/4 + Kre/pi), mean Fy = -N a (Ktc c/4 + Kte/pi),
    # mean Ft = N a (Ktc c/pi + Kte/2) (Altintas, Manufacturing Automation, Ch. 2, with the
    # sign of forces on the workpiece).
    n, a, c, k = TOOL.teeth, 5.0, 0.06, COEFFS
    f = average_forces(
        TOOL, MillingCut(radial_depth_mm=16.0, axial_depth_mm=a, feed_per_tooth_mm=c), k
    )
    expected = [
        n * a * (k.radial_cutting_N_mm2 * c / 4 + k.radial_edge_N_mm / math.pi),
        -n * a * (k.tangential_cutting_N_mm2 * c / 4 + k.tangential_edge_N_mm / math.pi),
        n * a * (k.tangential_cutting_N_mm2 * c / math.pi + k.tangential_edge_N_mm / 2),
    ]
    np.testing.assert_allclose([f.feed_N, f.normal_N, f.tangential_N], expected, rtol=1e-13)


def test_up_milling_feed_force_opposes_feed_and_down_milling_crosses_zero():
    # Physical signs: up-milling pushes the workpiece against the feed (Fx > 0); in
    # down-milling Fx < 0 at small immersion and > 0 at a slot, so it crosses zero.
    ae = np.linspace(0.2, 16.0, 80)
    up = average_forces(TOOL, MillingCut(radial_depth_mm=ae, mode="up"), COEFFS)
    down = average_forces(TOOL, MillingCut(radial_depth_mm=ae, mode="down"), COEFFS)
    assert np.all(up.feed_N > 0)
    assert down.feed_N[0] < 0 < down.feed_N[-1]
    np.testing.assert_allclose(up.tangential_N, down.tangential_N, rtol=1e-12)


def test_forces_vs_time_repeat_every_tooth_period():
    # Tooth passing: with N equal teeth the force has period 60 / (N n) exactly.
    cut = MillingCut(radial_depth_mm=4.0, axial_depth_mm=8.0)
    period = tooth_period_s(TOOL, cut.spindle_speed_rpm)
    t = np.arange(500) * 1e-4
    f0 = forces_vs_time(TOOL, cut, COEFFS, t, feedrate_mm_min=120.0)
    f1 = forces_vs_time(TOOL, cut, COEFFS, t + period, feedrate_mm_min=120.0)
    np.testing.assert_allclose(f1.feed_N, f0.feed_N, atol=1e-9 * np.abs(f0.feed_N).max())
    assert np.ptp(f0.feed_N) > 0.1 * np.abs(f0.feed_N).max()  # it does vary with angle


def test_forces_vs_time_batch_shape():
    cut = MillingCut(radial_depth_mm=np.array([[2.0], [3.0], [4.0]]), axial_depth_mm=8.0)
    t = np.arange(100) * 1e-3
    f = forces_vs_time(TOOL, cut, COEFFS, t, feedrate_mm_min=np.full(100, 140.0))
    assert f.feed_N.shape == (3, 100)


def test_static_gain_equals_force_over_feedrate_without_edge_forces():
    # Kim & Chung's form (K_s, r_t, no edge force): force proportional to feed, so the
    # gain is exactly mean F / feedrate.
    k = CuttingCoefficients.from_cutting_pressure(2000.0, 0.3)
    cut = MillingCut(
        radial_depth_mm=np.array([2.0, 3.0, 4.0]), axial_depth_mm=10.0, feed_per_tooth_mm=0.05
    )
    feedrate = 0.05 * TOOL.teeth * cut.spindle_speed_rpm
    f = average_forces(TOOL, cut, k)
    for comp in ("feed", "normal", "tangential", "resultant_xy"):
        gain = force_process_static_gain_N_per_mm_min(TOOL, cut, k, comp)
        np.testing.assert_allclose(gain * feedrate, f.component(comp), rtol=1e-12)


@pytest.mark.parametrize("exponent", [0.0, 0.25])
def test_static_gain_equals_central_difference(exponent):
    # Independent check by a central difference of the closed-form averages in the
    # feedrate; step 1e-3 mm/min gives truncation ~1e-9 relative, round-off ~1e-10.
    k = replace(COEFFS, chip_thickness_exponent=exponent)
    cut = MillingCut(
        radial_depth_mm=np.array([1.0, 3.0, 9.0]),
        axial_depth_mm=6.0,
        feed_per_tooth_mm=0.04,
        mode="down",
    )
    dv = 1e-3
    dc = dv / (TOOL.teeth * cut.spindle_speed_rpm)
    hi = average_forces(TOOL, replace(cut, feed_per_tooth_mm=0.04 + dc), k)
    lo = average_forces(TOOL, replace(cut, feed_per_tooth_mm=0.04 - dc), k)
    for comp in ("feed", "normal", "tangential", "axial", "resultant_xy"):
        fd = (hi.component(comp) - lo.component(comp)) / (2 * dv)
        gain = force_process_static_gain_N_per_mm_min(TOOL, cut, k, comp)
        np.testing.assert_allclose(gain, fd, rtol=1e-6)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"radial_depth_mm": 16.5}, "radial_depth_mm"),
        ({"radial_depth_mm": -1.0}, "radial_depth_mm"),
        ({"axial_depth_mm": -2.0}, "axial_depth_mm"),
        ({"feed_per_tooth_mm": -0.1}, "feed_per_tooth_mm"),
        ({"mode": "climb"}, "mode"),
    ],
)
def test_bad_cut_raises_value_error_naming_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        average_forces(TOOL, MillingCut(**kwargs), COEFFS)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"diameter_mm": 0.0}, "diameter_mm"),
        ({"teeth": 0}, "teeth"),
        ({"helix_angle_deg": 90.0}, "helix_angle_deg"),
    ],
)
def test_bad_tool_raises_value_error_naming_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        EndMill(**kwargs)


def test_static_gain_of_the_resultant_for_a_scalar_cut_matches_a_central_difference():
    from plants.cutting_coefficients import CuttingCoefficients
    from plants.end_mill_geometry import (
        EndMill,
        MillingCut,
        average_forces,
        force_process_static_gain_N_per_mm_min,
    )

    tool, co = EndMill(), CuttingCoefficients()
    feed, h = 120.0, 1e-3  # mm/min; the resultant is smooth in the feed
    gain = force_process_static_gain_N_per_mm_min(
        tool, MillingCut(3.0, 10.0, feed / 2400.0), co, "resultant_xy"
    )

    def resultant(v: float) -> float:
        return float(average_forces(tool, MillingCut(3.0, 10.0, v / 2400.0), co).resultant_xy_N)

    assert float(gain) == pytest.approx(
        (resultant(feed + h) - resultant(feed - h)) / (2 * h), rel=1e-6
    )
