"""Step-response costs of the sampled loop: reference- and disturbance-step IAE, ITAE, ISE.

The loop is the one the simulator runs (:func:`acc.design.linear.sampled_loop`, clamps
inactive), split at the PI: an *inner* system from the PI's output ``c`` (the command, or the
feed request inside an observer) and a feed disturbance ``d`` at the drive's input to the true
force ``f`` and the measured force ``y_m``, with the PI around it::

    e_k = r_k - y_m,k,   c_k = F (kp e_k + ki I_k),   I_{k+1} = I_k + T_c e_k.

Two unit events start from rest at ``k = 0``: a reference step ``r = 1`` N (error ``1 - f``)
and a feed-disturbance step of :func:`equivalent_disturbance_mm_min` (the feed that moves the
nominal plant's steady force by 1 N; error ``-f``).  Their costs over ``n`` control periods are
``sum_k w_k |e_k|`` with ``w_k = T_c`` (IAE [s]), ``T_c t_k`` (ITAE [s^2]) or ``T_c e_k`` in
place of ``|e_k|`` (ISE [s]); the force is the true one, as in the simulator's metrics.

:func:`true_costs` computes them numerically with python-control; :func:`unrolled_costs` as
casadi expressions of ``kp`` and ``ki`` (the loop unrolled step by step, ``|e|`` smoothed to
``sqrt(e^2 + eps^2) - eps``) for :mod:`acc.design.robust_tuning`.
"""

from __future__ import annotations

import functools
import math
from typing import Any, Literal

import control
import numpy as np
from numpy.typing import NDArray

from controllers.linear_loop import LoopSpec

Objective = Literal["iae", "itae", "ise"]
OBJECTIVES: tuple[str, ...] = ("iae", "itae", "ise")
#: Smoothing of ``|e|`` in the unrolled cost [N per N of step]: ``sqrt(e^2 + eps^2) - eps``
#: is within ``eps`` of ``|e|``, so the IAE over the horizon within ``eps * horizon``.
SMOOTHING = 1e-3


def equivalent_disturbance_mm_min(spec: LoopSpec) -> float:
    """Feed step [mm/min] that moves the nominal plant's steady force by 1 N: ``-p_n / K_n``."""
    return -spec.nominal_p2_rad_s / spec.nominal_k2_N_min_per_mm_s


@functools.lru_cache(maxsize=512)
def inner_system(spec: LoopSpec) -> tuple[NDArray, NDArray, NDArray]:
    """The loop without the PI, discrete at ``T_c``: ``(A, B, C)``.

    Inputs ``[c, d]`` (PI output, feed disturbance [mm/min]), outputs ``[f, y_m]`` [N]; the
    feed-through is zero (the drive's dead time is at least one period), checked.  Built with
    :func:`control.interconnect` from the blocks of :func:`acc.design.linear.sampled_loop`
    (the PI gains of ``spec`` are not used).

    Raises
    ------
    ValueError
        A dead time shorter than one control period (an algebraic loop through the PI).
    """
    from acc.design import linear

    tc = spec.control_period_s
    # the feed disturbance enters at the plant's input: the observer (if any) sees only its
    # own command
    sys = control.interconnect(
        _blocks_with_disturbance(spec), inputs=[linear.FEED_REQUEST, "feed_disturbance_mm_min"],
        outputs=[linear.FORCE, linear.MEASURED],
    )
    A, B, C, D = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    if np.abs(D).max() > 0 or sys.dt != tc:
        raise ValueError("the sampled plant must have no feed-through (dead time >= 1 period)")
    return A, B, C


def _blocks_with_disturbance(spec: LoopSpec) -> list[Any]:
    """The blocks of :func:`acc.design.linear.sampled_loop` without the PI, the command and a
    feed disturbance summed at the plant's input."""
    from acc.design import linear

    tc = spec.control_period_s
    if not spec.is_pi or spec.has_predictor:
        raise ValueError("the step costs cover the PI, alone or inside the observer")
    blocks = [
        linear.sampled_plant_block(spec, "plant_input_mm_min"),
        control.summing_junction([linear.COMMAND, "feed_disturbance_mm_min"],
                                 "plant_input_mm_min", dt=tc, name="d"),
    ]
    if not spec.has_observer:
        blocks.append(control.summing_junction([linear.FEED_REQUEST], linear.COMMAND, dt=tc,
                                               name="c"))
        return blocks
    return blocks + linear.sampled_observer_blocks(spec)


def closed_loop(spec: LoopSpec) -> control.StateSpace:
    """The sampled closed loop with the PI of ``spec``: inputs ``[r, d]``, output ``f`` [N]."""
    A, B, C = inner_system(spec)
    tc, F = spec.control_period_s, spec.programmed_feed_mm_min
    kp, ki = spec.kp_per_N, spec.ki_per_N_s
    cf, cm = C[0], C[1]
    bc, bd = B[:, :1], B[:, 1:]
    # states [x, I]; c = F (kp (r - cm x) + ki I)
    Acl = np.block([[A - F * kp * bc @ cm[None, :], F * ki * bc],
                    [-tc * cm[None, :], np.ones((1, 1))]])
    Bcl = np.block([[F * kp * bc, bd], [np.array([[tc, 0.0]])]])
    Ccl = np.concatenate([cf, [0.0]])[None, :]
    return control.ss(Acl, Bcl, Ccl, np.zeros((1, 2)), tc)


def true_costs(spec: LoopSpec, horizon_steps: int, objective: Objective = "iae"
               ) -> tuple[float, float]:
    """Reference- and disturbance-step cost of one loop (module docstring), numerically.

    Returns
    -------
    (float, float)
        Costs of the unit reference step and of the equivalent disturbance step
        (IAE [s], ITAE [s^2], ISE [s]); ``inf`` for an unstable loop.
    """
    cl = closed_loop(spec)
    if np.max(np.abs(np.linalg.eigvals(cl.A))) >= 1.0 - 1e-9:
        return math.inf, math.inf
    tc = spec.control_period_s
    t = np.arange(horizon_steps) * tc
    dist = equivalent_disturbance_mm_min(spec)
    u = np.vstack([np.ones(horizon_steps), np.full(horizon_steps, dist)])
    f_ref = np.asarray(control.forced_response(cl[:, 0], T=t, U=u[0]).outputs).ravel()
    f_dist = np.asarray(control.forced_response(cl[:, 1], T=t, U=u[1]).outputs).ravel()
    return _cost(1.0 - f_ref, t, tc, objective), _cost(-f_dist, t, tc, objective)


def _cost(e: NDArray, t: NDArray, tc: float, objective: Objective) -> float:
    if objective == "iae":
        return float(np.sum(np.abs(e)) * tc)
    if objective == "itae":
        return float(np.sum(t * np.abs(e)) * tc)
    return float(np.sum(e * e) * tc)


def unrolled_costs(
    specs: list[LoopSpec], horizon_steps: int, objective: Objective, kp: Any, ki: Any
) -> Any:
    """casadi expression of every loop's two step costs, shape ``(2 * len(specs), 1)``.

    ``kp``, ``ki``: casadi scalars [1/N], [1/(N s)].  Rows ``2 i`` and ``2 i + 1``: the
    reference and disturbance step of ``specs[i]`` (the PI gains of the specs are not used).
    The loops are stepped together (one block-diagonal step function, unrolled with
    ``mapaccum``), ``|e|`` smoothed by :data:`SMOOTHING`.
    """
    import casadi as ca
    from scipy.sparse import block_diag, csc_matrix

    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    tc, F = specs[0].control_period_s, specs[0].programmed_feed_mm_min
    systems = [inner_system(sp) for sp in specs]
    A = ca.DM(csc_matrix(block_diag([s[0] for s in systems], format="csc")))
    bc = ca.DM(csc_matrix(block_diag([s[1][:, :1] for s in systems], format="csc")))
    bd = ca.DM(csc_matrix(block_diag([s[1][:, 1:] for s in systems], format="csc")))
    cf = ca.DM(csc_matrix(block_diag([s[2][:1] for s in systems], format="csc")))
    cm = ca.DM(csc_matrix(block_diag([s[2][1:] for s in systems], format="csc")))
    n, m = A.size1(), len(specs)
    dist = ca.DM([equivalent_disturbance_mm_min(sp) for sp in specs])

    x = ca.SX.sym("x", n, 2)  # columns: reference step, disturbance step
    integ = ca.SX.sym("I", m, 2)
    acc = ca.SX.sym("J", m, 2)
    gains = ca.SX.sym("k", 2)
    w = ca.SX.sym("w")  # this step's weight: T_c, or T_c t_k
    r = ca.horzcat(ca.DM.ones(m), ca.DM.zeros(m))
    d = ca.horzcat(ca.DM.zeros(m), dist)
    e = r - ca.mtimes(cm, x)
    c = F * (gains[0] * e + gains[1] * integ)
    x_next = ca.mtimes(A, x) + ca.mtimes(bc, c) + ca.mtimes(bd, d)
    err = r - ca.mtimes(cf, x)  # on the true force
    if objective == "ise":
        size = err * err
    else:
        size = ca.sqrt(err * err + SMOOTHING**2) - SMOOTHING
    state = ca.vertcat(ca.vec(x), ca.vec(integ), ca.vec(acc))
    nxt = ca.vertcat(ca.vec(x_next), ca.vec(integ + tc * e), ca.vec(acc + w * size))
    step = ca.Function("step", [state, gains, w], [nxt])
    unroll = step.mapaccum("unroll", horizon_steps)
    t = np.arange(horizon_steps) * tc
    weights = np.full(horizon_steps, tc) if objective != "itae" else tc * t
    final = unroll(ca.DM.zeros(state.size1()), ca.repmat(ca.vertcat(kp, ki), 1, horizon_steps),
                   ca.DM(weights).T)[:, -1]
    costs = ca.reshape(final[-2 * m:], m, 2)  # (loop, event)
    return ca.vec(costs.T)


__all__ = [
    "OBJECTIVES",
    "Objective",
    "SMOOTHING",
    "closed_loop",
    "equivalent_disturbance_mm_min",
    "inner_system",
    "true_costs",
    "unrolled_costs",
]
