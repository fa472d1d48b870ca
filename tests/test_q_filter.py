"""Q filter of Eq. (11): closed forms of the binomial low-pass; the designable numerator
against python-control's transfer function built from its definition."""

import math

import control
import numpy as np
import pytest

from controllers.q_filter import (
    q_cutoff_rad_s,
    q_filter,
    q_filter_denominator,
    q_frequency_response,
    q_polynomials,
    q_relative_degree,
)
from controllers.registry import ControllerParams


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


# --- designable numerator ("higher-order" observer) ------------------------------------------
NUMERATORS = [((1.0,), 3), ((1.0, 3.0), 3), ((1.0, 4.0, 6.0), 4), ((1.0, -0.5, 0.0), 4)]


@pytest.mark.parametrize("numerator, order", NUMERATORS)
def test_numerator_q_equals_python_controls_tf_built_from_the_definition(numerator, order):
    """Q(s) = sum a_i (tau s)^i / (tau s + 1)^n assembled here with python-control's
    ``s`` arithmetic; its frequency response, DC gain and relative degree."""
    tau = 0.07
    s = control.tf("s")
    ref = sum(a * (tau * s) ** i for i, a in enumerate(numerator)) / (tau * s + 1) ** order
    num, den = q_polynomials(tau, numerator, order)
    w = np.logspace(-2, 3, 200)
    got = np.polyval(num, 1j * w) / np.polyval(den, 1j * w)
    want = control.frequency_response(ref, w).complex.ravel()
    np.testing.assert_allclose(got, want, rtol=1e-10, atol=0)
    assert control.dcgain(control.tf(num, den)) == pytest.approx(1.0, abs=1e-12)
    degree = max(i for i, a in enumerate(numerator) if a != 0)
    assert len(den) - len(num) == order - degree == q_relative_degree(numerator, order)


def test_default_numerator_is_eq_11():
    num, den = q_polynomials(0.1)
    np.testing.assert_array_equal(num, [1.0])
    np.testing.assert_array_equal(den, q_filter_denominator(0.1))


@pytest.mark.parametrize(
    "values, match",
    [
        ({"dob_q_numerator": (1.0, 1.0, 1.0)}, "relative degree .* is 1, must be >= 2"),
        ({"dob_q_numerator": (2.0,)}, r"dob_q_numerator\[0\] must be 1"),
        ({"dob_q_numerator": (1.0, 3.0), "dob_sensor_cutoff_hz": 20.0}, "must be >= 3"),
        ({"dob_q_order": 1}, "dob_q_order must be a whole number >= 2"),
        ({"dob_sensor_cutoff_hz": -1.0}, "dob_sensor_cutoff_hz must be >= 0"),
    ],
)
def test_bad_numerator_is_a_one_line_error_naming_the_key(values, match):
    with pytest.raises(ValueError, match=match) as err:
        ControllerParams.from_values({"kind": "dob_pi", **values})
    assert "\n" not in str(err.value)
