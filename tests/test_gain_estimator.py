"""Online estimation of K2 and p2: recovery from closed-loop data, no drift in air."""

import numpy as np
import pytest

from acc.scenario import Scenario
from controllers.gain_estimator import GainEstimatorParams, ProcessGainEstimator

TABLE1 = [(2.0, 10.05, -2.35), (3.0, 12.57, -3.75), (4.0, 20.11, -5.35)]
TC, N = 0.01, 10


def _closed_loop(k2, p2, periods, method="rls", air=False):
    """Estimator inside the simulator's loop, driven by a fixed PI, noise-free.

    The loop is the project's own simulator (plant step 1 ms, exact ZOH feed drive and
    force process); the estimator sees what the adaptive controllers see.
    """
    from acc.simulator import simulate

    depth = 0.0 if air else float([d for d, k, p in TABLE1 if k == k2][0])
    sc = Scenario().with_values(
        {
            "workpiece.segment_length_mm": [100.0],
            "workpiece.radial_depth_mm": [depth] if depth else [0.0, 3.0],
            "workpiece.axial_depth_mm": [10.0] if depth else [10.0, 10.0],
            "sensor.noise_std_N": 0.0,
            "sensor.lowpass_cutoff_hz": 0.0,
            "simulation.time_limit_s": periods * TC,
        }
        if not air
        else {
            "workpiece.segment_length_mm": [100.0, 10.0],
            "workpiece.radial_depth_mm": [0.0, 3.0],
            "workpiece.axial_depth_mm": [10.0, 10.0],
            "sensor.noise_std_N": 0.0,
            "sensor.lowpass_cutoff_hz": 0.0,
            "simulation.time_limit_s": periods * TC,
        }
    )
    res = simulate(sc, record_every_steps=10)
    f = res.signal("measured_force_N")[0]
    u = res.signal("commanded_feed_mm_min")[0]
    est = ProcessGainEstimator(
        GainEstimatorParams(method=method), 29.33, 12.57, -3.75, N, 500.0, 120.0, TC, 1
    )
    st = est.init()
    states = []
    for k in range(len(f)):
        st = est.update(st, f[k : k + 1])
        st = est.record_command(st, u[k : k + 1])
        states.append(st)
    return est, states


@pytest.mark.parametrize(("depth", "k2", "p2"), TABLE1)
def test_rls_recovers_table1_plants_within_1_5_s_of_cutting(depth, k2, p2):
    # Tolerance 3 %: a K2 error e moves the loop gain by e, i.e. the crossover by about e
    # and the phase margin by < 1 deg; the estimate starts at the 3 mm model (up to 60 %
    # off) and must get there from the start-of-cut transient alone (noise-free data: what
    # is left is the prior along weakly excited directions, measured 0.5-1.3 %).
    est, states = _closed_loop(k2, p2, 150)
    k2_hat, p2_hat = est.estimates(states[-1])
    assert k2_hat[0] == pytest.approx(k2, rel=0.03)
    assert p2_hat[0] == pytest.approx(p2, rel=0.03)


def test_kalman_variant_moves_towards_the_plant():
    # the random-walk Kalman filter is slower (no forgetting); it must at least halve the
    # initial error of the 4 mm plant's K2 (60 %) within the same 1.5 s
    est, states = _closed_loop(20.11, -5.35, 150, method="kalman")
    k2_hat, _ = est.estimates(states[-1])
    assert abs(k2_hat[0] / 20.11 - 1) < 0.5 * abs(12.57 / 20.11 - 1)


def test_no_drift_during_an_air_cut():
    # 100 mm of air at the clamped override: force 0, command held.  The in-cut guard must
    # keep the estimate and its covariance exactly where they started.
    est, states = _closed_loop(None, None, 200, air=True)
    for st in states:
        np.testing.assert_array_equal(st.theta, est.theta0)
        np.testing.assert_array_equal(st.covariance, est.P0)
        assert not st.updated.any()


def test_projection_keeps_the_estimate_in_range():
    est = ProcessGainEstimator(GainEstimatorParams(), 29.33, 12.57, -3.75, N, 500, 120, TC, 2)
    wild = np.array([[0.2, -1.0, -1.0], [0.99999, 5.0, 5.0]])
    out = est._project(wild, np.arange(2))
    st = est.init()._replace(theta=out)
    k2, p2 = est.estimates(st)
    g = k2 / -p2
    g_nom = 12.57 / 3.75
    assert np.all((-p2 >= 3.75 / 5 - 1e-9) & (-p2 <= 3.75 * 5 + 1e-9))
    assert np.all((g >= g_nom / 5 - 1e-9) & (g <= g_nom * 5 + 1e-9))


def test_update_does_not_mutate_its_input():
    est = ProcessGainEstimator(GainEstimatorParams(), 29.33, 12.57, -3.75, N, 500, 120, TC, 1)
    st = est.init()
    before = [np.copy(a) for a in st if isinstance(a, np.ndarray)]
    est.update(st, np.array([400.0]))
    est.record_command(st, np.array([100.0]))
    after = [a for a in st if isinstance(a, np.ndarray)]
    for b, a in zip(before, after, strict=True):
        np.testing.assert_array_equal(a, b)
