"""Feed drive, Eq. (6): exact ZOH lag and a delay line of whole plant steps."""

import math

import numpy as np
import pytest

from plants.feed_drive import (
    DeadTimeError,
    FeedDrive,
    FeedDriveParams,
    dead_time_steps,
    step_response,
    time_to_63_percent_s,
)

DT = 0.001


def run_step(drive: FeedDrive, n: int, amplitude: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    state = drive.init()
    v = np.empty((drive.runs, n))
    travel = np.empty((drive.runs, n))
    u = np.full(drive.runs, amplitude)
    for k in range(n):
        state, out = drive.step(state, u)
        v[:, k] = out.velocity_mm_min
        travel[:, k] = out.travel_mm
    return v, travel


def test_step_response_equals_closed_form_and_is_zero_until_dead_time():
    p = FeedDriveParams()
    n_delay = dead_time_steps(p.dead_time_s, DT)
    assert n_delay == 100
    drive = FeedDrive(p.bandwidth_rad_s, n_delay, DT, runs=1)
    v, _ = run_step(drive, 600)
    t = np.arange(600) * DT
    # exactly zero up to and including t = L
    assert np.all(v[0, : n_delay + 1] == 0.0)
    assert v[0, n_delay + 1] > 0.0
    # ZOH of a step is exact: samples equal the continuous response (rounding only)
    np.testing.assert_allclose(v[0], step_response(p, t), rtol=0, atol=1e-12)


def test_63_percent_at_dead_time_plus_time_constant():
    p = FeedDriveParams()
    drive = FeedDrive(p.bandwidth_rad_s, 100, DT, runs=1)
    v, _ = run_step(drive, 400)
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
    with_delay = FeedDrive(a, 100, DT, runs=1)
    without = FeedDrive(a, 0, DT, runs=1)
    rng = np.random.default_rng(1)
    u = rng.uniform(50, 200, size=500)
    s1, s0 = with_delay.init(), without.init()
    v1, v0 = [], []
    for x in u:
        s1, o1 = with_delay.step(s1, np.array([x]))
        s0, o0 = without.step(s0, np.array([x]))
        v1.append(o1.velocity_mm_min[0])
        v0.append(o0.velocity_mm_min[0])
    v1, v0 = np.array(v1), np.array(v0)
    assert np.array_equal(v1[100:], v0[:-100])  # bit-exact shift
    assert np.all(v1[:101] == 0.0)


def test_travel_is_the_exact_integral_of_velocity():
    p = FeedDriveParams()
    drive = FeedDrive(p.bandwidth_rad_s, 100, DT, runs=1)
    _, travel = run_step(drive, 1000, amplitude=120.0)
    t_end = 1.0
    tau = t_end - p.dead_time_s
    a = p.bandwidth_rad_s
    closed_form_mm = 120.0 / 60.0 * (tau + math.expm1(-a * tau) / a)
    assert travel.sum() == pytest.approx(closed_form_mm, rel=1e-12)


def test_batch_with_different_delays_equals_single_runs():
    bandwidth = np.array([29.33, 20.0, 40.0])
    delays = np.array([100, 0, 37])
    batch = FeedDrive(bandwidth, delays, DT, runs=3)
    vb, tb = run_step(batch, 300, amplitude=100.0)
    for i in range(3):
        single = FeedDrive(bandwidth[i], delays[i], DT, runs=1)
        vs, ts = run_step(single, 300, amplitude=100.0)
        assert np.array_equal(vb[i], vs[0])
        assert np.array_equal(tb[i], ts[0])


def test_step_does_not_modify_its_input_state():
    drive = FeedDrive(29.33, 5, DT, runs=2)
    state = drive.init(10.0)
    before = (state.velocity_mm_min.copy(), state.history_mm_min.copy(), state.head)
    drive.step(state, np.array([1.0, 2.0]))
    assert np.array_equal(state.velocity_mm_min, before[0])
    assert np.array_equal(state.history_mm_min, before[1])
    assert state.head == before[2]


def test_dead_time_not_whole_steps_is_an_error_or_rounded_with_the_amount():
    assert dead_time_steps(0.1, 0.001) == 100
    assert dead_time_steps(0.1, 0.002) == 50
    with pytest.raises(DeadTimeError, match="not a whole number of plant steps"):
        dead_time_steps(0.1005, 0.001)
    with pytest.warns(UserWarning, match=r"rounded to 101 steps .* change of \+0.0004 s"):
        assert dead_time_steps(0.1006, 0.001, policy="round") == 101
    with pytest.raises(DeadTimeError):
        dead_time_steps(-0.1, 0.001)
