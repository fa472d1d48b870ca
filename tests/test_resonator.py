"""Resonant term of the override PI: off by default (the plain PI law, exactly), its impulse
and frequency response are the written-out resonator, and in the closed loop it rejects a
10 Hz force disturbance exactly as the sampled linear loop (python-control) says."""

import math

import control
import numpy as np
import pytest

from acc.engine.element import step_runs
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario
from controllers.pi import pi_records
from controllers.registry import resolved_gains
from controllers.resonator import ResonantOptions, resonator_records
from controllers.robust_force_controller import robust_records

DIAG = np.full(7, np.nan)
TC = 0.01


def resonator_tf(kr: float, f0_hz: float, phase_deg: float, zeta: float
                 ) -> control.TransferFunction:
    """R(z) written from its definition: poles r e^{+-jW}, impulse response kr Tc r^k
    cos(W k + phi)  (Z{r^k cos(Wk)} = z (z - r cos W) / den, Z{r^k sin(Wk)} = z r sin W / den)."""
    w = 2 * math.pi * f0_hz * TC
    r = math.exp(-zeta * w)
    phi = math.radians(phase_deg)
    den = [1.0, -2 * r * math.cos(w), r * r]
    cos_part = control.tf([1.0, -r * math.cos(w), 0.0], den, TC)
    sin_part = control.tf([r * math.sin(w), 0.0], den, TC)
    return kr * TC * (math.cos(phi) * cos_part - math.sin(phi) * sin_part)


def test_off_by_default_is_the_plain_pi_recurrence_bit_for_bit():
    """resonant_frequency_hz = 0 (the default): the element's overrides equal the PI
    recurrence w = kp e + i, clip, i += ki Tc e (clamping) written here, exactly."""
    rng = np.random.default_rng(3)
    forces = 500.0 + 300.0 * rng.standard_normal(400)
    res = resonator_records([ResonantOptions()], TC)
    assert not res["on"].any()
    p, s = pi_records(500.0, 0.002, 0.01, 0.1, 2.0, 1.0, TC, resonator=res)
    i = 1.0
    for y in forces:
        u = step_runs(p, s, [y], shared=(DIAG,))[0]
        e = 500.0 - y
        w = 0.002 * e + i
        expected = min(max(w, 0.1), 2.0)
        if not ((w > 2.0 and e > 0) or (w < 0.1 and e < 0)):
            i = i + 0.01 * TC * e
        assert u == expected


@pytest.mark.parametrize(("kr", "f0", "phase", "zeta"), [(0.3, 10.0, -165.0, 0.01),
                                                           (2.0, 7.0, 40.0, 0.05)])
def test_impulse_and_frequency_response_are_the_written_resonator(kr, f0, phase, zeta):
    """PI with kp = ki = 0 and wide limits: the override is the resonator's output alone.
    Its impulse response equals python-control's of R(z) to 1e-12, and its DFT (the sum of
    h[k] z^-k, r^k negligible) equals R(e^{jwTc}) to 1e-10 at f0 and elsewhere."""
    opts = ResonantOptions(f0, kr, phase, zeta)
    p, s = pi_records(0.0, 0.0, 0.0, -1e9, 1e9, 0.0, TC,
                      resonator=resonator_records([opts], TC))
    n = 8000
    h = np.array([step_runs(p, s, [-1.0 if k == 0 else 0.0], shared=(DIAG,))[0]
                  for k in range(n)])
    tf = resonator_tf(kr, f0, phase, zeta)
    _, h_ref = control.impulse_response(tf, np.arange(n) * TC)  # a unit-area pulse: 1 / Tc
    np.testing.assert_allclose(h, np.ravel(h_ref) * TC, rtol=0, atol=1e-12)
    w, r = 2 * math.pi * f0 * TC, math.exp(-zeta * 2 * math.pi * f0 * TC)
    k = np.arange(n)
    np.testing.assert_allclose(
        h, kr * TC * r**k * np.cos(w * k + math.radians(phase)), rtol=0, atol=1e-12
    )
    for f in (f0, 0.5 * f0, 2.3):
        z = np.exp(1j * 2 * math.pi * f * TC)
        measured = np.sum(h * z ** -np.arange(n))
        assert abs(measured - tf(z)) < 1e-10
    assert abs(tf(np.exp(1j * 2 * math.pi * f0 * TC))) > 10 * kr * TC  # a resonance


def test_robust_element_adds_the_same_resonator():
    """The element of adaptive_pi / dob_pi (here with neither estimator nor observer, so the
    gain ratio is 1): zero PI gains, wide limits: its impulse response is kr Tc r^k
    cos(W k + phi) to 1e-12."""
    kr, f0, phase, zeta = 0.3, 10.0, -165.0, 0.01
    one = np.ones(1)
    p, s = robust_records(0.0 * one, 0.0 * one, 0.0 * one, -1e9 * one, 1e9 * one, 0.0 * one,
                          120.0 * one, 29.33 * one, 12.57 * one, -3.75 * one, TC,
                          resonator=resonator_records([ResonantOptions(f0, kr, phase, zeta)], TC))
    n = 300
    h = np.array([step_runs(p, s, [-1.0 if k == 0 else 0.0], shared=(DIAG,))[0]
                  for k in range(n)])
    w, r = 2 * math.pi * f0 * TC, math.exp(-zeta * 2 * math.pi * f0 * TC)
    k = np.arange(n)
    np.testing.assert_allclose(
        h, kr * TC * r**k * np.cos(w * k + math.radians(phase)), rtol=0, atol=1e-12
    )


def constant_depth(**values) -> Scenario:
    base = {
        "workpiece.segment_length_mm": [10_000.0],
        "workpiece.radial_depth_mm": [3.0],
        "workpiece.axial_depth_mm": [10.0],
        "simulation.time_limit_s": 12.0,
        "sensor.noise_std_N": 0.0,
        "sensor.lowpass_cutoff_hz": 0.0,
        "controller.initial_override": 0.0,
        "controller.override_min": 0.0,
        "controller.override_max": 100.0,
        "disturbance": [{"kind": "force", "shape": "sinusoid", "amplitude_N": 5.0,
                         "frequency_hz": 10.0, "start_s": 3.0}],
    }
    return Scenario().with_values({**base, **values})


def test_closed_loop_rejects_a_10_hz_force_disturbance_as_the_sampled_loop_says():
    """pi + resonator (10 Hz, kr = 0.3, phi = -165 deg), force = G x + d with d a 5 N
    10 Hz sinusoid from 3 s: the force's response to d (the run with d minus the same run
    without it: the start-up, where the force may touch zero, is the same in both) is S d of
    the sampled loop (ZOH of Eq. 8, z^-10, PI + R(z)) to 1e-9; the steady 10 Hz amplitude is
    |S(e^{jw0 Tc})| x 5 N, about 0.30 of the plain PI's (|S| = 1.0 there)."""
    opts = {"controller.resonant_frequency_hz": 10.0, "controller.resonant_gain_per_N_s": 0.3,
            "controller.resonant_phase_deg": -165.0, "controller.resonant_damping": 0.01}
    amplitude = {}
    for label, extra in (("pi", {}), ("resonant", opts)):
        sc = constant_depth(**extra)
        res = simulate(sc)
        quiet = simulate(constant_depth(**extra, disturbance=[]))
        tc, m = sc.simulation.control_period_s, sc.simulation.steps_per_control
        assert tc == TC
        g = resolved_gains(sc.controller, sc.nominal_plant, tc)
        a, k2, p2 = 29.33, 12.57, -3.75
        plant = control.c2d(control.tf([a * k2], np.polymul([1, a], [1, -p2])), tc, "zoh")
        delay = control.tf([1], [1] + [0] * 10, tc)
        c = control.tf([g.kp_per_N, g.ki_per_N_s * tc - g.kp_per_N], [1, -1], tc)
        if extra:
            c = c + resonator_tf(0.3, 10.0, -165.0, 0.01)
        loop = 120.0 * c * plant * delay
        n = int(round(12.0 / tc))
        t = np.arange(n) * tc
        d = res.signal("disturbance_force_N")[0, ::m][:n]
        _, y_d = control.forced_response(control.feedback(1, loop), t, d)
        f = (res.signal("force_N")[0, ::m] - quiet.signal("force_N")[0, ::m])[:n]
        np.testing.assert_allclose(f, y_d, rtol=0, atol=1e-9 * 500)
        late = t >= 8.0
        w0 = 2 * math.pi * 10.0
        x = np.column_stack([np.sin(w0 * t[late]), np.cos(w0 * t[late]), np.ones(late.sum())])
        (sc_, cc_, _), *_ = np.linalg.lstsq(x, f[late], rcond=None)
        amplitude[label] = math.hypot(sc_, cc_)
        s_pred = abs(control.feedback(1, loop)(np.exp(1j * w0 * tc)))
        assert amplitude[label] == pytest.approx(5.0 * s_pred, rel=0.01)
    assert amplitude["resonant"] / amplitude["pi"] == pytest.approx(0.30, abs=0.02)


def test_bad_keys_and_analysis_refusal():
    with pytest.raises(ValueError, match="resonant_frequency_hz"):
        ResonantOptions(resonant_frequency_hz=-1.0)
    with pytest.raises(ValueError, match="resonant_frequency_hz"):
        ResonantOptions(resonant_frequency_hz=60.0).coefficients(TC)
    from acc.design.analysis import loop_spec

    sc = constant_depth(**{"controller.resonant_frequency_hz": 10.0})
    with pytest.raises(ValueError, match="resonant_frequency_hz"):
        loop_spec(sc)
    loop_spec(constant_depth())  # off: analysable
