"""Feed drive (Eq. 6): exact ZOH step response, exact delay, exact travel, dead-time policy."""

import math

import numpy as np
import pytest

from acc.engine.element import step_runs
from plants.feed_drive import (
    DeadTimeError,
    FeedDriveParams,
    dead_time_steps,
    feed_drive_records,
    step_response,
    time_to_63_percent_s,
)

DT = 0.001


def run_step(records, n: int, amplitude: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Velocity at the start of each step and travel over it, shape (runs, n)."""
    params, state = records
    runs = params.shape[0]
    v = np.empty((runs, n))
    travel = np.empty((runs, n))
    for k in range(n):
        v[:, k], _, travel[:, k] = step_runs(params, state, np.full(runs, amplitude))
    return v, travel


def test_step_response_equals_closed_form_and_is_zero_until_dead_time():
    p = FeedDriveParams()
    n_delay = dead_time_steps(p.dead_time_s, DT)
    assert n_delay == 100
    v, _ = run_step(feed_drive_records(p.bandwidth_rad_s, n_delay, DT), 600)
    t = np.arange(600) * DT
    # exactly zero up to and including t = L
    assert np.all(v[0, : n_delay + 1] == 0.0)
    assert v[0, n_delay + 1] > 0.0
    # ZOH of a step is exact: samples equal the continuous response (rounding only)
    np.testing.assert_allclose(v[0], step_response(p, t), rtol=0, atol=1e-12)


def test_63_percent_at_dead_time_plus_time_constant():
    p = FeedDriveParams()
    v, _ = run_step(feed_drive_records(p.bandwidth_rad_s, 100, DT), 400)
    target = 1.0 - math.exp(-1.0)  # 0.632
    first = int(np.argmax(v[0] >= target))
    # L + 1/a = 0.134095 s: the first sample at or above 63.2 % is the next whole step
    assert first == math.ceil(time_to_63_percent_s(p) / DT)
    # interpolating log(1 - v) (linear in t for a first-order lag) gives the time exactly
    y0, y1 = np.log1p(-v[0, first - 1]), np.log1p(-v[0, first])
    t_cross = (first - 1 + (-1.0 - y0) / (y1 - y0)) * DT
    assert t_cross == pytest.approx(0.1 + 1 / 29.33, abs=1e-9)


def test_delay_shifts_the_undelayed_response_by_exactly_n_samples():
    a = 29.33
    with_delay = feed_drive_records(a, 100, DT)
    without = feed_drive_records(a, 0, DT)
    rng = np.random.default_rng(1)
    u = rng.uniform(50, 200, size=500)
    v1 = np.array([step_runs(*with_delay, [x])[0][0] for x in u])
    v0 = np.array([step_runs(*without, [x])[0][0] for x in u])
    assert np.array_equal(v1[100:], v0[:-100])  # bit-exact shift
    assert np.all(v1[:101] == 0.0)


def test_delays_beyond_the_ring_capacity_boundary_are_exact():
    # a ring of 128 slots holds delays up to 127 steps, 128 needs the next size: both exact
    rng = np.random.default_rng(2)
    u = rng.uniform(50, 200, size=400)
    ref = feed_drive_records(29.33, 0, DT)
    v0 = np.array([step_runs(*ref, [x])[0][0] for x in u])
    for n in (127, 128):
        rec = feed_drive_records(29.33, n, DT)
        v = np.array([step_runs(*rec, [x])[0][0] for x in u])
        assert np.array_equal(v[n:], v0[:-n])


def test_travel_is_the_exact_integral_of_velocity():
    p = FeedDriveParams()
    _, travel = run_step(feed_drive_records(p.bandwidth_rad_s, 100, DT), 1000, amplitude=120.0)
    t_end = 1.0
    tau = t_end - p.dead_time_s
    a = p.bandwidth_rad_s
    closed_form_mm = 120.0 / 60.0 * (tau + math.expm1(-a * tau) / a)
    assert travel.sum() == pytest.approx(closed_form_mm, rel=1e-12)


def test_batch_with_different_delays_equals_single_runs():
    bandwidth = np.array([29.33, 20.0, 40.0])
    delays = np.array([100, 0, 37])
    vb, tb = run_step(feed_drive_records(bandwidth, delays, DT), 300, amplitude=100.0)
    for i in range(3):
        vs, ts = run_step(feed_drive_records(bandwidth[i], delays[i], DT), 300, amplitude=100.0)
        assert np.array_equal(vb[i], vs[0])
        assert np.array_equal(tb[i], ts[0])


def test_initial_velocity_is_held_for_all_of_the_past():
    v, _ = run_step(feed_drive_records(29.33, 5, DT, initial_velocity_mm_min=10.0), 20, 10.0)
    np.testing.assert_array_equal(v, 10.0)


def test_dead_time_not_whole_steps_is_an_error_or_rounded_with_the_amount():
    assert dead_time_steps(0.1, 0.001) == 100
    assert dead_time_steps(0.1, 0.002) == 50
    with pytest.raises(DeadTimeError, match="not a whole number of plant steps"):
        dead_time_steps(0.1005, 0.001)
    with pytest.warns(UserWarning, match=r"rounded to 101 steps .* change of \+0.0004 s"):
        assert dead_time_steps(0.1006, 0.001, policy="round") == 101
    with pytest.raises(DeadTimeError):
        dead_time_steps(-0.1, 0.001)
    with pytest.raises(DeadTimeError):
        feed_drive_records(29.33, 1.5, DT)
