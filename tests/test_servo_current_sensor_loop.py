"""Peng's force estimators as the force loop's sensor (``sensor.kind``) on the servo axis.

Numbers from: the estimators' closed forms (inverse model: the previous plant step's feed
force, exactly; steady state: ``F + J_e dW/dt / k``), the current-noise prediction
``sigma_i sqrt(c1^2 + c3^2) / k`` with ``c1, c3`` computed here from Peng's (2.5)-(2.7) by
scipy's ZOH, and scipy's ``lfilter`` for the low-passed case."""

import math

import numpy as np
import pytest
from scipy.signal import cont2discrete, lfilter

from acc.engine.simulate import simulate
from acc.scenarios.force import ScenarioError, scenario_from_dict
from plants.axis.servo_axis import ServoAxisParams

AXIS = ServoAxisParams()  # the force loop's servo axis (Peng's Appendix A)
K_FT = 9.45e-4  # T_c = k F (3.37)
DT = 1e-3


def _run(kind: str, **sensor):
    data = {
        "feed_drive": {"kind": "servo_axis"},
        "sensor": {"kind": kind, **sensor},
        "simulation": {"time_limit_s": 4.0, "seed": 11},
        "workpiece": {"segment_length_mm": [3.0, 3.0], "radial_depth_mm": [2.0, 4.0],
                      "axial_depth_mm": [10.0, 10.0]},
    }
    r = simulate(scenario_from_dict(data))
    return r.signal("force_N")[0], r.signal("measured_force_N")[0], r


def _peng_c1_c3() -> tuple[float, float]:
    """Inverse-model current coefficients from (2.5)-(2.7) written here, scipy's ZOH."""
    a = AXIS
    r1 = a.armature_resistance_ohm + a.pwm_gain_V_A * a.current_feedback_gain
    kb1 = a.back_emf_V_s_rad + a.pwm_gain_V_A * a.current_amp_gain_A_V * a.tacho_gain * (
        a.tacho_constant_V_s_rad)
    la, je = a.armature_inductance_H, a.inertia_kg_m2
    A = np.array([[-r1 / la, -kb1 / la],
                  [a.torque_constant_Nm_A / je, -a.viscous_friction_Nm_s_rad / je]])
    B = np.array([[a.pwm_gain_V_A * a.current_amp_gain_A_V * a.command_gain / la, 0.0],
                  [0.0, -1.0 / je]])
    phi, h, *_ = cont2discrete((A, B, np.eye(2), np.zeros((2, 2))), DT, method="zoh")
    hinv = np.linalg.inv(h)
    return float(hinv[1, 0]), float(-(hinv @ phi)[1, 0])


def test_inverse_model_regulates_the_previous_steps_feed_force_exactly():
    force, measured, r = _run("peng_inverse_model")
    assert np.nanmax(force) > 400.0  # the loop cut and regulated
    assert measured[0] == 0.0  # nothing estimated before the first pair of samples
    # 1e-9 N: rounding of the 2x2 inversion at forces of hundreds of newtons
    np.testing.assert_allclose(measured[1:], force[:-1], rtol=0, atol=1e-9)
    # same instant would be wrong by the force's step-to-step change
    assert np.max(np.abs(measured[1:] - force[1:])) > 1e-3
    assert "feed_current_A" in r.signals


def test_steady_state_estimate_is_the_current_minus_the_viscous_tare_and_settles_on_the_force():
    force, measured, r = _run("peng_steady_state")
    current = r.signal("feed_current_A")[0]
    w = r.signal("feed_velocity_mm_min")[0] / (60.0 * AXIS.mm_per_rad)  # motor speed [rad/s]
    # (3.36) on the same sample's current and speed: no delay, tare B W
    closed_form = (AXIS.torque_constant_Nm_A * current - AXIS.viscous_friction_Nm_s_rad * w) / K_FT
    np.testing.assert_allclose(measured, closed_form, rtol=0, atol=1e-9)
    # its error is the inertia torque J_e dW/dt: hundreds of N while the axis accelerates
    # at the entry, and nothing once the feed settles in the cut
    assert np.max(np.abs(measured - force)) > 100.0
    cut = np.flatnonzero(force > 0)
    settled = cut[-300:-1]  # the last 0.3 s of the 4 mm segment (the feed has settled)
    np.testing.assert_allclose(measured[settled], force[settled], atol=1.0)


def test_current_noise_of_the_inverse_model_matches_its_prediction():
    sigma = 0.05
    force, measured, _ = _run("peng_inverse_model", current_noise_std_A=sigma)
    c1, c3 = _peng_c1_c3()
    assert c1 + c3 == pytest.approx(AXIS.torque_constant_Nm_A, rel=1e-9)
    residual = measured[1:] - force[:-1]  # the noise term, exactly, sample by sample
    predicted = sigma * math.hypot(c1, c3) / K_FT
    # 4000 samples: the sample std's standard error is 1.1 %; 5 % is > 4 of them
    assert np.std(residual) == pytest.approx(predicted, rel=0.05)
    lag1 = np.corrcoef(residual[1:], residual[:-1])[0, 1]
    assert lag1 == pytest.approx(c1 * c3 / (c1**2 + c3**2), abs=0.05)


def test_current_noise_through_the_sensor_lowpass():
    sigma, fc = 0.05, 50.0
    force, measured, _ = _run("peng_inverse_model", current_noise_std_A=sigma,
                              lowpass_cutoff_hz=fc)
    c1, c3 = _peng_c1_c3()
    phi = math.exp(-2 * math.pi * fc * DT)
    clean = lfilter([1 - phi], [1, -phi], np.concatenate([[0.0], force[:-1]]))
    residual = (measured - clean)[100:]  # the filter's start-up transient of zero noise
    impulse = lfilter([1 - phi], [1, -phi], np.r_[[c1, c3], np.zeros(400)])
    predicted = sigma / K_FT * math.sqrt(np.sum(impulse**2))
    assert np.std(residual) == pytest.approx(predicted, rel=0.1)  # ~ 400 independent samples


@pytest.mark.parametrize(
    ("values", "key"),
    [
        ({"sensor": {"kind": "peng_inverse_model"}}, "sensor.kind"),
        ({"sensor": {"kind": "peng_steady_state"}, "feed_drive": {"kind": "fopdt"}},
         "sensor.kind"),
        ({"sensor": {"kind": "peng_inverse_model"}, "feed_drive": {"kind": "servo_axis"},
          "current_sensing": {"enabled": True}}, "sensor.kind"),
        ({"sensor": {"kind": "peng_inverse_model"}, "feed_drive": {"kind": "servo_axis"},
          "geometry": {"enabled": True, "component": "resultant_xy"}}, "sensor.kind"),
        ({"sensor": {"kind": "strain_gauge"}}, "sensor.kind"),
        ({"sensor": {"current_noise_std_A": 0.1}}, "sensor.current_noise_std_A"),
    ],
)
def test_bad_combinations_are_one_line_errors_naming_the_key(values, key):
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(values, source="s.toml")
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"s.toml: {key}:")
