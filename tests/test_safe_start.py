"""The adaptive kinds' safe start: the estimate starts at the stiffest plant of the declared
``[design]`` set and stays in it, and the tool entering the material at a low override is
never overloaded on any plant of the set (the nominal start spiked to several times the
reference on stiff plants)."""

from __future__ import annotations

import numpy as np
import pytest

from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario
from controllers.gain_estimator import EstimatorOptions, estimator_records
from plants.design_set import DesignSet

A, K2N, P2N = 29.33, 12.57, -3.75  # nominal model (Eq. 9)
GN = K2N / -P2N  # nominal static gain [N/(mm/min)]
R = 500.0


def test_estimator_starts_at_the_stiffest_plant_and_is_bounded_by_the_set():
    sets = [DesignSet(gain_ratio_range=(0.3, 15.0)),
            DesignSet(gain_ratio_range=(0.5, 2.0), pole_range_rad_s=(-8.0, -2.0))]
    opts = [EstimatorOptions(estimator="output_error"), EstimatorOptions(estimator="rls")]
    params, state = estimator_records(opts, [A, A], [K2N, K2N], [P2N, P2N], [10, 10], [R, R],
                                      [120.0, 120.0], 0.01, design=sets)
    np.testing.assert_allclose(params["static_gain_min_N_per_mm_min"], [0.3 * GN, 0.5 * GN])
    np.testing.assert_allclose(params["static_gain_max_N_per_mm_min"], [15 * GN, 2 * GN])
    # start: the largest static gain with the nominal pole (inside the declared pole range)
    assert state["static_gain_N_per_mm_min"][0] == pytest.approx(15 * GN, rel=1e-12)
    assert state["p2_rad_s"][0] == pytest.approx(P2N, rel=1e-12)
    # rls: theta0 = exp(p2 Tc) and the ZOH numerator of a K2 / ((s + a)(s - p2)), K2 = 2 K2n
    a, p, k2, tc = A, P2N, 2 * GN * -P2N, 0.01
    # the numerator's sum is the static gain times (1 - phi_a)(1 - phi_2) (unit DC gain)
    b_sum = k2 / -p * (1 - np.exp(-a * tc)) * (1 - np.exp(p * tc))
    assert params["theta0"][1][0] == pytest.approx(np.exp(p * tc), rel=1e-12)
    assert (params["theta0"][1][1] + params["theta0"][1][2]) * R / 120.0 == pytest.approx(
        b_sum, rel=1e-9)
    # the pole range declared: phi2 bounds and the output-error grid span it
    assert params["phi2_min"][1] == pytest.approx(np.exp(-8.0 * tc), rel=1e-12)
    assert params["phi2_max"][1] == pytest.approx(np.exp(-2.0 * tc), rel=1e-12)
    grid = params["pole_grid_rad_s"][1]
    assert grid.min() == pytest.approx(-8.0, rel=1e-9) and grid.max() == pytest.approx(-2.0)
    nominal = estimator_records(EstimatorOptions(estimator_start="nominal"), A, K2N, P2N, 10, R,
                                120.0, 0.01, design=sets[0])[1]
    assert nominal["static_gain_N_per_mm_min"][0] == pytest.approx(GN, rel=1e-12)


def _entry(kind: str, ratio: float, start: str) -> float:
    """Peak force [N] of ``kind`` entering a 3 mm part of static gain ``ratio`` x nominal at
    override 0.1, the declared set 0.3-15."""
    sc = Scenario().with_values({
        "controller.kind": kind, "controller.estimator_start": start,
        "controller.initial_override": 0.1, "controller.override_max": 4.0,
        "controller.estimator_sensor_cutoff_hz": 20.0,
        "sensor.noise_std_N": 5.0, "sensor.lowpass_cutoff_hz": 20.0,
        "workpiece.radial_depth_mm": [3.0], "workpiece.segment_length_mm": [4.0],
        "workpiece.axial_depth_mm": [10.0], "force_process.gain_multiplier": ratio,
        "design.gain_ratio_range": [0.3, 15.0], "simulation.time_limit_s": 8.0,
    })
    return float(simulate(sc, record_every_steps=None).metrics["peak_force_N"][0])


@pytest.mark.parametrize("ratio", [3.0, 8.0, 15.0])
def test_entry_peak_on_stiff_plants_of_the_declared_set(ratio):
    """Within 1.5 r on every stiff plant of the set; at 15x the lowest override alone gives
    0.1 x 120 x 15 G_n = 603 N, which no controller removes.  The nominal start (the kinds'
    former behaviour) overloads the same plants at 2-7 r: the test can tell them apart."""
    floor = 0.1 * 120.0 * ratio * GN
    safe = _entry("adaptive_pi", ratio, "stiffest")
    assert safe <= 1.5 * R
    assert safe <= max(1.1 * R, 1.05 * floor)
    assert _entry("adaptive_pi", ratio, "nominal") > 2.0 * R
