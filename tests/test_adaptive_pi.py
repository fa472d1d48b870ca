"""Adaptive PI: the rescaled gains restore the designed crossover and phase margin."""

import pytest

from acc.design.analysis import loop_spec, margins
from acc.scenario import Scenario


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
