"""Per-cell oracle designs of the robust design study (acc/design/oracle_design.py)."""

import math
from pathlib import Path

import numpy as np
import pytest

from acc.design.oracle_design import (
    best_per_cell,
    cell_of,
    oracle_fsp,
    oracle_pi,
    per_run_values,
    tail_summary,
)
from acc.design.robust_tuning import robust_tune
from acc.scenarios.force import Scenario, load_scenario

SHIPPED = Path(__file__).resolve().parents[1] / "experiments" / "kim_chung_2001.toml"
#: The co-designed PI of the study: a start that meets the constraints on every cell.
START = {"kp_per_N": 6.78e-4, "ki_per_N_s": 3.07e-3}


def campaign_run(depth_mm: float, material: float) -> Scenario:
    """A run of the campaign's kind: one depth, a material multiplier, the shipped table."""
    return load_scenario(SHIPPED).with_values({
        "workpiece.segment_length_mm": [30.0], "workpiece.axial_depth_mm": [10.0],
        "workpiece.radial_depth_mm": [depth_mm], "force_process.gain_multiplier": material,
        "controller.override_max": 4.0,
    })


def test_cell_of_reads_depth_and_material():
    assert cell_of(campaign_run(4.0, 3.0)) == (4.0, 3.0)
    with pytest.raises(ValueError, match="radial_depth_mm"):
        cell_of(campaign_run(4.0, 3.0).with_values({
            "workpiece.segment_length_mm": [10.0, 10.0],
            "workpiece.axial_depth_mm": [10.0, 10.0], "workpiece.radial_depth_mm": [2.0, 3.0]}))


def test_oracle_pi_is_the_tuner_on_the_cells_plant_alone():
    """Independent path: a scenario whose table *is* the cell's plant (one row, K2 already
    times the material) tuned over its only plant at the exact dead time.  The oracle of the
    4 mm x 3 cell must give the same gains; taking the wrong row (3 mm), ignoring the
    material or tuning over the whole table moves kp or ki by far more than 1e-4."""
    base = campaign_run(2.0, 0.5)  # any run: the oracle replaces depth and material
    got = oracle_pi(base, (4.0, 3.0), start=START)
    one_row = campaign_run(4.0, 1.0).with_values({
        "force_process.radial_depth_mm": [4.0],
        "force_process.k2_N_min_per_mm_s": [20.11 * 3.0],
        "force_process.p2_rad_s": [-5.35],
        "force_process.gain_multiplier": 1.0,
        "controller.kind": "pi",
    })
    dead = one_row.feed_drive.dead_time_s
    want = robust_tune(one_row, 2.0, 1.5, material_range=(1.0, 1.0),
                       dead_time_range_s=(dead, dead), start=START)
    assert want.plants == 1
    assert want.max_sensitivity <= 2.0 + 1e-6 and want.max_complementary_sensitivity <= 1.5 + 1e-6
    assert got["controller.kind"] == "pi"
    for key in ("controller.kp_per_N", "controller.ki_per_N_s"):
        assert got[key] == pytest.approx(want.values[key], rel=1e-4)


def test_oracle_fsp_model_is_the_cells_plant():
    """The predictor's model is the table's row times the material (3 mm: K2 12.57, p2
    -3.75; 2.5 mm interpolates 10.05 and 12.57, -2.35 and -3.75)."""
    v = oracle_fsp(campaign_run(2.0, 1.0), (2.5, 3.0), 45.0, 0.05)
    assert v["nominal_plant.k2_N_min_per_mm_s"] == pytest.approx(3.0 * (10.05 + 12.57) / 2)
    assert v["nominal_plant.p2_rad_s"] == pytest.approx((-2.35 - 3.75) / 2)
    assert v["controller.design_phase_margin_deg"] == 45.0
    assert v["controller.fsp_filter_time_constant_s"] == 0.05
    assert v["controller.fsp_sensor_cutoff_hz"] == 20.0


def percentile_by_hand(x, q):
    """The linear-interpolation percentile: sorted values, position (n - 1) q / 100."""
    s = sorted(x)
    h = (len(s) - 1) * q / 100.0
    lo = math.floor(h)
    hi = min(lo + 1, len(s) - 1)
    return s[lo] + (h - lo) * (s[hi] - s[lo])


def test_per_cell_designs_and_their_p95_on_a_constructed_set():
    """Two candidates per cell on three cells (7 runs): per cell the lower mean IAE without an
    oscillating run wins (cell A: candidate 1; B: candidate 0, as 1 oscillates although its
    mean is lower; C: both oscillate, the lower mean, 1).  The runs' IAE is then each run's
    from its cell's choice, and the p95 is the interpolated percentile written above."""
    A, B, C = (2.0, 0.5), (3.0, 1.0), (4.0, 3.0)
    cells = [A, B, C, A, B, C, A]
    iae = np.array([
        [10.0, 20.0, 300.0, 12.0, 22.0, 320.0, 14.0],
        [5.0, 1.0, 200.0, 6.0, 2.0, 250.0, 7.0],
    ])
    osc = np.zeros_like(iae, bool)
    osc[1, 1] = True  # candidate 1 oscillates in cell B
    osc[:, 2] = True  # both oscillate in cell C
    choice, runs_iae, runs_osc = best_per_cell(cells, iae, osc)
    assert choice == {A: 1, B: 0, C: 1}
    want = [5.0, 20.0, 200.0, 6.0, 22.0, 250.0, 7.0]
    assert runs_iae.tolist() == want
    assert runs_osc.tolist() == [False, False, True, False, False, False, False]
    summary = tail_summary(runs_iae, 250.0, runs_osc)
    assert summary["p95_iae_N_s"] == pytest.approx(percentile_by_hand(want, 95))
    assert summary["p95_iae_N_s"] == pytest.approx(200.0 + 0.7 * 50.0)  # h = 5.7
    assert summary["ratio"] == pytest.approx(235.0 / 250.0)
    assert summary["oscillating_runs"] == 1
    designs = {A: {"k": 1}, B: {"k": 2}, C: {"k": 3}}
    assert [v["k"] for v in per_run_values(cells, designs)] == [1, 2, 3, 1, 2, 3, 1]
    with pytest.raises(KeyError, match="4.0, 3.0"):
        per_run_values(cells, {A: {}, B: {}})
