"""Tests of depth-of-cut identification from average forces."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controllers.depth_of_cut_identification import identify_depth_of_cut, immersion_quantity
from plants.cutting_coefficients import CuttingCoefficients
from plants.end_mill_geometry import EndMill, MillingCut, average_forces

TOOL = EndMill()
KIM_CHUNG = CuttingCoefficients.from_cutting_pressure(2000.0, 0.3)
MATCHED_EDGE = replace(KIM_CHUNG, tangential_edge_N_mm=30.0, radial_edge_N_mm=9.0,
                       chip_thickness_exponent=0.3)  # K_re / K_te = r_t
AE = np.linspace(1e-3, 16.0, 4000)


@pytest.mark.parametrize("coefficients", [KIM_CHUNG, MATCHED_EDGE])
@pytest.mark.parametrize("mode", ["up", "down"])
@pytest.mark.parametrize("c", [0.005, 0.05, 0.2])
def test_rotated_quantity_is_strictly_monotonic_over_whole_immersion_range(coefficients, mode, c):
    f = average_forces(TOOL, MillingCut(radial_depth_mm=AE, axial_depth_mm=1.0,
                                        feed_per_tooth_mm=c, mode=mode), coefficients)
    assert np.all(f.tangential_N > 0)  # denominator never crosses zero: no pole
    q = immersion_quantity(f.feed_N, f.normal_N, f.tangential_N, coefficients.radial_ratio)
    step = np.diff(q)
    assert np.all(step < 0) if mode == "up" else np.all(step > 0)


@pytest.mark.parametrize("mode,sign", [("up", 1.0), ("down", -1.0)])
def test_rotated_quantity_is_linear_in_radial_depth_for_constant_pressure(mode, sign):
    # Closed form: weighted mean of cos over the arc with weight sin -> +-(1 + cos theta)/2.
    f = average_forces(TOOL, MillingCut(radial_depth_mm=AE, mode=mode), KIM_CHUNG)
    q = immersion_quantity(f.feed_N, f.normal_N, f.tangential_N, KIM_CHUNG.radial_ratio)
    np.testing.assert_allclose(q, sign * (1.0 - AE / TOOL.diameter_mm), rtol=0, atol=1e-12)


def test_plain_feed_to_tangential_ratio_is_not_monotonic_in_up_milling():
    # Why the paper's ratio is not used over the whole range: F_x/F_t first rises (peak
    # near theta = 4 r_t / 3 for small r_t), so small immersions are ambiguous.
    f = average_forces(TOOL, MillingCut(radial_depth_mm=AE, mode="up"), KIM_CHUNG)
    ratio = f.feed_N / f.tangential_N
    peak = AE[np.argmax(ratio)]
    expected_peak = TOOL.radius_mm * (1 - np.cos(4 * 0.3 / 3))
    assert 0.0 < peak < 16.0
    assert peak == pytest.approx(expected_peak, rel=0.25)  # small-angle estimate


@pytest.mark.parametrize("mode", ["up", "down"])
@pytest.mark.parametrize("method", ["rotated", "feed_tangential"])
def test_identification_recovers_true_depths_on_noise_free_forces(mode, method):
    # Default coefficients (edge forces of another ratio): the exact inverse on the
    # monotonic branch; root-finding tolerance 1e-13 rad -> 1e-9 mm is ample.
    ae, a = np.meshgrid(np.linspace(0.25, 16.0, 40), np.linspace(1.0, 30.0, 8))
    ae, a = ae.ravel(), a.ravel()
    k = CuttingCoefficients()
    f = average_forces(TOOL, MillingCut(radial_depth_mm=ae, axial_depth_mm=a,
                                        feed_per_tooth_mm=0.05, mode=mode), k)
    est = identify_depth_of_cut(TOOL, k, 0.05, mode, f.feed_N, f.tangential_N, f.normal_N,
                                method=method)
    valid = ae >= est.min_identifiable_radial_depth_mm
    assert valid.mean() > 0.85  # the ambiguous band is small
    assert np.all(est.identifiable[valid])
    np.testing.assert_allclose(est.radial_depth_mm[valid], ae[valid], atol=1e-9)
    np.testing.assert_allclose(est.axial_depth_mm[valid], a[valid], atol=1e-9)
    assert np.all(est.min_identifiable_radial_depth_mm < 2.0)


@pytest.mark.parametrize("mode", ["up", "down"])
def test_identification_error_with_noise_matches_linearised_prediction(mode):
    # Noise: N(0, (0.01 F_t)^2) on each averaged component.  For the paper's force law
    # a_e = 2R (1 -+ q), so to first order std(a_e) = 2R (sigma/F_t) sqrt(1/(1+r^2) + q^2).
    # 3000 samples estimate an RMS to ~1.3 %; 8 % covers that and the linearisation.
    rng = np.random.default_rng(20240611)
    r, n = KIM_CHUNG.radial_ratio, 3000
    for ae0 in (1.0, 3.0, 8.0, 12.0):
        f = average_forces(TOOL, MillingCut(radial_depth_mm=ae0, axial_depth_mm=10.0,
                                            mode=mode), KIM_CHUNG)
        sigma = 0.01 * float(f.tangential_N)
        noisy = [float(getattr(f, name)) + sigma * rng.standard_normal(n)
                 for name in ("feed_N", "normal_N", "tangential_N")]
        est = identify_depth_of_cut(TOOL, KIM_CHUNG, 0.05, mode, noisy[0], noisy[2], noisy[1])
        q = 1.0 - ae0 / TOOL.diameter_mm
        predicted = TOOL.diameter_mm * 0.01 * np.sqrt(1 / (1 + r * r) + q * q)
        rms = np.sqrt(np.mean((est.radial_depth_mm - ae0) ** 2))
        assert rms == pytest.approx(predicted, rel=0.08), ae0
        # stated spec at 1 % force noise: axial depth within 10 % RMS for a_e >= 3 mm
        if ae0 >= 3.0:
            assert np.sqrt(np.mean((est.axial_depth_mm / 10.0 - 1) ** 2)) < 0.10


def test_identification_input_errors():
    with pytest.raises(ValueError, match="normal_force_N"):
        identify_depth_of_cut(TOOL, KIM_CHUNG, 0.05, "up", [100.0], [120.0])
    with pytest.raises(ValueError, match="tangential_force_N"):
        identify_depth_of_cut(TOOL, KIM_CHUNG, 0.05, "up", [100.0], [-1.0], [3.0])
    with pytest.raises(ValueError, match="feed_per_tooth_mm"):
        identify_depth_of_cut(TOOL, KIM_CHUNG, 0.0, "up", [100.0], [120.0], [3.0])
