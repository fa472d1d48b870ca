"""Contouring scenarios (``model = "xy_contour"``) and ``acc run`` on them.

* the shipped mismatched diamond run by ``acc run`` shows the closed-form line error (4.91)
  in its summary (a wiring error between file, axes and metrics would move it);
* ``[servo_axis.y]`` overrides only the y axis; bad keys and impossible combinations are
  one-line errors naming ``section.key``;
* a cross-coupled controller with zero gain run through the coupled XY loop equals the
  independent axes.
"""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from acc.contour_scenario import contour_scenario_from_dict
from acc.design import axis_analysis as aa
from acc.errors import ScenarioError
from controllers.axis.lead_lag import LeadLagParams
from tests.cli_run import ROOT, acc, assert_one_line_error

DIAMOND = str(ROOT / "experiments" / "peng_diamond_mismatched.toml")


def test_acc_run_on_the_mismatched_diamond(tmp_path):
    res = acc("run", DIAMOND, "--out", tmp_path / "d")
    assert res.status == 0, res.err
    with (tmp_path / "d" / "summary.csv").open() as fh:
        row = next(csv.DictReader(fh))
    sc = contour_scenario_from_dict({"simulation": {"model": "xy_contour"},
                                     "servo_axis": {"y": {"viscous_friction_Nm_s_rad": 0.3}}})
    expected = aa.contour_error_mm(sc.axis_x, sc.axis_y, LeadLagParams(), 0.001,
                                   20.0 * math.sqrt(2), math.pi / 4)
    assert float(row["linear_segment_error_mm"]) == pytest.approx(expected, rel=1e-5)
    assert float(row["M1_vertex_distance_mm"]) > 5 * expected
    for name in ("traces.npz", "traces.csv", "path.png", "contour_error.png"):
        assert (tmp_path / "d" / name).stat().st_size > 0


def test_per_axis_overrides_and_errors(tmp_path):
    sc = contour_scenario_from_dict({"simulation": {"model": "xy_contour"},
                                     "servo_axis": {"inertia_kg_m2": 0.004,
                                                    "y": {"viscous_friction_Nm_s_rad": 0.3}}})
    assert sc.axis_x.viscous_friction_Nm_s_rad == 0.09
    assert sc.axis_y.viscous_friction_Nm_s_rad == 0.3
    assert sc.axis_x.inertia_kg_m2 == sc.axis_y.inertia_kg_m2 == 0.004
    for data, key in (
        ({"path": {"kind": "spiral"}}, "path.kind"),
        ({"servo_axis": {"y": {"bogus": 1.0}}}, "servo_axis.y.bogus"),
        ({"integrator_switching": {"enabled": True}}, "integrator_switching.enabled"),
        ({"path": {"corner": "accel_decel", "accel_time_s": 0.1005}}, "path.accel_time_s"),
        ({"lanes": {}}, "[lanes]"),
    ):
        with pytest.raises(ScenarioError, match=key.replace("[", r"\[").replace(".", r"\.")):
            contour_scenario_from_dict({"simulation": {"model": "xy_contour"}, **data})
    res = acc("run", DIAMOND, "--out", tmp_path / "x", "--set", "path.feed_per_axis_mm_s=-1")
    assert_one_line_error(res, "path.feed_per_axis_mm_s")


def test_zero_gain_cec_equals_the_independent_axes():
    base = {"simulation": {"model": "xy_contour"},
            "path": {"kind": "diamond", "lead_in_s": 0.3, "lead_out_s": 0.2},
            "servo_axis": {"y": {"viscous_friction_Nm_s_rad": 0.3}}}
    _, pos_a, _ = contour_scenario_from_dict(base).simulate()
    cec = {**base, "contour_controller": {"kind": "cec", "kp_V_per_mm": 0.0}}
    _, pos_b, _ = contour_scenario_from_dict(cec).simulate()
    np.testing.assert_allclose(pos_b, pos_a, rtol=0, atol=1e-12)
