"""Q filter of Eq. (11): closed forms of the binomial low-pass."""

import math

import control
import numpy as np
import pytest

from controllers.q_filter import q_cutoff_rad_s, q_filter, q_frequency_response


@pytest.mark.parametrize("tau", [0.02, 0.1, 0.5])
def test_dc_gain_is_one(tau):
    # closed form Q(0) = 1; python-control's dcgain is exact for this rational tf
    assert control.dcgain(q_filter(tau)) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("tau", [0.02, 0.1, 0.5])
def test_minus_3db_at_closed_form_frequency(tau):
    # (1 + (w tau)^2)^3 = 2  =>  w tau = sqrt(2^(1/3) - 1) = 0.5098 (4 digits quoted)
    w = q_cutoff_rad_s(tau)
    assert w * tau == pytest.approx(0.5098, abs=5e-5)
    mag = abs(q_frequency_response(w, tau))
    assert 20 * math.log10(mag) == pytest.approx(-10 * math.log10(2), abs=1e-12)
    # python-control's own frequency response of the tf agrees (independent evaluation)
    resp = control.frequency_response(q_filter(tau), [w])
    assert abs(resp.magnitude.ravel()[0]) == pytest.approx(mag, rel=1e-10)


def test_bad_tau_is_a_clear_error():
    with pytest.raises(ValueError, match="tau_s"):
        q_filter(0.0)


def test_response_shape_follows_input():
    assert q_frequency_response(np.ones((2, 3)), 0.1).shape == (2, 3)
