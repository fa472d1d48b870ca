"""The closed loop with the geometric force model and with force estimated from feed current."""

import math

import numpy as np
import pytest

from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario, ScenarioError
from plants.cutting_coefficients import CuttingCoefficients
from plants.end_mill_geometry import EndMill, MillingCut, force_process_static_gain_N_per_mm_min


def constant_depth(**extra) -> Scenario:
    values = {
        "workpiece.segment_length_mm": [10_000.0],
        "workpiece.radial_depth_mm": [3.0],
        "workpiece.axial_depth_mm": [10.0],
        "simulation.time_limit_s": 3.0,
        "sensor.noise_std_N": 0.0,
        "sensor.lowpass_cutoff_hz": 0.0,
        "geometry.enabled": True,
    }
    values.update(extra)
    return Scenario().with_values(values)


NO_EDGE = {
    "cutting_coefficients.tangential_edge_N_mm": 0.0,
    "cutting_coefficients.radial_edge_N_mm": 0.0,
    "cutting_coefficients.axial_edge_N_mm": 0.0,
}


def test_without_edge_forces_the_geometric_loop_equals_the_table_loop_with_its_gain():
    """Independent route: the static gain from the geometry, put into a one-row table as
    K2 = G (-p2), must give the same closed loop (force proportional to feed)."""
    geo = constant_depth(**NO_EDGE, **{"geometry.component": "feed"})
    gain = float(
        force_process_static_gain_N_per_mm_min(
            EndMill(),
            MillingCut(3.0, 10.0, 0.05),
            CuttingCoefficients(**{**_coeff_dict(), **_no_edge_dict()}),
            "feed",
        )
    )
    table = constant_depth(
        **{
            "geometry.enabled": False,
            "force_process.radial_depth_mm": [3.0],
            "force_process.k2_N_min_per_mm_s": [gain * 3.75],
            "force_process.p2_rad_s": [-3.75],
        }
    )
    a, b = simulate(geo), simulate(table)
    np.testing.assert_allclose(a.signal("force_N"), b.signal("force_N"), rtol=1e-12, atol=1e-9)


def _coeff_dict() -> dict:
    from dataclasses import asdict

    return asdict(CuttingCoefficients())


def _no_edge_dict() -> dict:
    return {k.split(".")[1]: v for k, v in NO_EDGE.items()}


def test_regulates_the_resultant_to_the_reference_with_edge_forces_on_every_depth():
    scs = [
        constant_depth(
            **{
                "workpiece.radial_depth_mm": [d],
                "simulation.time_limit_s": 25.0,
                "controller.reference_force_N": 300.0,
                "controller.override_max": 4.0,  # 2 mm needs 281 mm/min, above 2 x 120
            }
        )
        for d in (2.0, 3.0, 4.0)
    ]
    res = simulate(scs, record_every_steps=1000)
    # integral action removes the offset of the (affine) edge force exactly
    np.testing.assert_allclose(res.signal("force_N")[:, -1], 300.0, atol=1e-6)


def test_tooth_passing_force_averages_to_the_tooth_period_average():
    """Over whole tooth periods (25 ms = 25 steps at 1 ms) the sample mean of the
    instantaneous feed force is a rectangle rule of the period average: it must agree to
    1e-3 at 1 ms and improve by more than 4x (second order) at 0.5 ms."""
    errors = []
    for dt in (0.001, 0.0005):
        sc = constant_depth(
            **{
                "simulation.plant_step_s": dt,
                "controller.kind": "constant",
                "controller.constant_override": 1.0,
                "geometry.tooth_passing": True,
                "geometry.component": "feed",
            }
        )
        inst = simulate(sc).signal("force_N")[0]
        avg = simulate(sc.with_values({"geometry.tooth_passing": False})).signal("force_N")[0]
        n = int(round(1.0 / dt))  # the last second: 40 whole tooth periods at steady feed
        errors.append(abs(inst[-n:].mean() - avg[-1]) / avg[-1])
        # tooth passing: the force swings well around its mean
        assert inst[-n:].max() > 1.2 * avg[-1] and inst[-n:].min() < 0.8 * avg[-1]
    assert errors[0] < 1e-3
    assert errors[1] < errors[0] / 4


def test_component_that_falls_with_feed_is_rejected():
    with pytest.raises(ScenarioError, match="geometry.component: component 'normal' does not grow"):
        constant_depth(**{"geometry.component": "normal"})


def test_radial_depth_beyond_the_tool_is_rejected():
    with pytest.raises(ScenarioError, match="exceeds the tool diameter"):
        constant_depth(
            **{
                "workpiece.radial_depth_mm": [20.0],
                "force_process.out_of_table": "clamp",
            }
        )


def current_scenario(noise_A: float, **extra) -> Scenario:
    values = {
        "geometry.enabled": False,
        "current_sensing.enabled": True,
        "current_sensing.current_noise_std_A": noise_A,
        "sensor.lowpass_cutoff_hz": 20.0,
        "simulation.time_limit_s": 12.0,
    }
    values.update(extra)
    return constant_depth(**values)


def test_current_estimated_force_without_noise_regulates_the_true_force():
    res = simulate(current_scenario(0.0), record_every_steps=100)
    # noise-free air cuts identify J, B, Tf exactly, so the estimate is the true force one
    # step late: the true force settles on the reference
    assert res.signal("force_N")[0, -1] == pytest.approx(500.0, abs=1e-3)
    assert "feed_current_A" in res.signals


def test_current_noise_reaches_the_controller_filtered_as_predicted():
    """Noise on the current, sigma_I, becomes force noise K_t sigma_I / (p / (2 pi eta)) per
    step; the 20 Hz first-order filter scales its std by sqrt((1 - phi) / (1 + phi))."""
    sigma_i = 0.05
    res = simulate(current_scenario(sigma_i))
    f = res.signal("force_N")[0]
    y = res.signal("measured_force_N")[0]
    steady = slice(6000, None)  # after 6 s: constant force, filter lag negligible
    phi = math.exp(-2 * math.pi * 20.0 * 0.001)
    torque_per_force = 5.08e-3 / (2 * math.pi * 0.89)
    predicted = 0.3 * sigma_i / torque_per_force * math.sqrt((1 - phi) / (1 + phi))
    assert np.std(y[steady] - f[steady]) == pytest.approx(predicted, rel=0.1)
    # and the loop still holds the true force near the reference on average
    assert abs(f[steady].mean() - 500.0) < 2.0


def test_current_sensing_needs_the_feed_component_with_geometry():
    with pytest.raises(ScenarioError, match="current_sensing.enabled"):
        current_scenario(0.0, **{"geometry.enabled": True})
