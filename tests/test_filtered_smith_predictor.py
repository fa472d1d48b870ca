"""Filtered Smith predictor (fsp_pi, fsp_adaptive_pi): the delay-free design rule, the Smith
predictor's closed form with a perfect model, and the law in the compiled loop against one
written here from the equations (python-control / scipy), with the delayed model output.

The largest tolerated gain ratio of these loops is checked against their characteristic
polynomial in tests/test_observer_structures.py.
"""

import math

import control
import numpy as np
import pytest
from scipy.linalg import expm
from scipy.signal import lfilter

from acc.design.analysis import loop_spec
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario
from controllers.filtered_smith_predictor import design_delay_free_pi
from controllers.registry import ControllerParams
from plants.nominal_plant import NominalPlant

A, K2, P2, TC, N_DELAY, FEED, REF = 29.33, 12.57, -3.75, 0.01, 10, 120.0, 500.0


@pytest.mark.parametrize("sensor_hz, margin", [(0.0, 60.0), (20.0, 60.0), (20.0, 45.0)])
def test_delay_free_design_rule_puts_the_margin_at_the_crossover(sensor_hz, margin):
    """``|L(j w_c)| = 1`` and ``arg L(j w_c) = -180 + phi_m`` for the delay-free loop
    ``F (kp + ki / s) G_m e^{-s T_c / 2}`` (closed form evaluated here), zero on the pole."""
    g = design_delay_free_pi(NominalPlant(), FEED, TC, margin, sensor_hz)
    s = 1j * g.crossover_rad_s
    sensor = 1 / (1 + s / (2 * np.pi * sensor_hz)) if sensor_hz else 1.0
    loop = FEED * (g.kp_per_N + g.ki_per_N_s / s) * A * K2 / ((s + A) * (s - P2)) * sensor
    loop *= np.exp(-s * TC / 2)
    assert abs(loop) == pytest.approx(1.0, rel=1e-10)
    assert math.degrees(np.angle(loop)) == pytest.approx(-180.0 + margin, abs=1e-8)
    assert g.ki_per_N_s == pytest.approx(g.kp_per_N * -P2, rel=1e-14)


def _one_segment(kind, depth=3.0, **extra):
    return Scenario().with_values(
        {
            "controller.kind": kind,
            "controller.override_min": 0.0,
            "controller.override_max": 100.0,
            "workpiece.segment_length_mm": [20.0],
            "workpiece.radial_depth_mm": [depth],
            "workpiece.axial_depth_mm": [10.0],
            "sensor.noise_std_N": 0.0,
            "sensor.lowpass_cutoff_hz": 0.0,
            "simulation.time_limit_s": 4.0,
            **{f"controller.{k}": v for k, v in extra.items()},
        }
    )


def _model_zoh(k2, p2, sensor_hz=0.0):
    """ZOH at T_c of the delay-free model on states (v, f, z) (scipy's expm)."""
    ws = 2 * np.pi * sensor_hz
    M = np.zeros((4, 4))
    M[:3, :3] = [[-A, 0.0, 0.0], [k2, p2, 0.0], [0.0, ws, -ws]]
    M[0, 3] = A
    E = expm(M * TC)
    return E[:3, :3], E[:3, 3]


def test_perfect_model_reference_response_is_the_delay_free_loop_delayed():
    """Smith predictor's closed form: plant = model (the 3 mm row is Eq. 9, no sensor, no
    noise, no clamp), so the prediction error is zero and the force at the control instants
    is the delay-free PI loop's (written here) delayed by ``N = L / T_c`` periods."""
    sc = _one_segment("fsp_pi")
    res = simulate(sc, record_every_steps=sc.simulation.steps_per_control)
    f = res.signal("force_N")[0]
    f = f[np.isfinite(f)]
    spec = loop_spec(sc)
    Ad, Bd = _model_zoh(K2, P2)
    x = np.zeros(3)
    integral = sc.controller.initial_override
    delay_free = np.empty(len(f))
    for k in range(len(f)):
        delay_free[k] = x[1]
        e = REF - x[1]
        override = spec.kp_per_N * e + integral
        integral += spec.ki_per_N_s * TC * e
        x = Ad @ x + Bd * override * FEED
    expected = np.r_[np.zeros(N_DELAY), delay_free[: len(f) - N_DELAY]]
    np.testing.assert_allclose(f, expected, rtol=0, atol=1e-9 * REF)
    assert np.ptp(f) > 400.0 and abs(f[-1] - REF) < 1.0  # a full step response, settled


def _replay(sc, res, model_sensor_hz, filter_s):
    """Override the FSP law gives from the recorded measured force and commands, written
    here: y0 = G_m u (python-control ZOH), e_p = y - y0[k - N], e_f = F_r e_p (lfilter),
    e = r - (y0 + e_f), override = kp e + i0 + ki T_c sum_{j<k} e_j."""
    y = res.signal("measured_force_N")[0]
    keep = np.isfinite(y)
    y, override = y[keep], res.signal("override")[0][keep]
    u = override * FEED
    g = control.tf([A * K2], np.polymul([1, A], [1, -P2]))
    if model_sensor_hz:
        g = g * control.tf([1.0], [1 / (2 * np.pi * model_sensor_hz), 1.0])
    t = np.arange(len(y)) * TC
    y0 = control.forced_response(control.c2d(g, TC, "zoh"), T=t, U=u).outputs
    ep = y - np.r_[np.zeros(N_DELAY), y0[: len(y) - N_DELAY]]
    beta = math.exp(-TC / filter_s)
    ef = lfilter([1 - beta], [1, -beta], ep)
    e = REF - (y0 + ef)
    spec = loop_spec(sc)
    integral = sc.controller.initial_override + spec.ki_per_N_s * TC * np.r_[0, np.cumsum(e)[:-1]]
    return override, spec.kp_per_N * e + integral, ef


def test_fsp_pi_in_the_compiled_loop_equals_the_law_written_here():
    """The shipped part (2 -> 3 -> 4 mm: the plant leaves the model), 5 N noise, the 20 Hz
    sensor in plant and model, T_r = 0.2 s; every control instant."""
    sc = Scenario().with_values(
        {
            "controller.kind": "fsp_pi",
            "controller.fsp_sensor_cutoff_hz": 20.0,
            "controller.override_min": 0.0,
            "controller.override_max": 100.0,
            "sensor.noise_std_N": 5.0,
            "sensor.lowpass_cutoff_hz": 20.0,
        }
    )
    res = simulate(sc, record_every_steps=sc.simulation.steps_per_control)
    override, expected, ef = _replay(sc, res, 20.0, 0.2)
    assert 0.0 < override.min() and override.max() < 100.0  # no clamp acted
    np.testing.assert_allclose(override, expected, rtol=0, atol=1e-9)
    assert np.ptp(ef) > 50.0  # the prediction error is working (depth steps)


@pytest.mark.parametrize("start", ["nominal", "stiffest"])
def test_fsp_adaptive_pi_in_the_compiled_loop_equals_the_law_written_here(start):
    """As above with the estimator: at every control instant the PI gains follow the
    recorded estimate by the adaptive_pi rule, ``kp = kp_n K2n / K2``, ``ki = ki_n (K2n /
    K2)(p2 / p2n)``, and the delay-free model is re-discretised (scipy's expm here) from it
    whenever the estimator updated; its states (v, f, z) carry over.  With the safe start
    (``"stiffest"``, the default) the estimate, the model and the gains start at the design
    set's stiffest plant (the default set's static gain x5, nominal pole), the integrator at
    ``initial_override - kp0 r`` (the first output is the initial override) and a gain
    change moves the integrator by ``(kp[k-1] - kp[k]) e[k]`` (bumpless)."""
    sc = Scenario().with_values(
        {
            "controller.estimator_start": start,
            "controller.kind": "fsp_adaptive_pi",
            "controller.override_min": 0.0,
            "controller.override_max": 100.0,
            "sensor.noise_std_N": 5.0,
            "sensor.lowpass_cutoff_hz": 20.0,
            "controller.estimator_sensor_cutoff_hz": 20.0,
        }
    )
    res = simulate(sc, record_every_steps=sc.simulation.steps_per_control)
    y = res.signal("measured_force_N")[0]
    keep = np.isfinite(y)
    y, override = y[keep], res.signal("override")[0][keep]
    kp, ki = res.signal("kp_per_N")[0][keep], res.signal("ki_per_N_s")[0][keep]
    k2h = res.signal("estimated_k2_N_min_per_mm_s")[0][keep]
    p2h = res.signal("estimated_p2_rad_s")[0][keep]
    updated = res.signal("estimator_updated")[0][keep]
    assert 0.0 < override.min() and override.max() < 100.0  # no clamp acted
    assert updated.sum() > 10 and np.ptp(k2h) > 1.0  # the model does adapt
    nominal = loop_spec(sc)  # the designed gains on the nominal plant
    np.testing.assert_allclose(kp, nominal.kp_per_N * K2 / k2h, rtol=1e-12)
    np.testing.assert_allclose(ki, nominal.ki_per_N_s * (K2 / k2h) * (p2h / P2), rtol=1e-12)
    safe = start == "stiffest"
    k2_start = K2 * (sc.design.gain_ratio_range[1] if safe else 1.0)
    assert k2h[0] == pytest.approx(k2_start, rel=1e-12)  # the first periods: the start plant
    assert p2h[0] == pytest.approx(P2, rel=1e-12)
    kp0 = nominal.kp_per_N * K2 / k2_start
    Ad, Bd = _model_zoh(k2_start, P2)
    x = np.zeros(3)
    history = np.zeros(len(y))
    integral = sc.controller.initial_override - (kp0 * REF if safe else 0.0)
    ef = 0.0
    beta = math.exp(-TC / 0.2)
    expected = np.empty(len(y))
    for k in range(len(y)):
        if updated[k]:
            Ad, Bd = _model_zoh(k2h[k], p2h[k])
        history[k] = x[1]
        ef = beta * ef + (1 - beta) * (y[k] - (history[k - N_DELAY] if k >= N_DELAY else 0.0))
        e = REF - (x[1] + ef)
        if safe and k > 0:
            integral += (kp[k - 1] - kp[k]) * e
        expected[k] = kp[k] * e + integral
        integral += ki[k] * TC * e
        x = Ad @ x + Bd * override[k] * FEED
    np.testing.assert_allclose(override, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    "values, match",
    [
        ({"fsp_filter_time_constant_s": -0.1}, "fsp_filter_time_constant_s must be >= 0"),
        ({"fsp_sensor_cutoff_hz": float("nan")}, "fsp_sensor_cutoff_hz must be >= 0"),
    ],
)
def test_bad_predictor_keys_are_one_line_errors(values, match):
    with pytest.raises(ValueError, match=match) as err:
        ControllerParams.from_values({"kind": "fsp_pi", **values})
    assert "\n" not in str(err.value)
