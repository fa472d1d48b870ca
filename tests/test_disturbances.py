"""Disturbances in the loop: integral action rejects a constant force disturbance exactly
as the sampled loop says (python-control), the observer's attenuation of a slow feed
disturbance is the analysed |S| |1 - Q e^{-jwL}|, runs sharing a noise key share their
random walks, and every disturbance key is checked."""

import math

import control
import numpy as np
import pytest

from acc.design.analysis import loop_response, loop_spec, max_gain_ratio, plant_response
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario, ScenarioError
from controllers.q_filter import q_frequency_response
from controllers.registry import resolved_gains


def constant_depth(time_limit_s: float, **values) -> Scenario:
    base = {
        "workpiece.segment_length_mm": [10_000.0],
        "workpiece.radial_depth_mm": [3.0],
        "workpiece.axial_depth_mm": [10.0],
        "simulation.time_limit_s": time_limit_s,
        "sensor.noise_std_N": 0.0,
        "sensor.lowpass_cutoff_hz": 0.0,
        "controller.initial_override": 0.0,
        "controller.override_min": 0.0,
        "controller.override_max": 100.0,
    }
    return Scenario().with_values({**base, **values})


def test_constant_force_disturbance_is_rejected_as_the_sampled_loop_says():
    """Force = G x + d with d a step of 80 N at 3 s: the force at the control instants equals
    T r + S d of the sampled loop built with python-control (ZOH of Eq. 8 at Tc, z^-10, PI),
    to 1e-9; integral action leaves no steady error."""
    d_N, t0 = 80.0, 3.0
    sc = constant_depth(
        12.0, disturbance=[{"kind": "force", "shape": "step", "amplitude_N": d_N, "start_s": t0}]
    )
    res = simulate(sc)
    tc, m = sc.simulation.control_period_s, sc.simulation.steps_per_control
    g = resolved_gains(sc.controller, sc.nominal_plant, tc)
    a, k2, p2 = 29.33, 12.57, -3.75
    plant = control.c2d(control.tf([a * k2], np.polymul([1, a], [1, -p2])), tc, "zoh")
    delay = control.tf([1], [1] + [0] * 10, tc)
    pi = control.tf([g.kp_per_N, g.ki_per_N_s * tc - g.kp_per_N], [1, -1], tc)
    loop = 120.0 * pi * plant * delay
    n = int(round(12.0 / tc))
    t = np.arange(n) * tc
    _, y_r = control.forced_response(control.feedback(loop, 1), t, np.full(n, 500.0))
    _, y_d = control.forced_response(control.feedback(1, loop), t, np.where(t >= t0, d_N, 0.0))
    f = res.signal("force_N")[0, ::m][:n]
    np.testing.assert_allclose(f, y_r + y_d, rtol=0, atol=1e-9 * 500)
    assert np.max(np.abs(y_d[t >= t0])) > 20.0  # the disturbance did move the force
    assert abs(f[-1] - 500.0) < 1e-3  # zero steady-state error
    assert res.signal("disturbance_force_N")[0, -1] == d_N


def test_observer_attenuates_a_slow_feed_disturbance_as_analysed():
    """dob_pi on its nominal plant, a feed disturbance d sin(w t) at the plant input: the
    steady force amplitude over |P(jw)| d is |S(jw)| of acc analyze's loop, which for P = Pn
    is |S_PI| |1 - Q e^{-jwL}|; within 2 %."""
    w, amp = 1.0, 20.0
    sc = constant_depth(
        45.0,
        **{
            "controller.kind": "dob_pi",
            "controller.initial_override": 1.0,
            "controller.override_min": 0.0,
        },
        disturbance=[{"kind": "feed", "shape": "sinusoid", "amplitude_mm_min": amp,
                      "frequency_hz": w / (2 * math.pi), "start_s": 5.0}],
    )
    res = simulate(sc, record_every_steps=10)
    t, f = res.time_s, res.signal("force_N")[0]
    late = t >= 45.0 - 4 * 2 * math.pi / w  # four periods, transients long gone
    design = np.column_stack([np.sin(w * t[late]), np.cos(w * t[late]), np.ones(late.sum())])
    (s_coef, c_coef, _), *_ = np.linalg.lstsq(design, f[late], rcond=None)
    measured = math.hypot(s_coef, c_coef) / (amp * abs(plant_response(loop_spec(sc), w)))
    spec = loop_spec(sc)  # the 3 mm plant = the nominal plant, with the observer
    s_full = abs(1.0 / (1.0 + loop_response(spec, np.array([w]))[0]))
    assert measured == pytest.approx(s_full, rel=0.02)
    # and the closed form of that S for P = Pn: the analysis puts the hold (half a control
    # period, Tc/2) after the PI, so the observer compares the force with the held command,
    # and S = S_PI |1 - Q e^{-jw(L + Tc/2)}| exactly
    pi_only = loop_spec(sc, kind="pi")
    s_pi = abs(1.0 / (1.0 + loop_response(pi_only, np.array([w]))[0]))
    q = q_frequency_response(w, 0.1)
    tc = sc.simulation.control_period_s
    assert s_full == pytest.approx(s_pi * abs(1 - q * np.exp(-1j * w * (0.1 + tc / 2))), rel=1e-9)


def test_observer_helps_only_below_about_2_8_rad_s():
    """|1 - Q e^{-jwL}| (tau = 0.1 s, L = 0.1 s) is below 1 only under about 2.8 rad/s and
    is 1.22 at the PI's crossover (3.77 rad/s)."""
    w = np.linspace(0.01, 10.0, 100_000)
    g = np.abs(1 - q_frequency_response(w, 0.1) * np.exp(-1j * w * 0.1))
    crossing = w[np.argmax(g >= 1.0)]
    assert 2.7 < crossing < 2.9
    assert abs(1 - q_frequency_response(3.77, 0.1) * np.exp(-1j * 3.77 * 0.1)) == pytest.approx(
        1.22, abs=0.01
    )


@pytest.mark.parametrize(("ratio", "expected"), [(0.8, False), (1.2, True)])
def test_oscillation_detector_fires_above_the_analysed_boundary_only(ratio, expected):
    """With sensor noise and the 20 Hz filter, 20 % below the largest tolerated gain ratio of
    the sampled loop (acc analyze's) the loop settles; 20 % above it oscillates."""
    sc = Scenario().with_values(
        {
            "workpiece.segment_length_mm": [500.0],
            "workpiece.radial_depth_mm": [3.0],
            "workpiece.axial_depth_mm": [10.0],
            "simulation.time_limit_s": 40.0,
            "sensor.noise_std_N": 5.0,
            "sensor.lowpass_cutoff_hz": 20.0,
            "controller.override_max": 4.0,
        }
    )
    k = max_gain_ratio(loop_spec(sc), "sampled", rtol=1e-3)
    res = simulate(
        sc.with_values({"force_process.gain_multiplier": ratio * k}), record_every_steps=None
    )
    assert bool(res.metrics["oscillating"][0]) is expected
    amplitude = res.metrics["limit_cycle_amplitude_N"][0]
    assert (amplitude > 50.0) if expected else (amplitude < 10.0)
    assert not res.metrics["failed"][0]


def test_runs_sharing_a_noise_key_share_their_random_walks():
    walk = {"kind": "force", "shape": "random_walk", "random_walk_N_per_sqrt_s": 10.0}
    sc = constant_depth(2.0, disturbance=[walk])
    res = simulate(
        [sc, sc.with_values({"controller.kind": "dob_pi"}), sc],
        noise_ids=[7, 7, 8],
        record_every_steps=1,
    )
    d = res.signal("disturbance_force_N")
    np.testing.assert_array_equal(d[0], d[1])
    assert not np.array_equal(d[0], d[2])
    # a random walk's increments have the stated intensity: var(delta) = s^2 dt
    inc = np.diff(d[0][np.isfinite(d[0])])
    assert inc.std() == pytest.approx(10.0 * math.sqrt(0.001), rel=0.1)


def test_measurement_bias_is_what_the_controller_regulates_away():
    # a +40 N bias on the measured force: integral action makes the measured force the
    # reference, so the true force settles 40 N below it
    sc = constant_depth(
        15.0, disturbance=[{"kind": "measurement", "bias_N": 40.0, "start_s": 2.0}]
    )
    f = simulate(sc, record_every_steps=100).signal("force_N")[0]
    assert f[-1] == pytest.approx(460.0, abs=1e-3)


def test_hardness_zone_and_axial_profile_scale_the_force():
    # open loop (constant override): the force in a zone is the multiplier times the force
    # outside it, and an axial profile at twice the part's depth doubles it
    base = constant_depth(
        8.0, **{"controller.kind": "constant", "controller.constant_override": 1.0}
    )
    plain = simulate(base, record_every_steps=1)
    zone = simulate(
        base.with_values(
            {"disturbance": [{"kind": "hardness", "gain_multiplier": 1.5, "start_s": 4.0}]}
        ),
        record_every_steps=1,
    )
    deep = simulate(
        base.with_values(
            {"disturbance": [{"kind": "axial_depth", "positions_mm": [0.0],
                              "axial_depth_mm": [20.0]}]}
        ),
        record_every_steps=1,
    )
    t = plain.time_s
    f0 = plain.signal("force_N")[0]
    np.testing.assert_allclose(zone.signal("force_N")[0][t >= 4.0], 1.5 * f0[t >= 4.0],
                               rtol=1e-14)
    np.testing.assert_array_equal(zone.signal("force_N")[0][t < 4.0], f0[t < 4.0])
    np.testing.assert_allclose(deep.signal("force_N")[0], 2.0 * f0, rtol=1e-14)


@pytest.mark.parametrize(
    ("values", "key"),
    [
        ({"disturbance": [{"kind": "torque"}]}, "disturbance[0]"),
        ({"disturbance": [{"kind": "force", "shape": "square"}]}, "disturbance[0]"),
        ({"disturbance": [{"kind": "hardness", "gain_multiplier": -1.0}]}, "gain_multiplier"),
        ({"disturbance": [{"kind": "force", "amplitude_N": "big"}]}, "amplitude_N"),
        ({"disturbance": [{"kind": "force", "start_s": 3.0, "end_s": 1.0}]}, "start_s"),
        ({"disturbance": [{"kind": "axial_depth", "positions_mm": [1.0, 0.0],
                           "axial_depth_mm": [1.0, 2.0]}]}, "positions_mm"),
        ({"disturbance": [{"name": "a"}, {"name": "a"}]}, "used twice"),
        ({"disturbance": [{"kind": "force", "colour": 1}]}, "disturbance[0].colour"),
        ({"disturbance.wear.amplitude_N": 1.0}, "no disturbance named 'wear'"),
        ({"metrics.force_limit_N": -1.0}, "force_limit_N"),
        ({"metrics.oscillation_window_s": 0.0}, "oscillation_window_s"),
        ({"force_process.reference_axial_depth_mm": 0.0}, "reference_axial_depth_mm"),
    ],
)
def test_every_new_key_gives_a_one_line_error_naming_it(values, key):
    with pytest.raises(ScenarioError) as err:
        Scenario().with_values(values)
    message = str(err.value)
    assert key in message
    assert "\n" not in message
