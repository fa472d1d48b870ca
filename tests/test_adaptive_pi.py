"""Adaptive PI: the rescaled gains restore the designed crossover and phase margin."""

import pytest

from acc.design.analysis import loop_spec, margins
from acc.scenarios.force import Scenario


@pytest.mark.parametrize("depth", [2.0, 3.0, 4.0])
@pytest.mark.parametrize("multiplier", [0.5, 1.0, 3.0])
def test_converged_adaptive_gains_give_the_design_margins(depth, multiplier):
    sc = Scenario().with_values(
        {"force_process.gain_multiplier": multiplier, "sensor.lowpass_cutoff_hz": 0.0}
    )
    design = margins(loop_spec(sc, None, "pi"))  # the nominal loop: PM 60 deg by design_pi
    assert design.phase_margin_deg == pytest.approx(60.0, abs=1e-6)
    m = margins(loop_spec(sc, depth, "adaptive_pi"))  # a converged estimate
    # same loop after the zero cancels the true pole and the gain is rescaled: exact up to
    # the FRD grid interpolation of python-control's margin search (1e-3 relative)
    assert m.phase_margin_deg == pytest.approx(60.0, abs=0.05)
    assert m.crossover_rad_s == pytest.approx(design.crossover_rad_s, rel=1e-3)


def _designed_kp(k2: float, a: float = 29.33, theta_s: float = 0.105, feed: float = 120.0,
                 phase_margin_deg: float = 60.0) -> float:
    """The PI with its zero on the pole: L = F kp a K2 e^{-theta s}/(s (s + a)); crossover
    from pi/2 - atan(w/a) - theta w = PM, gain from |L(j w_c)| = 1 (written here)."""
    import math

    from scipy.optimize import brentq

    pm = math.radians(phase_margin_deg)
    wc = brentq(lambda w: math.pi / 2 - math.atan(w / a) - theta_s * w - pm, 1e-6, 100.0)
    return wc * math.hypot(wc, a) / (feed * a * k2)


@pytest.mark.parametrize("k2_hat", [6.0, 12.57, 25.0])
@pytest.mark.parametrize("p2_hat", [-1.5, -3.75, -8.0])
def test_adaptive_gains_put_the_zero_on_the_estimated_pole_at_the_designed_crossover(
    k2_hat, p2_hat
):
    from controllers.adaptive_pi import adaptive_pi_gains

    k2n, p2n = 12.57, -3.75
    kp_n = _designed_kp(k2n)
    kp, ki = adaptive_pi_gains(kp_n, kp_n * -p2n, k2n, p2n, k2_hat, p2_hat)
    # the zero ki/kp follows the estimated pole, and the gain gives |L(j w_c)| = 1 for K2_hat
    assert ki / kp == pytest.approx(-p2_hat, rel=1e-12)
    assert kp == pytest.approx(_designed_kp(k2_hat), rel=1e-12)


def test_the_shipped_design_is_the_one_written_here():
    from acc.engine.simulate import simulate

    res = simulate(Scenario().with_values({"simulation.time_limit_s": 0.1}))
    row = res.summary_rows()[0]
    assert float(row["kp_per_N"]) == pytest.approx(_designed_kp(12.57), rel=1e-9)
    assert float(row["ki_per_N_s"]) == pytest.approx(3.75 * _designed_kp(12.57), rel=1e-9)
