"""Feedrate-override PI: design rule, difference equation, clamping anti-windup."""

import math

import control
import numpy as np
import pytest

from acc.engine.element import step_runs
from controllers.pi import pi_records
from controllers.pi_design import design_pi
from plants.nominal_plant import NominalPlant


@pytest.mark.parametrize("pm", [45.0, 60.0, 70.0])
def test_design_gives_the_phase_margin_with_the_exact_delay(pm):
    """Independent check with python-control: margins of the delay-free loop, then the
    exact delay's phase lag at that crossover (the delay does not change the gain)."""
    plant = NominalPlant()
    tc, feed = 0.01, 120.0
    g = design_pi(plant, feed, tc, pm)
    pi = control.tf([g.kp_per_N * feed, g.ki_per_N_s * feed], [1, 0])
    loop = pi * plant.rational_part()
    _, pm_free, _, wc = control.margin(loop)
    assert wc == pytest.approx(g.crossover_rad_s, rel=1e-6)
    theta = plant.dead_time_s + tc / 2
    assert pm_free - math.degrees(wc * theta) == pytest.approx(pm, abs=1e-4)
    # the PI zero cancels the nominal pole
    assert g.ki_per_N_s / g.kp_per_N == pytest.approx(3.75)


DIAG = np.full(7, np.nan)


def test_difference_equation_and_clamping():
    p, s = pi_records(500.0, 0.002, 0.01, 0.1, 2.0, 1.0, 0.01)
    u = step_runs(p, s, [400.0], shared=(DIAG,))  # e = 100: 0.2 + 1.0
    assert u[0] == pytest.approx(1.2)
    integral = s["integral"][0]
    assert integral == pytest.approx(1.0 + 0.01 * 0.01 * 100)
    # far below the reference: output clamps at 2.0 and the integrator is held
    u2 = step_runs(p, s, [-1000.0], shared=(DIAG,))
    assert u2[0] == 2.0 and s["integral"][0] == integral
    # ... but integrates when the error would pull the output back inside
    s["integral"] = 2.5
    u3 = step_runs(p, s, [600.0], shared=(DIAG,))
    assert u3[0] == 2.0 and s["integral"][0] == pytest.approx(2.5 - 0.01 * 0.01 * 100)


def test_no_anti_windup_keeps_integrating():
    p, s = pi_records(500.0, 0.002, 0.01, 0.1, 2.0, 1.0, 0.01, anti_windup="none")
    for _ in range(100):
        u = step_runs(p, s, [0.0], shared=(DIAG,))
    assert u[0] == 2.0
    assert s["integral"][0] == pytest.approx(1.0 + 100 * 0.01 * 0.01 * 500)
