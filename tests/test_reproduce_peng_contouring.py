"""The contouring reproduction script end to end: validation.csv has one column per
validation ID and one numeric row, and its closed-form columns equal the analysis
functions (so a broken wiring between script and library shows)."""

from __future__ import annotations

import csv
import math

import pytest

from acc.design import axis_analysis as aa
from tests.cli_run import experiment_module


def test_validation_csv(tmp_path):
    mod = experiment_module("reproduce_peng_contouring")
    assert mod.main(["--out", str(tmp_path)]) == 0
    with (tmp_path / "validation.csv").open() as fh:
        header, row = list(csv.reader(fh))
    assert len(header) == len(set(header)) == len(row)
    values = dict(zip(header, map(float, row), strict=True))
    assert all(h.startswith("H0-") for h in header)
    expected = aa.contour_error_mm(mod.AX, mod.AY_MISMATCHED, mod.LL, 0.001,
                                   20.0 * math.sqrt(2), math.pi / 4)
    assert values["H0-24_closed_form_45"] == pytest.approx(expected, rel=1e-12)
    assert values["H0-24_mismatched_45"] == pytest.approx(expected, rel=1e-6)
    assert values["H0-28_radial_simulated"] == pytest.approx(
        values["H0-28_radial_closed_form"], rel=1e-4)
    for name in ("diamond_overlay.png", "diamond_contour_error.png", "circle_polar.png",
                 "contour_lab.png"):
        assert (tmp_path / name).stat().st_size > 0
