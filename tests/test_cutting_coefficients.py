"""Tests of the cutting coefficients and their slot-cut calibration."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from plants.cutting_coefficients import (
    CuttingCoefficients,
    calibrate_from_slot_averages,
    calibrate_from_slot_csv,
)
from plants.end_mill_geometry import EndMill, MillingCut, average_forces, average_forces_numerical

TOOL = EndMill()
TRUE = CuttingCoefficients(
    tangential_cutting_N_mm2=1850.0, radial_cutting_N_mm2=620.0, axial_cutting_N_mm2=310.0,
    tangential_edge_N_mm=24.0, radial_edge_N_mm=41.0, axial_edge_N_mm=3.5,
)
FIELDS = ("tangential_cutting_N_mm2", "radial_cutting_N_mm2", "axial_cutting_N_mm2",
          "tangential_edge_N_mm", "radial_edge_N_mm", "axial_edge_N_mm")
FEEDS = np.array([0.02, 0.04, 0.06, 0.08, 0.10])
EXAMPLE_CSV = Path(__file__).resolve().parents[1] / "experiments" / "slot_calibration_example.csv"


def _assert_coefficients(found, expected, rtol):
    for name in FIELDS:
        assert getattr(found, name) == pytest.approx(getattr(expected, name), rel=rtol), name


def test_slot_calibration_round_trip_closed_form():
    # Averages synthesised by the general geometric model at 5 feeds (one axial depth per
    # cut, varied): the regression inverts them exactly, up to round-off (1e-10).
    a = np.array([3.0, 4.0, 5.0, 4.0, 3.0])
    f = average_forces(TOOL, MillingCut(radial_depth_mm=16.0, axial_depth_mm=a,
                                        feed_per_tooth_mm=FEEDS), TRUE)
    result = calibrate_from_slot_averages(FEEDS, a, f.feed_N, f.normal_N, TOOL.teeth, f.axial_N)
    _assert_coefficients(result.coefficients, TRUE, 1e-10)
    assert max(result.residual_rms_N) < 1e-9


def test_slot_calibration_round_trip_brute_force_averages():
    # Same, with averages from the independent brute-force integration (quadrature tolerance
    # ~1e-12 relative, amplified by the regression: 1e-8).
    forces = [average_forces_numerical(TOOL, MillingCut(radial_depth_mm=16.0,
                                                        axial_depth_mm=4.0,
                                                        feed_per_tooth_mm=c), TRUE)
              for c in FEEDS]
    fx, fy, fz = (np.array([float(getattr(f, n)) for f in forces])
                  for n in ("feed_N", "normal_N", "axial_N"))
    result = calibrate_from_slot_averages(FEEDS, 4.0, fx, fy, TOOL.teeth, fz)
    _assert_coefficients(result.coefficients, TRUE, 1e-8)


def test_slot_calibration_from_csv_equals_array_path(tmp_path):
    f = average_forces(TOOL, MillingCut(radial_depth_mm=16.0, axial_depth_mm=4.0,
                                        feed_per_tooth_mm=FEEDS), TRUE)
    path = tmp_path / "slots.csv"
    rows = ["mean_force_y_N,feed_per_tooth_mm,axial_depth_mm,mean_force_x_N,mean_force_z_N"]
    rows += [f"{float(y)!r},{float(c)!r},4.0,{float(x)!r},{float(z)!r}"
             for x, y, z, c in zip(f.feed_N, f.normal_N, f.axial_N, FEEDS, strict=True)]
    path.write_text("\n".join(rows) + "\n")
    _assert_coefficients(calibrate_from_slot_csv(path, TOOL.teeth).coefficients, TRUE, 1e-10)


def test_example_csv_recovers_defaults_within_regression_standard_error():
    # The shipped example was synthesised from the default coefficients (4 mm slots) with
    # N(0, 2 N) noise on each average.  Each coefficient is a slope or intercept of a line
    # fit of F/(N a) on c; the OLS standard errors with sigma = 2 N give the tolerance,
    # 4 standard errors (the file is fixed, so this is deterministic).
    result = calibrate_from_slot_csv(EXAMPLE_CSV, TOOL.teeth)
    c = np.loadtxt(EXAMPLE_CSV, delimiter=",", skiprows=1)[:, 0]
    n, sigma = c.size, 2.0 / (TOOL.teeth * 4.0)
    sxx = np.sum((c - c.mean()) ** 2)
    se_slope = sigma / math.sqrt(sxx)
    se_intercept = sigma * math.sqrt(1 / n + c.mean() ** 2 / sxx)
    scale = {"tangential_cutting_N_mm2": 4 * se_slope, "radial_cutting_N_mm2": 4 * se_slope,
             "axial_cutting_N_mm2": math.pi * se_slope,
             "tangential_edge_N_mm": math.pi * se_intercept,
             "radial_edge_N_mm": math.pi * se_intercept, "axial_edge_N_mm": 2 * se_intercept}
    default = CuttingCoefficients()
    for name, se in scale.items():
        assert abs(getattr(result.coefficients, name) - getattr(default, name)) < 4 * se, name


def test_csv_missing_column_is_named(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("feed_per_tooth_mm,axial_depth_mm,mean_force_x_N\n0.05,4,100\n")
    with pytest.raises(ValueError, match="mean_force_y_N"):
        calibrate_from_slot_csv(path, 4)


def test_calibration_needs_two_distinct_feeds():
    with pytest.raises(ValueError, match="feed_per_tooth_mm"):
        calibrate_from_slot_averages([0.05, 0.05], 4.0, [1.0, 1.0], [-1.0, -1.0], 4)


def test_from_cutting_pressure_and_pressure_factor():
    k = CuttingCoefficients.from_cutting_pressure(2000.0, 0.3, chip_thickness_exponent=0.25,
                                                  reference_chip_thickness_mm=0.05)
    assert k.radial_ratio == pytest.approx(0.3, rel=1e-15)
    assert not k.has_edge_forces
    # (h/h_ref)^-x: exact power law
    np.testing.assert_allclose(k.pressure_factor([0.05, 0.8]), [1.0, 16.0 ** -0.25], rtol=1e-15)
    with pytest.raises(ValueError, match="chip_thickness_exponent"):
        replace(k, chip_thickness_exponent=1.0)
    with pytest.raises(ValueError, match="radial_cutting_N_mm2"):
        CuttingCoefficients(radial_cutting_N_mm2=-1.0)
