"""Peng's two-axis contouring system (spec M0-12): two independent position loops on one path.

Peng's Fig. 4.25: the interpolator sends ``X_rx(k)`` and ``X_ry(k)`` to two copies of the
sampled servo loop (2.31), each with its own parameters (e.g. the mismatched viscous
friction ``B_x = 0.09``, ``B_y = 0.3`` N m s/rad) and no mechanical or control coupling.
So the contouring run is exactly two runs of the single-axis engine
(:func:`acc.engine.axis_simulate.simulate_axis`), driven sample by sample by the
interpolator's x and y references; a batch of ``runs`` XY runs is one call of ``2 runs``
axis runs (x of run ``i`` is axis run ``2i``, y is ``2i + 1``).

Beside the axis signals the result traces the exact contour error (distance to the ideal
path; closed form on a circle) and the estimates of
:mod:`controllers.contouring.contour_error` computed from the same samples: Peng's linear
(4.78) and the curvature-corrected Eq. 16 (spec O-21 sign: + with the tool to the right of
the motion).  A coupled loop (a cross-coupled controller acting across the axes) is not
this module's concern: see :mod:`acc.engine.xy_simulate`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from acc.engine.axis_simulate import AxisParams, AxisResult, ControllerParams, simulate_axis
from acc.engine.axis_verdicts import DIVERGENCE_FACTOR
from acc.engine.batch import per_run, runs_of
from acc.engine.result import FrozenSignals
from controllers.axis.lead_lag import LeadLagParams
from controllers.contouring import contour_error as ce
from controllers.contouring.interpolator import PathReference

#: Signals of a contouring result (shape (runs, n)), their units and meaning.
CONTOUR_SIGNALS: dict[str, str] = {
    "x_ref_mm": "x reference [mm]",
    "y_ref_mm": "y reference [mm]",
    "x_mm": "x table position [mm]",
    "y_mm": "y table position [mm]",
    "following_error_x_mm": "x following error x_ref - x [mm]",
    "following_error_y_mm": "y following error y_ref - y [mm]",
    "velocity_x_mm_s": "x table velocity [mm/s]",
    "velocity_y_mm_s": "y table velocity [mm/s]",
    "command_x": "x controller output (V for a servo axis)",
    "command_y": "y controller output",
    "contour_error_mm": "exact contour error: signed distance to the ideal path, + right [mm]",
    "linear_estimate_mm": "Peng's (4.78) (= -Eq. 11), + right [mm]",
    "curvature_estimate_mm": "Eq. 16 [RECON], + right [mm]",
}


@dataclass(frozen=True)
class ContourResult(FrozenSignals):
    """What :func:`simulate_contouring` returns.

    Attributes
    ----------
    time_s : ndarray, shape (n,)
        ``t_k = k dt`` [s].
    signals : mapping of str to ndarray, shape (runs, n)
        See :data:`CONTOUR_SIGNALS`.
    metrics : mapping of str to ndarray, shape (runs,)
        ``iae_contour_mm_s`` (integral of ``|contour error|`` dt),
        ``max_abs_contour_error_mm``, ``max_abs_linear_estimate_error_mm`` and
        ``max_abs_curvature_estimate_error_mm`` (estimate minus exact),
        ``saturated_fraction`` (the larger of the two axes' shares of plant steps at a
        limit; NaN without limits), all NaN for a failed run; ``failed`` (bool) and
        ``spectral_radius_x``/``_y`` (:mod:`acc.engine.axis_verdicts`).
    references : tuple of PathReference, length runs
    axis_result : AxisResult
        The underlying single-axis batch (x of run ``i`` at ``2i``, y at ``2i + 1``).
    plant_step_s : float
    failure_reasons : tuple of str, length runs
        Why each run failed (``""``: it did not): an axis run's reason, naming the axis.
    """

    time_s: NDArray[np.float64]
    signals: Mapping[str, NDArray[np.float64]]
    metrics: Mapping[str, NDArray[np.float64]]
    references: tuple[PathReference, ...]
    axis_result: AxisResult
    plant_step_s: float
    failure_reasons: tuple[str, ...] = ()

    _runs_field: ClassVar[str] = "references"

    def position_mm(self, run: int = 0) -> NDArray[np.float64]:
        """Tool (table) positions of one run, shape (n, 2) [mm]."""
        return np.stack([self.signals["x_mm"][run], self.signals["y_mm"][run]], axis=1)


def switched_integrator(
    controller: LeadLagParams,
    reference: PathReference,
    off_before_vertex_mm: float,
    on_after_vertex_mm: float,
    when_off: str = "frozen",
) -> LeadLagParams:
    """Peng's switched integral action around a corner (Sec. 4.4.2, spec A0-7).

    The integrator of ``controller`` is switched off when the reference is
    ``off_before_vertex_mm`` of path before the vertex and back on ``on_after_vertex_mm``
    after it (distances along the reference, converted to times with the reference's own
    speed).  ``P_1`` is not specified in the thesis: both distances are the user's.

    Parameters
    ----------
    controller : LeadLagParams
        With an integrator form other than ``"none"``.
    reference : PathReference
        A corner path (``vertex_time_s`` finite).
    off_before_vertex_mm, on_after_vertex_mm : float
        Path distances [mm], >= 0.
    when_off : {"frozen", "reset"}

    Returns
    -------
    LeadLagParams
        ``controller`` with ``integrator_off_from_s`` and ``integrator_on_from_s`` set.
    """
    if not math.isfinite(reference.vertex_time_s):
        raise ValueError("switched_integrator needs a corner path (vertex_time_s)")
    if controller.integrator_form == "none":
        raise ValueError("integrator_form: the controller has no integrator to switch")
    if not (off_before_vertex_mm >= 0 and on_after_vertex_mm >= 0):
        raise ValueError("off_before_vertex_mm and on_after_vertex_mm must be >= 0")
    dt = reference.plant_step_s
    step = np.hypot(*np.diff(reference.position_mm, axis=0).T)
    travelled = np.concatenate([[0.0], np.cumsum(step)])  # path length at each sample
    k_v = int(round(reference.vertex_time_s / dt))
    s_v = travelled[min(k_v, travelled.size - 1)]
    k_off = int(np.searchsorted(travelled, s_v - off_before_vertex_mm, side="left"))
    k_on = int(np.searchsorted(travelled, s_v + on_after_vertex_mm, side="left"))
    return replace(controller, integrator_off_from_s=k_off * dt,
                   integrator_on_from_s=max(k_on, k_off) * dt, integrator_when_off=when_off)


def simulate_contouring(
    path: PathReference | Sequence[PathReference],
    axis_x: AxisParams | Sequence[AxisParams],
    axis_y: AxisParams | Sequence[AxisParams],
    controller_x: ControllerParams | Sequence[ControllerParams],
    controller_y: ControllerParams | Sequence[ControllerParams] | None = None,
    *,
    curvature_angle: str = "chord",
    threads: int | None = None,
    divergence_factor: float = DIVERGENCE_FACTOR,
) -> ContourResult:
    """Simulate a batch of Peng two-axis contouring runs over their whole references.

    Parameters
    ----------
    path : PathReference or sequence of them (one per run)
        From :func:`controllers.contouring.interpolator.interpolate`; every run's reference
        has the same number of samples and plant step.
    axis_x, axis_y : ServoAxisParams (or another axis kind of the single-axis engine), or a
        sequence per run
    controller_x, controller_y : LeadLagParams, AxisPIDParams or StateControlParams, or a
        sequence per run; ``controller_y`` defaults to ``controller_x``.  One kind for all.
    curvature_angle : {"chord", "tangent_lag"}
        Reading of Eq. 16 for the traced curvature estimate.
    threads : int or None
        Threads of the compiled loop.
    divergence_factor : float
        ``D`` of the axes' error and current bounds (:mod:`acc.engine.axis_verdicts`); the
        path size ``L`` of both axes is the path's (the larger range of x and y).

    Returns
    -------
    ContourResult
        With each run's verdict: failed when either axis run failed.
    """
    if controller_y is None:
        controller_y = controller_x
    runs = runs_of(path, axis_x, axis_y, controller_x, controller_y)
    refs = per_run(path, PathReference, runs, "path")
    n = refs[0].samples
    dt = refs[0].plant_step_s
    if any(r.samples != n or r.plant_step_s != dt for r in refs):
        raise ValueError("path: every run's reference must have the same samples and plant step")
    ax_x, ax_y, c_x, c_y = (
        list(v) if isinstance(v, (list, tuple)) else [v] * runs
        for v in (axis_x, axis_y, controller_x, controller_y)
    )
    axes = [a for pair in zip(ax_x, ax_y, strict=True) for a in pair]
    ctrls = [c for pair in zip(c_x, c_y, strict=True) for c in pair]
    samples = np.empty((2 * runs, n))
    for i, r in enumerate(refs):
        samples[2 * i] = r.position_mm[:, 0]
        samples[2 * i + 1] = r.position_mm[:, 1]
    sizes = np.repeat(np.ptp(samples, axis=1).reshape(runs, 2).max(axis=1), 2)
    res = simulate_axis(axes, ctrls, reference_samples_mm=samples, duration_s=n * dt,
                        plant_step_s=dt, threads=threads, path_size_mm=sizes,
                        divergence_factor=divergence_factor)
    sig = res.signals
    x, y = sig["x_mm"][0::2], sig["x_mm"][1::2]
    ex, ey = sig["following_error_mm"][0::2], sig["following_error_mm"][1::2]
    cmd = "command_V" if "command_V" in sig else "speed_command_mm_s"
    exact = np.empty((runs, n))
    lin = np.empty((runs, n))
    curv = np.empty((runs, n))
    for i, r in enumerate(refs):
        pos = np.stack([x[i], y[i]], axis=1)
        exact[i] = r.exact_contour_error(pos)
        lin[i] = ce.linear_estimate(ex[i], ey[i], r.tangent_angle_rad)
        curv[i] = ce.curvature_corrected_estimate(ex[i], ey[i], r.tangent_angle_rad,
                                                  r.position_mm, r.centre_mm, r.radius_mm,
                                                  curvature_angle)
    signals = {
        "x_ref_mm": sig["x_ref_mm"][0::2],
        "y_ref_mm": sig["x_ref_mm"][1::2],
        "x_mm": x,
        "y_mm": y,
        "following_error_x_mm": ex,
        "following_error_y_mm": ey,
        "velocity_x_mm_s": sig["velocity_mm_s"][0::2],
        "velocity_y_mm_s": sig["velocity_mm_s"][1::2],
        "command_x": sig[cmd][0::2],
        "command_y": sig[cmd][1::2],
        "contour_error_mm": exact,
        "linear_estimate_mm": lin,
        "curvature_estimate_mm": curv,
    }
    reasons = [f"x axis: {x}" if x else (f"y axis: {y}" if y else "")
               for x, y in zip(res.failure_reasons[0::2], res.failure_reasons[1::2],
                               strict=True)]
    failed = np.array([bool(x) for x in reasons])
    axis_metrics = res.metrics
    with np.errstate(invalid="ignore"):
        metrics = {
            "iae_contour_mm_s": np.abs(exact).sum(axis=1) * dt,
            "max_abs_contour_error_mm": np.abs(exact).max(axis=1),
            "max_abs_linear_estimate_error_mm": np.abs(lin - exact).max(axis=1),
            "max_abs_curvature_estimate_error_mm": np.abs(curv - exact).max(axis=1),
            "saturated_fraction": np.fmax(axis_metrics["saturated_fraction"][0::2],
                                          axis_metrics["saturated_fraction"][1::2]),
        }
    metrics = {k: np.where(failed, np.nan, v) for k, v in metrics.items()}
    metrics["failed"] = failed
    metrics["spectral_radius_x"] = axis_metrics["spectral_radius"][0::2]
    metrics["spectral_radius_y"] = axis_metrics["spectral_radius"][1::2]
    return ContourResult(time_s=np.arange(n) * dt, signals=signals, metrics=metrics,
                         references=tuple(refs), axis_result=res, plant_step_s=dt,
                         failure_reasons=tuple(reasons))


__all__ = ["CONTOUR_SIGNALS", "ContourResult", "simulate_contouring", "switched_integrator"]
