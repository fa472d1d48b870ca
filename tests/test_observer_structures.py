"""Observer structures for the 0.1 s dead time: Q with a designed numerator, the observer whose
model includes the sensor's low-pass, and (with the filtered Smith predictor) the largest
tolerated gain ratio of each new loop.

Oracles, all written here from the equations: python-control's first-order-hold and
zero-order-hold ``c2d`` of ``Q (H_n P_n0)^{-1}`` and ``Q`` with the delayed command (Eqs.
10-11 with the sensor), the PI written as a sum, and the characteristic polynomial of each
sampled loop multiplied out with numpy.
"""

import control
import numpy as np
import pytest

from acc.design.analysis import loop_spec, max_gain_ratio
from acc.engine.element import call_runs
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario
from controllers.disturbance_observer import advance, estimate, observer_records

A, K2, P2, TC, N_DELAY = 29.33, 12.57, -3.75, 0.01, 10
SHIPPED_PART = {
    "sensor.noise_std_N": 5.0,
    "sensor.lowpass_cutoff_hz": 20.0,
    "controller.override_min": 0.0,
    "controller.override_max": 100.0,  # no clamp: the law is linear
}


def _q_tf(tau, numerator, order):
    s = control.tf("s")
    return sum(a * (tau * s) ** i for i, a in enumerate(numerator)) / (tau * s + 1) ** order


def _observer_paths(tau, numerator, order, sensor_hz, k2=K2, p2=P2):
    """Force path ``Q (H_n P_n0)^{-1}`` by first-order hold, command path ``Q`` by
    zero-order hold (Eqs. 10-11; the force is continuous, the command held)."""
    q = _q_tf(tau, numerator, order)
    inverse = control.tf([1.0, A - p2, -A * p2], [A * k2])
    if sensor_hz:
        inverse = inverse * control.tf([1.0 / (2 * np.pi * sensor_hz), 1.0], [1.0])
    return control.c2d(q * inverse, TC, method="foh"), control.c2d(q, TC, method="zoh")


def _delayed(u, n):
    return np.concatenate([np.zeros(n), u[: len(u) - n]])


@pytest.mark.parametrize(
    "numerator, order, sensor_hz",
    [((1.0, 3.0), 3, 0.0), ((1.0, 2.0), 4, 20.0), ((1.0,), 3, 20.0)],
)
def test_observer_transient_with_numerator_and_sensor_model_equals_eqs_10_11(
    numerator, order, sensor_hz
):
    """d_hat = Q (H_n P_n0)^-1 f - Q e^{-L_n s} u at every sample of random sequences."""
    tau = 0.1
    force_path, command_path = _observer_paths(tau, numerator, order, sensor_hz)
    rng = np.random.default_rng(11)
    n = 300
    f = 500.0 + np.cumsum(rng.normal(0.0, 5.0, n))
    u = 120.0 + np.cumsum(rng.normal(0.0, 2.0, n))
    t = np.arange(n) * TC
    expected = (
        control.forced_response(force_path, T=t, U=f).outputs
        - control.forced_response(command_path, T=t, U=_delayed(u, N_DELAY)).outputs
    )
    q = _q_tf(tau, numerator, order)
    q_poly = (np.ravel(q.num[0][0]), np.ravel(q.den[0][0]))
    params, state = observer_records([q_poly], N_DELAY, TC, sensor_cutoff_hz=sensor_hz)
    got = np.empty(n)
    for k in range(n):
        got[k] = call_runs(estimate, params, state, f[k], A, K2, P2)[0]
        call_runs(advance, params, state, f[k], u[k])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    assert np.ptp(expected[N_DELAY:]) > 10.0  # a transient, not a constant


def _control_instants(res):
    """Measured force and override at the control instants (traces every period)."""
    y = res.signal("measured_force_N")[0]
    keep = np.isfinite(y)
    return y[keep], res.signal("override")[0][keep]


def test_dob_pi_with_numerator_and_sensor_model_in_the_compiled_loop():
    """The shipped part (2 -> 3 -> 4 mm, 5 N noise, 20 Hz sensor), observer with Q = (1 + 2
    tau s) / (tau s + 1)^4 and the sensor in its model: the override the compiled loop sent
    at every control instant equals the law written here from the recorded measured force,
    ``o = kp e + i0 + ki T_c sum_{j<k} e_j - d_hat / F`` with d_hat from Eqs. 10-11
    (python-control) and the command delayed by N periods."""
    numerator, order, sensor_hz, tau = (1.0, 2.0), 4, 20.0, 0.1
    sc = Scenario().with_values(
        {
            **SHIPPED_PART,
            "controller.kind": "dob_pi",
            "controller.dob_q_numerator": list(numerator),
            "controller.dob_q_order": order,
            "controller.dob_sensor_cutoff_hz": sensor_hz,
        }
    )
    res = simulate(sc, record_every_steps=sc.simulation.steps_per_control)
    y, override = _control_instants(res)
    assert 0.0 < override.min() and override.max() < 100.0  # no clamp acted
    spec = loop_spec(sc)
    F, r = sc.controller.programmed_feed_mm_min, sc.controller.reference_force_N
    u = override * F
    t = np.arange(len(y)) * TC
    force_path, command_path = _observer_paths(tau, numerator, order, sensor_hz)
    d_hat = (
        control.forced_response(force_path, T=t, U=y).outputs
        - control.forced_response(command_path, T=t, U=_delayed(u, N_DELAY)).outputs
    )
    e = r - y
    integral = sc.controller.initial_override + spec.ki_per_N_s * TC * np.r_[0.0, np.cumsum(e)[:-1]]
    expected = spec.kp_per_N * e + integral - d_hat / F
    np.testing.assert_allclose(override, expected, rtol=0, atol=1e-9)
    assert np.ptp(d_hat) > 20.0  # the observer is working (depth steps), not idle


def _nominal(kind, **extra):
    return Scenario().with_values(
        {
            "controller.kind": kind,
            "controller.override_max": 100.0,
            "workpiece.segment_length_mm": [30.0],
            "workpiece.radial_depth_mm": [3.0],
            "workpiece.axial_depth_mm": [10.0],
            "sensor.noise_std_N": 0.0,
            "sensor.lowpass_cutoff_hz": 20.0,
            "simulation.plant_step_s": 0.0002,
            "simulation.time_limit_s": 4.0,
            **{f"controller.{k}": v for k, v in extra.items()},
        }
    )


def test_observer_with_the_sensor_in_its_model_keeps_the_nominal_loop():
    """DOB nominal invariance: plant = model (the 3 mm row is Eq. 9) with the 20 Hz sensor,
    no noise.  The observer that models the sensor leaves the bare PI loop's force; the one
    that ignores it does not (the sensor is then a model error ``H - 1``).  The residual of
    the first is discretisation: the force path's first-order hold assumes a force linear
    between samples (0.08 N without any sensor) and the simulator's sensor is a per-plant-step
    filter (0.16 N in all at the 0.2 ms step used here, 0.67 N at 1 ms)."""
    scs = [
        _nominal("pi"),
        _nominal("dob_pi"),
        _nominal("dob_pi", dob_sensor_cutoff_hz=20.0),
    ]
    res = simulate(scs, record_every_steps=5)
    f = res.signal("force_N")
    n = min(int(np.isfinite(f[i]).sum()) for i in range(3))
    ignores = np.abs(f[1, :n] - f[0, :n]).max()
    models = np.abs(f[2, :n] - f[0, :n]).max()
    assert ignores > 7.0
    assert models < 0.25
    assert np.ptp(f[0, :n]) > 400.0  # the comparison spans the start-up transient


# --- largest tolerated k / kn: characteristic polynomials written here ----------------------
def _tf_polys(sys):
    return np.ravel(sys.num[0][0]), np.ravel(sys.den[0][0])


def _plant_zoh(spec, gain_ratio):
    """ZOH at T_c of ``k a K2 / ((s + a)(s - p2))`` times the sensor (continuous, exact)."""
    a, k2, p2 = spec.bandwidth_rad_s, spec.k2_N_min_per_mm_s * gain_ratio, spec.p2_rad_s
    p = control.tf([a * k2], np.polymul([1, a], [1, -p2]))
    if spec.sensor_cutoff_hz:
        p = p * control.tf([1.0], [1.0 / (2 * np.pi * spec.sensor_cutoff_hz), 1.0])
    return _tf_polys(control.c2d(p, spec.control_period_s, "zoh"))


def _pi_polys(spec):
    tc, feed = spec.control_period_s, spec.programmed_feed_mm_min
    return feed * np.array([spec.kp_per_N, spec.ki_per_N_s * tc - spec.kp_per_N]), [1.0, -1.0]


def _shift(n):
    z = np.zeros(n + 1)
    z[0] = 1.0
    return z


def _characteristic_dob(spec, k):
    """``(1 - G_Q z^-N) + k (C + F_Q) P z^-N = 0`` multiplied out (Eqs. 10-11 with the
    sensor model); F_Q, G_Q the observer paths written above."""
    n = round(spec.dead_time_s / spec.control_period_s)
    num_p, den_p = _plant_zoh(spec, k)
    num_c, den_c = _pi_polys(spec)
    q = _q_tf(spec.dob_tau_s, spec.dob_q_numerator, spec.dob_q_order)
    inverse = control.tf([1.0, spec.bandwidth_rad_s - spec.nominal_p2_rad_s,
                          -spec.bandwidth_rad_s * spec.nominal_p2_rad_s],
                         [spec.bandwidth_rad_s * spec.nominal_k2_N_min_per_mm_s])
    if spec.dob_sensor_cutoff_hz:
        inverse = inverse * control.tf([1.0 / (2 * np.pi * spec.dob_sensor_cutoff_hz), 1.0],
                                       [1.0])
    num_f, den_f = _tf_polys(control.c2d(q * inverse, spec.control_period_s, "foh"))
    num_g, den_g = _tf_polys(control.c2d(q, spec.control_period_s, "zoh"))
    one = np.polymul(np.polymul(np.polysub(np.polymul(den_g, _shift(n)), num_g), den_c),
                     np.polymul(den_f, den_p))
    c_plus_f = np.polyadd(np.polymul(num_c, den_f), np.polymul(num_f, den_c))
    return np.polyadd(one, np.polymul(np.polymul(c_plus_f, num_p), den_g))


def _characteristic_fsp(spec, k):
    """``1 + C G - C G F_r z^-N + C F_r P z^-N = 0`` times ``D_c D_g D_f D_p z^N``: the
    filtered Smith predictor (``u = C (r - G u - F_r (y - G z^-N u))``, ``y = P z^-N u``);
    G the delay-free model by ZOH, ``F_r = (1 - beta) z / (z - beta)``."""
    tc = spec.control_period_s
    n = round(spec.nominal_dead_time_s / tc)
    num_p, den_p = _plant_zoh(spec, k)
    g = control.tf([spec.bandwidth_rad_s * spec.nominal_k2_N_min_per_mm_s],
                   np.polymul([1, spec.bandwidth_rad_s], [1, -spec.nominal_p2_rad_s]))
    if spec.fsp_sensor_cutoff_hz:
        g = g * control.tf([1.0], [1.0 / (2 * np.pi * spec.fsp_sensor_cutoff_hz), 1.0])
    num_g, den_g = _tf_polys(control.c2d(g, tc, "zoh"))
    beta = np.exp(-tc / spec.fsp_filter_time_constant_s)
    num_f, den_f = np.array([1.0 - beta, 0.0]), np.array([1.0, -beta])
    num_c, den_c = _pi_polys(spec)
    zn = _shift(n)
    mul = np.polymul
    terms = [
        mul(mul(mul(mul(den_c, den_g), den_f), den_p), zn),
        mul(mul(mul(num_c, num_g), den_f), mul(den_p, zn)),
        -mul(mul(mul(num_c, num_g), num_f), den_p),
        mul(mul(mul(num_c, num_f), num_p), den_g),
    ]
    out = np.zeros(max(len(t) for t in terms))
    for t in terms:
        out[len(out) - len(t):] += t
    return out


def _largest_k(characteristic, spec):
    def stable(k):
        return np.abs(np.roots(characteristic(spec, k))).max() < 1.0

    assert stable(1.0)
    k = 1.0
    while stable(k + 0.02) and k < 20:
        k += 0.02
    lo, hi = k, k + 0.02
    while hi - lo > 1e-5:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


@pytest.mark.parametrize(
    "kind, extra, depth, characteristic",
    [
        ("dob_pi", {"dob_q_numerator": [1.0, 3.0]}, None, _characteristic_dob),
        ("dob_pi", {"dob_q_numerator": [1.0, 2.0], "dob_q_order": 4,
                    "dob_sensor_cutoff_hz": 20.0}, 4.0, _characteristic_dob),
        ("fsp_pi", {}, None, _characteristic_fsp),
        ("fsp_pi", {"fsp_sensor_cutoff_hz": 20.0, "fsp_filter_time_constant_s": 0.1}, 2.0,
         _characteristic_fsp),
        ("fsp_adaptive_pi", {"fsp_sensor_cutoff_hz": 20.0}, 4.0, _characteristic_fsp),
    ],
)
def test_largest_gain_ratio_equals_the_characteristic_polynomial(kind, extra, depth,
                                                                 characteristic):
    sc = Scenario().with_values(
        {"controller.kind": kind, "sensor.lowpass_cutoff_hz": 20.0,
         **{f"controller.{k}": v for k, v in extra.items()}}
    )
    spec = loop_spec(sc, depth, kind)
    got = max_gain_ratio(spec, rtol=1e-4)
    want = _largest_k(characteristic, spec)
    assert 1.05 < want < 20.0  # a finite boundary above the plant itself
    assert got == pytest.approx(want, rel=1e-3)  # the brief asks 1 %; both bisect to 1e-4


@pytest.mark.parametrize(
    "kind, extra",
    [
        ("dob_pi", {"dob_q_numerator": [1.0, 2.0], "dob_q_order": 4,
                    "dob_sensor_cutoff_hz": 20.0}),
        ("fsp_pi", {"fsp_sensor_cutoff_hz": 20.0}),
    ],
)
def test_continuous_loop_gain_equals_the_closed_form(kind, extra):
    """The exact-delay loop gain ``acc analyze`` takes its margins from, against the closed
    form written here at the 4 mm row.  Both structures read the held command ``h u``
    (``h = e^{-s T_c / 2}``), as their sampled forms do:

    * observer: ``L = h (C + Q / (H_n P_n0)) H P / (1 - h Q e^{-L_n s})``;
    * predictor: ``L = h C F_r H P / (1 + h C G_m (1 - F_r e^{-L_n s}))``,
      ``F_r = 1 / (T_r s + 1)``, ``G_m = H_n P_n0``.
    """
    from acc.design import linear as lin

    sc = Scenario().with_values(
        {"controller.kind": kind, "sensor.lowpass_cutoff_hz": 20.0,
         **{f"controller.{k}": v for k, v in extra.items()}}
    )
    spec = loop_spec(sc, 4.0)
    w = np.array([0.5, 3.0, 8.0, 40.0])
    s = 1j * w
    hold = np.exp(-s * TC / 2)
    wc = 2 * np.pi * 20.0
    H = 1 / (1 + s / wc)
    P = A * 20.11 * np.exp(-0.1 * s) / ((s + A) * (s + 5.35))
    pn0 = A * K2 / ((s + A) * (s - P2))
    C = 120.0 * (spec.kp_per_N + spec.ki_per_N_s / s)
    delay_n = np.exp(-0.1 * s)
    if kind == "dob_pi":
        q = (1 + 2 * 0.1 * s) / (0.1 * s + 1) ** 4
        want = hold * (C + q / (H * pn0)) * H * P / (1 - hold * q * delay_n)
    else:
        fr = 1 / (spec.fsp_filter_time_constant_s * s + 1)
        want = hold * C * fr * H * P / (1 + hold * C * H * pn0 * (1 - fr * delay_n))
    got = lin.open_loop(spec, omega=w).frdata.ravel()
    np.testing.assert_allclose(got, want, rtol=1e-12)
