"""Lacerda & Belo's cross-coupled contour-error controller (CEC), spec A1-2.

Per control period (seed 001, Fig. 3, L172-L210; the source's block diagram is an image)::

    eps   = Eq. (11) | Eq. (16) | exact, from the axis errors E = R - P_meas
    u_c   = PID_c(eps)                           (its own gains, limits and anti-windup)
    U_x   = +sin(alpha) u_c,   U_y = -cos(alpha) u_c     (blocks U_x, U_y of Fig. 3)

and the axis commands are ``u_x = PID_x(E_x) + U_x``, ``u_y = PID_y(E_y) + U_y``, each
limited to +-10 V (:mod:`acc.engine.xy_loop`).

Sign.  The controller works on the contour error in **Lacerda's sign**, ``eps = E.n`` with
``n = (sin alpha, -cos alpha)``, positive with the tool to the left of the motion: Eq. (11)
as printed.  The estimators come from :mod:`controllers.contouring.contour_error`, which
returns everything in Peng's sign (positive to the right, ``e = -eps``); this module only
negates them.  The correction ``u_c n`` drives the tool along ``n`` when ``eps > 0`` and the
contour error ``eps = (R - P).n`` falls: to first order, a displacement ``h U`` changes it by
``-h u_c`` on a straight path and by ``-h u_c cos(beta)`` on a curve, ``beta`` the angle
between ``n`` and the true normal (tested by finite differences).

``model``
    ``"linear"``: Eq. (11); ``"curvature"``: Eq. (16) [RECON] with the chord (paper) or the
    tangent-lag reading of gamma; ``"exact"``: the distance to the instantaneous circle of
    the reference (Eq. 17 on circles; the linear form on straight parts), for ablations.
``decomposition``
    ``"normal_at_reference"`` (Koren 1980; the paper's blocks U_x, U_y): along ``n`` at R.
    ``"towards_nearest"`` ("to move the tool to the point S", L210): along the normal at
    the path point S nearest the tool, ``n`` rotated by ``delta = sigma gamma`` where
    ``sigma = sign(n.(C - R))`` (+1: centre of curvature right of the motion) and ``gamma``
    the signed arc angle from R back to S, ``gamma = sign(E.t) |E|/r`` (chord reading) or
    ``sin gamma = E.t/r`` (tangent lag; ``t`` the tangent): ``U = u_c (sin(alpha + delta),
    -cos(alpha + delta))``.  On straight parts ``delta = 0``.

The PID on ``eps`` is LinuxCNC's ``calc_pid`` (:mod:`controllers.axis.pid`) with command
``eps`` and feedback 0, so the CEC's record carries the PID's fields under the same names:
``p_gain_per_mm`` [V/mm], ``i_gain_per_mm_s`` [V/(mm s)], ``d_gain_s_per_mm`` [V s/mm],
``max_output`` [V] and conditional integration when saturated.  Defaults [ASSUMED]: none
from the source (gains are tuned, A1-3).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import init_states, jit, record, register_element
from controllers.axis.pid import (
    _BOOL_FIELDS,
    _FLOAT_FIELDS,
    _STATE_FIELDS,
    AxisPIDParams,
    calc_pid,
    init,
    set_pid_fields,
)
from controllers.contouring.contour_error import (
    CURVATURE_ANGLES,
    curvature_corrected_estimate_at,
    exact_circle_error_at,
    lacerda_eq11_at,
    linear_estimate_at,
)

#: Contour-error models of the CEC and their codes.
CEC_MODELS = {"linear": 0, "curvature": 1, "exact": 2}
#: Decompositions of the CEC output onto the axes.
DECOMPOSITIONS = {"normal_at_reference": 0, "towards_nearest": 1}


@dataclass(frozen=True)
class CrossCoupledParams:
    """The CEC of spec A1-2.

    Attributes
    ----------
    model : {"linear", "curvature", "exact"}
        Contour-error model: Eq. (11), Eq. (16) (the paper's proposal), or exact.
    curvature_angle : {"chord", "tangent_lag"}
        Reading of gamma in Eq. (16) (``"chord"``: ``|E|/r``, the paper).
    decomposition : {"normal_at_reference", "towards_nearest"}
        How ``u_c`` is put back on the axes.
    kp_V_per_mm, ki_V_per_mm_s, kd_V_s_per_mm : float
        PID gains on ``eps`` [V/mm, V/(mm s), V s/mm].
    max_output_V : float
        Limit of ``u_c`` [V], >= 0 (0: none; the axis commands are limited after the sum).
    enable : bool
        False: the CEC contributes nothing (the axes run independently).
    """

    model: str = "curvature"
    curvature_angle: str = "chord"
    decomposition: str = "normal_at_reference"
    kp_V_per_mm: float = 0.0
    ki_V_per_mm_s: float = 0.0
    kd_V_s_per_mm: float = 0.0
    max_output_V: float = 0.0
    enable: bool = True

    def __post_init__(self) -> None:
        for name, allowed in (("model", CEC_MODELS), ("curvature_angle", CURVATURE_ANGLES),
                              ("decomposition", DECOMPOSITIONS)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be one of {', '.join(allowed)}, got "
                                 f"{getattr(self, name)!r}")
        for name in ("kp_V_per_mm", "ki_V_per_mm_s", "kd_V_s_per_mm", "max_output_V"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
                raise ValueError(f"{name} must be a finite number, got {v!r}")
        if self.max_output_V < 0:
            raise ValueError(f"max_output_V must be >= 0 (0 = no limit), got {self.max_output_V}")
        if not isinstance(self.enable, (bool, np.bool_)):
            raise ValueError(f"enable must be true or false, got {self.enable!r}")

    @property
    def pid(self) -> AxisPIDParams:
        """The PID on ``eps`` as LinuxCNC parameters (feed-forward off)."""
        return AxisPIDParams(p_gain_per_mm=self.kp_V_per_mm, i_gain_per_mm_s=self.ki_V_per_mm_s,
                             d_gain_s_per_mm=self.kd_V_s_per_mm, max_output=self.max_output_V,
                             enable=bool(self.enable))


def _dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "contour_controller.cec",
        [*((n, "f8") for n in _FLOAT_FIELDS), *((n, "b1") for n in _BOOL_FIELDS),
         ("period_s", "f8"), ("model", "i8"), ("curvature_angle", "i8"),
         ("decomposition", "i8")],
    )
    state = record("contour_controller.cec", [(n, "f8") for n in _STATE_FIELDS])
    return params, state


@jit
def contour_error_lacerda_at(model: int, curvature_angle: int, error_x_mm: float,
                             error_y_mm: float, tangent_angle_rad: float, reference_x_mm: float,
                             reference_y_mm: float, centre_x_mm: float, centre_y_mm: float,
                             radius_mm: float) -> float:
    """The CEC's contour error in Lacerda's sign (+ with the tool left of the motion) [mm].

    Parameters
    ----------
    model : int
        :data:`CEC_MODELS` code.
    curvature_angle : int
        ``CURVATURE_ANGLES`` code of :mod:`controllers.contouring.contour_error`.
    error_x_mm, error_y_mm : float
        ``E = R - P`` [mm].
    tangent_angle_rad : float
        ``alpha`` at R [rad].
    reference_x_mm, reference_y_mm : float
        R [mm].
    centre_x_mm, centre_y_mm, radius_mm : float
        Instantaneous centre and radius of the path at R [mm] (NaN, NaN, inf: straight).
    """
    if model == 0:
        return lacerda_eq11_at(error_x_mm, error_y_mm, tangent_angle_rad)
    if model == 1:
        return -curvature_corrected_estimate_at(
            error_x_mm, error_y_mm, tangent_angle_rad, reference_x_mm, reference_y_mm,
            centre_x_mm, centre_y_mm, radius_mm, curvature_angle)
    straight = not (radius_mm > 0.0 and radius_mm < math.inf) or centre_x_mm != centre_x_mm
    if straight:
        return -linear_estimate_at(error_x_mm, error_y_mm, tangent_angle_rad)
    side = (math.sin(tangent_angle_rad) * (centre_x_mm - reference_x_mm)
            - math.cos(tangent_angle_rad) * (centre_y_mm - reference_y_mm))
    turn = -1.0 if side > 0.0 else 1.0  # centre on the right: clockwise
    return -exact_circle_error_at(reference_x_mm - error_x_mm, reference_y_mm - error_y_mm,
                                  centre_x_mm, centre_y_mm, radius_mm, turn)


@jit
def decompose_at(correction_V: float, tangent_angle_rad: float) -> tuple[float, float]:
    """Blocks U_x, U_y: ``u_c (sin alpha, -cos alpha)`` [V]."""
    return (correction_V * math.sin(tangent_angle_rad),
            -correction_V * math.cos(tangent_angle_rad))


@jit
def nearest_point_rotation_at(curvature_angle: int, error_x_mm: float, error_y_mm: float,
                              tangent_angle_rad: float, reference_x_mm: float,
                              reference_y_mm: float, centre_x_mm: float, centre_y_mm: float,
                              radius_mm: float) -> float:
    """``delta`` [rad] of the ``"towards_nearest"`` decomposition (module docstring); 0 on
    straight parts.  Arguments as :func:`contour_error_lacerda_at`."""
    r = radius_mm
    if not (r > 0.0 and r < math.inf) or centre_x_mm != centre_x_mm or centre_y_mm != centre_y_mm:
        return 0.0
    ca = math.cos(tangent_angle_rad)
    sa = math.sin(tangent_angle_rad)
    side = sa * (centre_x_mm - reference_x_mm) - ca * (centre_y_mm - reference_y_mm)
    sigma = 1.0 if side > 0.0 else (-1.0 if side < 0.0 else 0.0)
    lag = error_x_mm * ca + error_y_mm * sa  # E.t: > 0 when the tool lags R
    if curvature_angle == 1:
        sg = lag / r
        sg = 1.0 if sg > 1.0 else (-1.0 if sg < -1.0 else sg)
        gamma = math.asin(sg)
    else:
        gamma = math.sqrt(error_x_mm * error_x_mm + error_y_mm * error_y_mm) / r
        if lag < 0.0:
            gamma = -gamma
    return sigma * gamma


@jit
def step(p, s, error_x_mm: float, error_y_mm: float, tangent_angle_rad: float,  # noqa: ANN001
         reference_x_mm: float, reference_y_mm: float, centre_x_mm: float,
         centre_y_mm: float, radius_mm: float) -> tuple[float, float, float]:
    """One CEC period: the axis corrections ``U_x, U_y`` [V] and ``eps`` [mm, Lacerda's
    sign] (arguments as :func:`contour_error_lacerda_at`)."""
    eps = contour_error_lacerda_at(p.model, p.curvature_angle, error_x_mm, error_y_mm,
                                   tangent_angle_rad, reference_x_mm, reference_y_mm,
                                   centre_x_mm, centre_y_mm, radius_mm)
    uc = calc_pid(p, s, eps, 0.0, 0.0, 0.0)
    direction = tangent_angle_rad
    if p.decomposition == 1:
        direction += nearest_point_rotation_at(p.curvature_angle, error_x_mm, error_y_mm,
                                               tangent_angle_rad, reference_x_mm,
                                               reference_y_mm, centre_x_mm, centre_y_mm,
                                               radius_mm)
    ux, uy = decompose_at(uc, direction)
    return ux, uy, eps


CEC = register_element(
    "contour_controller.cec",
    _dtypes,
    init,
    step,
    "Lacerda & Belo's cross-coupled contour-error controller (A1-2): PID on Eq. 11/16, "
    "along the normal",
)


def cec_records(
    controllers: CrossCoupledParams | Sequence[CrossCoupledParams],
    control_period_s: float,
    *,
    runs: int | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of CECs.

    Parameters
    ----------
    controllers : CrossCoupledParams or sequence of them, length runs
    control_period_s : float
        Period of the PID on ``eps`` [s], > 0.
    runs : int, optional
        Batch size when ``controllers`` is one parameter set.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    if not control_period_s > 0:
        raise ValueError(f"control_period_s must be > 0, got {control_period_s}")
    if isinstance(controllers, CrossCoupledParams):
        controllers = [controllers] * (1 if runs is None else int(runs))
    ctrls = list(controllers)
    params, state = CEC.records(len(ctrls))
    set_pid_fields(params, [c.pid for c in ctrls], control_period_s)
    for r, c in enumerate(ctrls):
        params["model"][r] = CEC_MODELS[c.model]
        params["curvature_angle"][r] = CURVATURE_ANGLES[c.curvature_angle]
        params["decomposition"][r] = DECOMPOSITIONS[c.decomposition]
    return params, init_states(params, state)


__all__ = ["CEC", "CEC_MODELS", "DECOMPOSITIONS", "CrossCoupledParams", "cec_records",
           "contour_error_lacerda_at", "decompose_at", "nearest_point_rotation_at"]
