"""PID tuning of the XY table (spec A1-3, A1-4): the ultimate gain from the sampled loop's
eigenvalues against the simulated P-only loop, the ZN table, and Nelder-Mead lowering its
objective (recomputed here from a fresh simulation)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from acc.design.contour_tuning import (
    closed_loop_spectral_radius,
    tune_axis_pid,
    ultimate_gain,
    ziegler_nichols_pid,
)
from acc.engine.axis_simulate import simulate_axis
from controllers.axis.pid import AxisPIDParams
from plants.axis.elastic_axis import ElasticAxisParams

LINEAR = ElasticAxisParams(coulomb_friction_N=0.0, current_limit_A=0.0,
                           encoder_quantisation=False)


def _p_only_run(kp: float) -> np.ndarray:
    ref = np.full(4000, 0.01)  # a 10 um step, P-only, 0.1 ms plant step, 1 ms controller
    ref[0] = 0.0  # the axis starts at the first sample
    r = simulate_axis(LINEAR, AxisPIDParams(p_gain_per_mm=kp), reference_samples_mm=ref,
                      duration_s=0.4, plant_step_s=1e-4, control_period_s=1e-3, threads=1)
    return r.signal("x_meas_mm")[0] - 0.01


def test_ultimate_gain_bounds_the_simulated_p_loop():
    ku, tu = ultimate_gain(LINEAR, 1e-3)
    below = _p_only_run(0.9 * ku)
    above = _p_only_run(1.1 * ku)
    early, late = slice(500, 1500), slice(3000, 4000)
    assert np.max(np.abs(below[late])) < 0.5 * np.max(np.abs(below[early]))  # decays
    assert np.max(np.abs(above[late])) > 2.0 * np.max(np.abs(above[early]))  # grows
    # the oscillation period at the limit: zero crossings of the growing run
    s = np.sign(above[2000:])
    crossings = np.flatnonzero(s[1:] != s[:-1])
    period = 2 * np.mean(np.diff(crossings)) * 1e-4
    assert period == pytest.approx(tu, rel=0.1)


@pytest.mark.parametrize("kd", [0.03, 0.05, 0.07])
def test_pid_loop_spectral_radius_equals_simulated_growth(kd):
    """The slowest mode of the simulated linear PID loop grows or decays by rho^N over N
    control periods (N = 400, from 0.5-0.6 s to 0.9-1.0 s)."""
    ref = np.full(10000, 0.01)
    ref[0] = 0.0
    r = simulate_axis(LINEAR, AxisPIDParams(p_gain_per_mm=2.0, i_gain_per_mm_s=20.0,
                                            d_gain_s_per_mm=kd),
                      reference_samples_mm=ref, duration_s=1.0, plant_step_s=1e-4,
                      control_period_s=1e-3, threads=1)
    e = r.signal("x_meas_mm")[0] - 0.01
    ratio = np.max(np.abs(e[9000:])) / np.max(np.abs(e[5000:6000]))
    rho = closed_loop_spectral_radius(LINEAR, 2.0, 20.0, kd, 1e-3)
    if rho > 1:  # one growing mode dominates
        assert ratio == pytest.approx(rho**400, rel=0.02)
    else:  # decaying; several modes of similar rate
        assert ratio < 1 and ratio == pytest.approx(rho**400, rel=0.1)


def test_ziegler_nichols_table():
    ku, tu = ultimate_gain(LINEAR, 1e-3)
    kp, ki, kd = ziegler_nichols_pid(LINEAR, 1e-3, td_scale=2.0)
    assert kp == pytest.approx(0.6 * ku, rel=1e-12)
    assert ki == pytest.approx(kp / (tu / 2), rel=1e-12)
    assert kd == pytest.approx(kp * 2.0 * tu / 8, rel=1e-12)


def test_nelder_mead_lowers_the_sinusoid_iae():
    axis = ElasticAxisParams()
    f = 166.67 / (2 * math.pi * 20.0)
    res = tune_axis_pid(axis, 20.0, f, periods=0.5, max_evaluations=25)
    assert res.cost < 0.9 * res.start_cost
    n = round(round(0.5 / f / 1e-3) * 1e-3 / 1e-4)
    ref = 20.0 * np.sin(2 * math.pi * f * np.arange(n) * 1e-4)
    r = simulate_axis(axis, AxisPIDParams(p_gain_per_mm=res.kp, i_gain_per_mm_s=res.ki,
                                          d_gain_s_per_mm=res.kd),
                      reference_samples_mm=ref, duration_s=n * 1e-4, plant_step_s=1e-4,
                      control_period_s=1e-3)
    iae = np.sum(np.abs(r.signal("following_error_mm")[0])) * 1e-4
    excess = max(0.0, np.max(np.abs(r.signal("command_V")[0])) - 10.0)
    assert res.cost == pytest.approx(iae + excess, rel=1e-9)
