"""Lacerda & Belo's cross-coupled contour-error controller (spec A1-2, §5.8): the
decomposition is normal to the tangent, the correction reduces the contour error to first
order (finite differences), the models against the pure-lag closed forms, and the loop
properties A1-2 names (zero contribution for matched linear axes on a line, a contour
disturbance reduced)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from acc.engine.element import step_runs
from acc.engine.xy_simulate import XYReference, simulate_xy
from controllers.axis.pid import AxisPIDParams
from controllers.contouring.cross_coupled import CrossCoupledParams, cec_records, decompose_at
from controllers.contouring.interpolator import PathParams, interpolate
from plants.axis.elastic_axis import ElasticAxisParams

PERIOD = 1e-3
LINEAR = dict(coulomb_friction_N=0.0, current_limit_A=0.0, encoder_quantisation=False)


def _cec(model: str, angle: str = "chord", kp: float = 2.0,
         decomposition: str = "normal_at_reference") -> tuple:
    return cec_records(CrossCoupledParams(model=model, curvature_angle=angle, kp_V_per_mm=kp,
                                          decomposition=decomposition), PERIOD)


def _eps_and_u(model: str, P: np.ndarray, R: np.ndarray, alpha: float, C: np.ndarray,
               r: float, angle: str = "chord", kp: float = 2.0,
               decomposition: str = "normal_at_reference") -> tuple[float, np.ndarray]:
    """One CEC period for tool P (fresh state): eps (Lacerda's sign) and (U_x, U_y)."""
    p, s = _cec(model, angle, kp, decomposition)
    E = R - P
    ux, uy, eps = step_runs(p, s, E[0], E[1], alpha, R[0], R[1], C[0], C[1], r)
    return float(eps[0]), np.array([ux[0], uy[0]])


@pytest.mark.parametrize("alpha", np.linspace(-math.pi, math.pi, 13))
def test_decomposition_is_normal_to_the_tangent(alpha):
    ux, uy = decompose_at(3.0, alpha)
    assert ux * math.cos(alpha) + uy * math.sin(alpha) == pytest.approx(0.0, abs=1e-15)
    assert math.hypot(ux, uy) == pytest.approx(3.0, rel=1e-15)
    # along n = (sin a, -cos a): the side on which Eq. (11) is positive is the other one
    assert ux * math.sin(alpha) - uy * math.cos(alpha) == pytest.approx(3.0, rel=1e-15)


def _exact_line(P: np.ndarray, R: np.ndarray, alpha: float) -> float:
    """Signed distance of P to the line through R along alpha, + to the left (Lacerda)."""
    return (R - P) @ np.array([math.sin(alpha), -math.cos(alpha)])


def _exact_circle(P: np.ndarray, C: np.ndarray, r: float) -> float:
    """Counter-clockwise circle, Lacerda's sign: + to the left = inside."""
    return r - float(np.hypot(*(P - C)))


@pytest.mark.parametrize("model", ["linear", "curvature", "exact"])
def test_correction_reduces_contour_error_to_first_order_on_a_line(model):
    alpha = math.radians(35.0)
    R = np.array([3.0, 2.0])
    t = np.array([math.cos(alpha), math.sin(alpha)])
    n_left = np.array([-math.sin(alpha), math.cos(alpha)])
    for offset in (0.05, -0.02):
        P = R - 0.3 * t + offset * n_left  # lagging, off the line to the left or right
        eps, U = _eps_and_u(model, P, R, alpha, np.array([np.nan, np.nan]), math.inf)
        assert eps == pytest.approx(offset, abs=1e-12)
        h = 1e-4
        d = (_exact_line(P + h * U, R, alpha) - _exact_line(P - h * U, R, alpha)) / (2 * h)
        assert d == pytest.approx(-2.0 * eps, rel=1e-9)  # d eps / dh = -u_c = -kp eps
        assert abs(_exact_line(P + h * U, R, alpha)) < abs(eps)


@pytest.mark.parametrize("model", ["linear", "curvature", "exact"])
def test_correction_reduces_contour_error_to_first_order_on_a_circle(model):
    r, C = 10.0, np.array([0.0, 0.0])
    th = math.radians(40.0)
    R = C + r * np.array([math.cos(th), math.sin(th)])
    alpha = th + math.pi / 2  # counter-clockwise
    lag = 0.01  # rad
    for radial in (0.03, -0.03):
        P = C + (r + radial) * np.array([math.cos(th - lag), math.sin(th - lag)])
        eps, U = _eps_and_u(model, P, R, alpha, C, r)
        exact = _exact_circle(P, C, r)
        assert exact == pytest.approx(-radial, abs=1e-12)
        h = 1e-5
        d = (_exact_circle(P + h * U, C, r) - _exact_circle(P - h * U, C, r)) / (2 * h)
        # gradient of the exact error along U = -u_c cos(beta), beta the angle between the
        # normal at R and the radius through P (= the lag here)
        assert d == pytest.approx(-2.0 * eps * math.cos(lag), rel=1e-6)
        assert np.sign(d) == -np.sign(exact)  # the correction reduces |eps|
        assert abs(_exact_circle(P + h * U, C, r)) < abs(exact)


@pytest.mark.parametrize("angle", ["chord", "tangent_lag"])
@pytest.mark.parametrize("direction", [1.0, -1.0])
@pytest.mark.parametrize("phi", [0.08, -0.05])
def test_towards_nearest_follows_the_normal_at_the_nearest_point(angle, direction, phi):
    """The rotated decomposition points along the normal at S (arc angle gamma back from
    R): the gradient of the exact error along it is -u_c cos(gamma - phi), phi the tool's
    true lag (< 0: the tool leads), against -u_c cos(phi) along the normal at R.  Both
    directions of travel."""
    r, C = 10.0, np.array([0.0, 0.0])
    th, d = math.radians(40.0), 0.03
    R = C + r * np.array([math.cos(th), math.sin(th)])
    alpha = th + direction * math.pi / 2
    lagged = th - direction * phi
    P = C + (r + d) * np.array([math.cos(lagged), math.sin(lagged)])
    E = R - P
    if angle == "tangent_lag":
        gamma = math.asin((r + d) * math.sin(phi) / r)  # E.t / r
    else:
        gamma = math.copysign(float(np.hypot(*E)) / r, phi)
    h = 1e-6
    for decomposition, cos_beta in (("towards_nearest", math.cos(gamma - phi)),
                                    ("normal_at_reference", math.cos(phi))):
        eps, U = _eps_and_u("exact", P, R, alpha, C, r, angle, decomposition=decomposition)
        def exact(Q: np.ndarray) -> float:  # Lacerda's sign on either direction
            return direction * _exact_circle(Q, C, r)
        dd = (exact(P + h * U) - exact(P - h * U)) / (2 * h)
        assert dd == pytest.approx(-2.0 * eps * cos_beta, rel=1e-6), decomposition


def test_towards_nearest_on_a_line_is_the_normal():
    alpha, R, P = 0.7, np.array([1.0, 2.0]), np.array([0.5, 2.3])
    nan = np.array([np.nan, np.nan])
    _, u_near = _eps_and_u("linear", P, R, alpha, nan, math.inf, decomposition="towards_nearest")
    _, u_ref = _eps_and_u("linear", P, R, alpha, nan, math.inf)
    np.testing.assert_array_equal(u_near, u_ref)


def test_models_on_a_pure_lag_closed_forms():
    """Tool on the circle lagging by phi: exact 0; Eq. (11) r (1 - cos phi); Eq. (16) chord
    r (cos(2 sin(phi/2)) - cos phi); tangent-lag reading 0 (spec M1-4)."""
    r, C = 20.0, np.array([1.0, -2.0])
    th = 1.1
    R = C + r * np.array([math.cos(th), math.sin(th)])
    alpha = th + math.pi / 2
    for phi in (0.01, 0.1, 0.3):
        P = C + r * np.array([math.cos(th - phi), math.sin(th - phi)])
        e11, _ = _eps_and_u("linear", P, R, alpha, C, r)
        e16, _ = _eps_and_u("curvature", P, R, alpha, C, r)
        e16t, _ = _eps_and_u("curvature", P, R, alpha, C, r, angle="tangent_lag")
        ex, _ = _eps_and_u("exact", P, R, alpha, C, r)
        assert e11 == pytest.approx(r * (1 - math.cos(phi)), rel=1e-9)
        assert e16 == pytest.approx(r * (math.cos(2 * math.sin(phi / 2)) - math.cos(phi)),
                                    rel=1e-6, abs=1e-13)
        assert abs(e16t) < 1e-12 * r
        assert abs(ex) < 1e-12 * r
        assert abs(e16) < abs(e11) * phi**2  # the 12/phi^2 improvement, order of magnitude


def _line(angle_deg: float, dt: float) -> XYReference:
    return XYReference.from_path(interpolate(PathParams(kind="line", feed_mm_s=100.0,
                                                        line_angle_deg=angle_deg,
                                                        duration_s=0.2), dt))


def test_matched_linear_axes_on_a_line_cec_contributes_nothing():
    dt = 1e-4
    a = ElasticAxisParams(**LINEAR)
    pid = AxisPIDParams(p_gain_per_mm=5.0, i_gain_per_mm_s=10.0, d_gain_s_per_mm=0.01,
                        max_output=10.0)
    ref = _line(30.0, dt)
    cec = CrossCoupledParams(model="curvature", kp_V_per_mm=3.0, ki_V_per_mm_s=10.0)
    on = simulate_xy(a, a, pid, pid, ref, cec=cec, plant_step_s=dt, control_period_s=PERIOD)
    off = simulate_xy(a, a, pid, pid, ref, plant_step_s=dt, control_period_s=PERIOD)
    following = np.max(np.hypot(ref.x_mm - on.signal("x_mm")[0], ref.y_mm - on.signal("y_mm")[0]))
    assert following > 0.05  # the axes lag the reference...
    assert np.max(np.abs(on.signal("cec_error_mm")[0])) < 1e-12 * following  # ...on the line
    np.testing.assert_allclose(on.signal("x_mm")[0], off.signal("x_mm")[0], atol=1e-12)


def test_contour_disturbance_reduced():
    """A force across an x-direction line (on y only): the CEC lowers the contour error."""
    dt = 1e-4
    a = ElasticAxisParams(**LINEAR)
    pid = AxisPIDParams(p_gain_per_mm=3.0, i_gain_per_mm_s=10.0, d_gain_s_per_mm=0.005,
                        max_output=10.0)
    ref = _line(0.0, dt)
    load = np.where(np.arange(ref.samples) * dt >= 0.05, 100.0, 0.0)
    kw = dict(load_y_N=load, plant_step_s=dt, control_period_s=PERIOD)
    off = simulate_xy(a, a, pid, pid, ref, **kw)
    cec = CrossCoupledParams(model="linear", kp_V_per_mm=2.0, ki_V_per_mm_s=50.0)
    on = simulate_xy(a, a, pid, pid, ref, cec=cec, **kw)
    m_on, m_off = on.metrics, off.metrics
    assert m_off["max_abs_contour_error_mm"][0] > 0.01  # the disturbance is felt
    assert m_on["max_abs_contour_error_mm"][0] < 0.8 * m_off["max_abs_contour_error_mm"][0]
    assert m_on["iae_contour_mm_s"][0] < 0.5 * m_off["iae_contour_mm_s"][0]


def test_bad_option_names_the_key():
    with pytest.raises(ValueError, match="model"):
        CrossCoupledParams(model="quadratic")
    with pytest.raises(ValueError, match="max_output_V"):
        CrossCoupledParams(max_output_V=-1.0)
