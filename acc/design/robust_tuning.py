"""Robust tuning on casadi/IPOPT: PI gains (and the observer's Q-filter tau) for a plant set.

Plant set.  Every table depth of the scenario (K2, p2 of the row, times the material
multipliers ``material_range``) and the dead times ``(min, nominal, max)``: up to 27 loops.

Loop: the sampled loop the simulator runs (:func:`acc.design.linear.sampled_loop`), in the
frequency domain at ``z = e^{j w T_c}``: the plant from command to measured force ``P_m(z)``
(feed drive, process and sensor by ZOH behind ``z^-N``), the PI ``C = F (kp + ki T_c/(z - 1))``
and, with the observer, its discrete filters ``F_Q`` (Q P_n0^-1 by first-order hold on the
force) and ``G_Q z^-N_n`` (Q by zero-order hold on the delayed command)::

    S = (1 - G_Q z^-N_n) / ((1 - G_Q z^-N_n) + (C + F_Q) P_m),   T = 1 - S

(without the observer ``F_Q = G_Q = 0``).  The loop is affine in ``kp`` and ``ki``, so these
are the program's variables (as logarithms, each within a factor :data:`BOUND_FACTOR` of its
start); the observer's ``tau`` is scanned over :data:`TAU_FACTORS` times its start, one
program per value, and the best feasible one kept.

Objective: a smooth soft-max (sharpness :data:`SOFTMAX_SHARPNESS` relative to a scale: the
start's worst cost, then the optimum's, solved again from there) over the plants of the IAE
(or ITAE, ISE) of a unit reference step and of the equivalent feed-disturbance step
(:mod:`acc.design.step_costs`), on the true force over ``horizon_s``: the sampled closed loop
unrolled symbolically period by period, ``|e|`` smoothed.  Constraints at every plant and
grid frequency: ``|S| <= Ms``, ``|T| <= Mt``.
Solved with IPOPT through casadi (exact gradients, a limited-memory Hessian).

The result is then checked on what the simulator runs: the sampled closed loops
(:func:`acc.design.analysis.sampled_closed_loop`) must all be stable, and their true worst
step costs (python-control's responses, no smoothing, no penalty) are reported before and
after, with the phase margins and the largest |S| and |T| over the set.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import control
import numpy as np

from acc.design import linear
from acc.design.analysis import is_stable, loop_spec, sampled_closed_loop
from acc.design.step_costs import OBJECTIVES, Objective, true_costs, unrolled_costs
from acc.design.tuning import HORIZON_S, NotTunableError
from acc.scenario import Scenario
from controllers.linear_loop import LoopSpec

#: Frequency grid points (log-spaced from :data:`LOWEST_RAD_S` to the Nyquist frequency).
GRID_POINTS = 200
#: Lowest grid frequency [rad/s]: slow closed-loop modes below it would escape the integrals.
LOWEST_RAD_S = 1e-4
#: Sharpness of the soft-max over plants.
SOFTMAX_SHARPNESS = 20.0
#: Each variable stays within this factor of its start (either way).
BOUND_FACTOR = 100.0
#: Starts of each program: the start's log-gains minus these (the gains, and 1/8 of them).
START_SHIFTS = (0.0, math.log(8.0))
#: Frequency grid of the reported phase margins [rad/s] (exact delay; a quarter of the
#: analysis grid's points over the same range).
MARGIN_OMEGA_RAD_S = np.logspace(-2, np.log10(2000.0), 1000)
#: IPOPT's iteration limit per solve (feasible solves of the shipped problem take <= 50).
MAX_ITERATIONS = 80
#: Largest start cost used as the soft-max's scale (an unstable start: 1 instead).
MAX_SCALE = 1e3
#: Further IPOPT options (tests and benchmarks may try others).
SOLVER_OPTIONS: dict[str, Any] = {}
#: Multiples of the start tau scanned for the observer kind.
TAU_FACTORS = (0.25, 0.5, 1.0, 2.0, 4.0)


class InfeasibleTuningError(Exception):
    """The constraints cannot be met (IPOPT failed, or the result violates them)."""


@dataclass(frozen=True)
class RobustTuneResult:
    """Outcome of :func:`robust_tune`; costs are the sampled loops' true step costs (no
    smoothing, no penalty; :func:`acc.design.step_costs.true_costs`), worst over the plant set.

    Attributes
    ----------
    scenario : Scenario
        The scenario with the tuned values.
    values : dict of str to float
        Tuned ``controller.*`` keys.
    initial_cost, cost : (float, float)
        Worst reference-step and worst disturbance-step cost before and after (IAE [s],
        ITAE [s^2] or ISE [s] per unit step, as ``objective_name``).
    initial_objective, objective : float
        The smooth objective (soft-max of the unrolled costs, at the final scale) before and
        after; candidates (values of tau, starts) are ranked by their worst unrolled cost.
    max_sensitivity, max_complementary_sensitivity : float
        Largest |S| and |T| over the plant set and grid after tuning.
    initial_max_sensitivity, initial_max_complementary_sensitivity : float
        The same at the start.
    min_phase_margin_deg, initial_min_phase_margin_deg : float
        Smallest phase margin over the plant set after and before [deg].
    plants : int
    seconds : float
        Wall time of the solve and checks [s].
    objective_name : str
        ``"iae"``, ``"itae"`` or ``"ise"``.
    horizon_s : float
        Horizon of the step responses [s].
    constraints : dict of str to float
        Each constraint's bound.
    """

    scenario: Scenario
    values: dict[str, float]
    initial_cost: tuple[float, float]
    cost: tuple[float, float]
    initial_objective: float
    objective: float
    max_sensitivity: float
    max_complementary_sensitivity: float
    min_phase_margin_deg: float
    initial_min_phase_margin_deg: float
    plants: int
    seconds: float
    objective_name: str = "iae"
    horizon_s: float = HORIZON_S
    initial_max_sensitivity: float = math.nan
    initial_max_complementary_sensitivity: float = math.nan
    constraints: dict[str, float] = field(default_factory=dict)


def plant_set(
    scenario: Scenario,
    material_range: tuple[float, float] = (1.0, 1.0),
    dead_time_range_s: tuple[float, float] | None = None,
    radial_depths_mm: tuple[float, ...] | None = None,
) -> list[LoopSpec]:
    """The scenario's loop on every table depth (or each of ``radial_depths_mm``, interpolated
    in the table) x material multiplier x dead time."""
    L = scenario.feed_drive.dead_time_s
    lo, hi = dead_time_range_s if dead_time_range_s is not None else (0.8 * L, 1.2 * L)
    if not 0 <= lo <= hi:
        raise ValueError(f"dead-time range must satisfy 0 <= min <= max, got {lo}, {hi}")
    m_lo, m_hi = material_range
    if not 0 < m_lo <= m_hi:
        raise ValueError(f"material range must satisfy 0 < min <= max, got {m_lo}, {m_hi}")
    specs = []
    depths = scenario.force_process.radial_depth_mm if radial_depths_mm is None else (
        radial_depths_mm)
    for depth in depths:
        spec = loop_spec(scenario, depth)
        for m in sorted({m_lo, 1.0, m_hi}) if m_lo <= 1.0 <= m_hi else sorted({m_lo, m_hi}):
            for dead in sorted({lo, L, hi}):
                specs.append(spec.with_gain_ratio(m).replace(dead_time_s=dead))
    return specs


def _frequency_data(
    specs: list[LoopSpec], omega: np.ndarray, tau_s: float | None
) -> dict[str, np.ndarray]:
    """Numeric parts of the sampled loop per plant (rows) and frequency (columns)."""
    import control

    from acc.design.linear import _observer_mats, _with_input_delay, _zoh_plant

    tc = specs[0].control_period_s
    z = np.exp(1j * omega * tc)
    meas, force = [], []
    for sp in specs:
        ad, bd, c = _zoh_plant(sp.bandwidth_rad_s, sp.p2_rad_s, sp.sensor_cutoff_hz, tc)
        A, B, C = _with_input_delay(ad, bd, c * sp.k2_N_min_per_mm_s,
                                    int(round(sp.dead_time_s / tc)))
        resp = control.frequency_response(
            control.ss(A, B, C, np.zeros((2, 1)), tc), omega
        ).complex
        force.append(np.asarray(resp[0, 0]).ravel())
        meas.append(np.asarray(resp[1, 0]).ravel())
    rows = len(specs)
    sp0 = specs[0]
    out = {"Pm": np.array(meas), "Pf": np.array(force),
           "integrator": np.tile(tc / (z - 1.0), (rows, 1))}
    if tau_s is not None:
        (ba, bb, bc, bd), (ia, ib, ic, idd) = _observer_mats(
            tau_s, tc, sp0.dob_q_numerator, sp0.dob_q_order, sp0.dob_sensor_cutoff_hz
        )
        a, kn, pn = sp0.bandwidth_rad_s, sp0.nominal_k2_N_min_per_mm_s, sp0.nominal_p2_rad_s
        comb = np.array([[1.0, a - pn, -a * pn]]) / (a * kn)
        f_q = control.frequency_response(control.ss(ba, bb, comb @ bc, comb @ bd, tc), omega)
        g_q = control.frequency_response(control.ss(ia, ib, ic, idd, tc), omega)
        n_nom = int(round(sp0.nominal_dead_time_s / tc))
        out["FQ"] = np.tile(np.asarray(f_q.complex).ravel(), (rows, 1))
        out["GQE"] = np.tile(np.asarray(g_q.complex).ravel() * z**-n_nom, (rows, 1))
    return out


def _loop_functions(
    specs: list[LoopSpec], tau_s: float | None, omega: np.ndarray
) -> Callable:
    """casadi expressions of |S|^2 and |T|^2 (plants x frequencies) for ``kp``, ``ki``."""
    import casadi as ca

    data = _frequency_data(specs, omega, tau_s)
    feed = specs[0].programmed_feed_mm_min
    rows, cols = data["Pm"].shape

    def const(v: np.ndarray) -> tuple[ca.DM, ca.DM]:
        v = np.asarray(v).ravel()
        return ca.DM(v.real), ca.DM(v.imag)

    def mul(x: tuple, y: tuple) -> tuple:
        return x[0] * y[0] - x[1] * y[1], x[0] * y[1] + x[1] * y[0]

    def add(x: tuple, y: tuple) -> tuple:
        return x[0] + y[0], x[1] + y[1]

    def abs2(x: tuple) -> Any:
        return x[0] * x[0] + x[1] * x[1]

    def div(x: tuple, y: tuple) -> tuple:
        d = abs2(y)
        return (x[0] * y[0] + x[1] * y[1]) / d, (x[1] * y[0] - x[0] * y[1]) / d

    Pm, integ = const(data["Pm"]), const(data["integrator"])
    ones = ca.DM.ones(rows * cols)
    if tau_s is not None:
        gqe = const(data["GQE"])
        one_minus = (ones - gqe[0], -gqe[1])
        fq = const(data["FQ"])
    else:
        one_minus = (ones, 0 * ones)
        fq = (0 * ones, 0 * ones)

    def build(kp: Any, ki: Any) -> tuple:
        C = (feed * kp + feed * ki * integ[0], feed * ki * integ[1])
        den = add(one_minus, mul(add(C, fq), Pm))
        S = div(one_minus, den)
        T = (1 - S[0], -S[1])
        return abs2(S), abs2(T)

    return build


def robust_tune(
    scenario: Scenario,
    max_sensitivity: float = 2.0,
    max_complementary_sensitivity: float = 1.5,
    material_range: tuple[float, float] = (1.0, 1.0),
    dead_time_range_s: tuple[float, float] | None = None,
    start: dict[str, float] | None = None,
    progress: Callable[[str], None] | None = None,
    objective: Objective = "iae",
    horizon_s: float = HORIZON_S,
    radial_depths_mm: tuple[float, ...] | None = None,
) -> RobustTuneResult:
    """Tune ``kp_per_N``, ``ki_per_N_s`` (and ``dob_tau_s`` of ``dob_pi``) (module docstring).

    Parameters
    ----------
    scenario : Scenario
        Kind ``pi`` or ``dob_pi``; its values (designed gains if unset) are the start.
    max_sensitivity, max_complementary_sensitivity : float
        ``Ms``, ``Mt`` [-], > 1.
    material_range : (float, float)
        Multipliers of the table gains covered [-].
    dead_time_range_s : (float, float), optional
        Dead times covered [s] (default the scenario's +-20 %).
    start : dict, optional
        Start values of the tuned keys (default: the scenario's).
    progress : callable, optional
        Receives one line per stage.
    objective : {"iae", "itae", "ise"}
        Step cost minimised (:mod:`acc.design.step_costs`).
    horizon_s : float
        Horizon of the step responses [s].
    radial_depths_mm : tuple of float, optional
        Depths of the plant set [mm] (default: every table row).

    Raises
    ------
    NotTunableError
        Another controller kind.
    InfeasibleTuningError
        IPOPT finds no point meeting the constraints, or the result fails the check.
    """
    import casadi as ca

    t0 = time.perf_counter()
    say = progress or (lambda _line: None)
    kind = scenario.controller.kind
    if kind not in ("pi", "dob_pi"):
        raise NotTunableError(
            f"the casadi tuner covers kinds pi and dob_pi, not {kind!r} (use --method nelder-mead)"
        )
    if not (max_sensitivity > 1 and max_complementary_sensitivity > 1):
        raise ValueError("Ms and Mt must be > 1")
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    observer = kind == "dob_pi"
    keys = ["kp_per_N", "ki_per_N_s"] + (["dob_tau_s"] if observer else [])
    nominal = loop_spec(scenario)
    x_start = dict(start or {})
    for k in keys:
        if k not in x_start:
            value = getattr(scenario.controller, k)
            x_start[k] = float(value if value is not None else getattr(nominal, k))
    start_scenario = scenario.with_values({f"controller.{k}": v for k, v in x_start.items()})
    specs = plant_set(start_scenario, material_range, dead_time_range_s, radial_depths_mm)
    tc = nominal.control_period_s
    steps = int(round(horizon_s / tc))
    omega = np.logspace(
        math.log10(LOWEST_RAD_S), math.log10(0.999 * math.pi / tc), GRID_POINTS,
    )
    rows = len(specs)
    ubg = np.concatenate([
        np.full(rows * GRID_POINTS, max_sensitivity**2),
        np.full(rows * GRID_POINTS, max_complementary_sensitivity**2),
    ])
    x = ca.SX.sym("x", 2)
    x0 = np.log([x_start["kp_per_N"], x_start["ki_per_N_s"]])
    span = math.log(BOUND_FACTOR)
    taus = [x_start["dob_tau_s"] * f for f in TAU_FACTORS] if observer else [None]
    best: tuple | None = None
    objectives: dict[float | None, Any] = {}
    beta = SOFTMAX_SHARPNESS
    kp_ki = ca.MX.sym("g", 2)
    for i, tau in enumerate(taus):
        say(f"program {i + 1}/{len(taus)}: {rows} plants x 2 steps x {steps} periods, "
            f"{rows} x {GRID_POINTS} frequencies"
            + (f", tau = {tau:.4g} s" if tau is not None else ""))
        tau_specs = specs if tau is None else [sp.replace(dob_tau_s=tau) for sp in specs]
        costs = unrolled_costs(tau_specs, steps, objective, kp_ki[0], kp_ki[1])
        cost_of = ca.Function("costs", [kp_ki], [costs])
        build = _loop_functions(tau_specs, tau, omega)
        s2, t2 = build(ca.exp(x[0]), ca.exp(x[1]))
        xm = ca.MX.sym("x", 2)
        scale_p = ca.MX.sym("scale")
        f_expr = ca.logsumexp(beta * cost_of(ca.exp(xm)) / scale_p) / beta * scale_p
        g_fun = ca.Function("g", [x], [ca.vertcat(s2, t2)])
        solver = ca.nlpsol(
            "tune", "ipopt", {"x": xm, "p": scale_p, "f": f_expr, "g": g_fun(xm)},
            {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
             "ipopt.max_iter": MAX_ITERATIONS, "ipopt.tol": 1e-6, "show_eval_warnings": False,
             "ipopt.hessian_approximation": "limited-memory",
             **SOLVER_OPTIONS},
        )
        objectives[tau] = ca.Function("f", [xm, scale_p], [f_expr])
        def worst_unrolled(xv: np.ndarray, c: Any = cost_of) -> float:
            return float(np.max(np.array(c(np.exp(xv)))))

        st_of = ca.Function("st", [x], [s2, t2])
        if tau is None or tau == x_start.get("dob_tau_s"):
            s2_0, t2_0 = (np.array(v).ravel() for v in st_of(x0))
            start_peaks = (float(np.sqrt(s2_0.max())), float(np.sqrt(t2_0.max())))
        for shift in START_SHIFTS:  # the start; if that fails, more cautious gains
            scale = worst_unrolled(x0 - shift)
            scale = scale if math.isfinite(scale) and 0 < scale < MAX_SCALE else 1.0
            x_try = x0 - shift
            for _ in range(2):  # once more, scaled to the optimum's worst cost, if it fell
                sol = solver(x0=x_try, p=scale, lbx=x0 - span, ubx=x0 + span, lbg=-np.inf,
                             ubg=ubg)
                status = solver.stats()["return_status"]
                x_opt = np.array(sol["x"]).ravel()
                worst_opt = worst_unrolled(x_opt)
                if not (status == "Solve_Succeeded" and 0 < worst_opt < scale / 1.5):
                    break
                x_try, scale = x_opt, worst_opt
            s2_opt, t2_opt = (np.array(v).ravel() for v in st_of(x_opt))
            ms, mt = float(np.sqrt(s2_opt.max())), float(np.sqrt(t2_opt.max()))
            ok = status in ("Solve_Succeeded", "Solved_To_Acceptable_Level") and (
                ms <= max_sensitivity * (1 + 1e-6)
                and mt <= max_complementary_sensitivity * (1 + 1e-6)
            )
            values = {"controller.kp_per_N": float(math.exp(x_opt[0])),
                      "controller.ki_per_N_s": float(math.exp(x_opt[1]))}
            if tau is not None:
                values["controller.dob_tau_s"] = float(tau)
            say(f"  start {'as given' if shift == 0 else 'gains / 8'}: IPOPT {status} after "
                f"{solver.stats()['iter_count']} iterations, worst step cost "
                f"{worst_opt:.4g}, max |S| {ms:.3f}, max |T| {mt:.3f}")
            if ok and (best is None or worst_opt < best[0] - 1e-12):
                candidate = scenario.with_values(values)
                stable = all(
                    is_stable(sampled_closed_loop(sp))
                    for sp in plant_set(candidate, material_range, dead_time_range_s,
                                        radial_depths_mm)
                )
                if stable:
                    best = (worst_opt, values, ms, mt, tau, x_opt, scale)
            if ok:
                break
        last = (status, ms, mt)
    if best is None:
        status, ms, mt = last
        raise InfeasibleTuningError(
            f"no gains meet |S| <= {max_sensitivity:g} and |T| <= "
            f"{max_complementary_sensitivity:g} with every sampled loop stable on the {rows} "
            f"plants (IPOPT: {status}; last |S| {ms:.3f}, |T| {mt:.3f})"
        )
    _worst, values, ms, mt, tau_best, x_best, scale = best
    tau_start = taus[TAU_FACTORS.index(1.0)] if observer else None
    objective_value = float(objectives[tau_best](x_best, scale))
    f_start = float(objectives[tau_start](x0, scale))
    tuned = scenario.with_values(values)
    say("checking the sampled loops")
    tuned_specs = plant_set(tuned, material_range, dead_time_range_s,
                            radial_depths_mm)
    before = worst_costs(specs, steps, objective)
    after = worst_costs(tuned_specs, steps, objective)
    return RobustTuneResult(
        scenario=tuned, values=values, initial_cost=before[:2], cost=after[:2],
        initial_objective=f_start, objective=objective_value, max_sensitivity=ms,
        max_complementary_sensitivity=mt, min_phase_margin_deg=after[2],
        initial_max_sensitivity=start_peaks[0],
        initial_max_complementary_sensitivity=start_peaks[1],
        initial_min_phase_margin_deg=before[2], plants=rows, seconds=time.perf_counter() - t0,
        objective_name=objective, horizon_s=steps * tc,
        constraints={"max_sensitivity": max_sensitivity,
                     "max_complementary_sensitivity": max_complementary_sensitivity},
    )


def worst_costs(
    specs: list[LoopSpec], horizon_steps: int, objective: Objective = "iae"
) -> tuple[float, float, float]:
    """Worst reference-step cost, worst disturbance-step cost (:func:`step_costs.true_costs`,
    no smoothing or penalty; ``inf`` if a loop is unstable) and smallest phase margin [deg]
    over a set of loops."""
    ref, dist, pm = 0.0, 0.0, math.inf
    for sp in specs:
        r, d = true_costs(sp, horizon_steps, objective)
        ref, dist = max(ref, r), max(dist, d)
        if math.isfinite(r):
            pm = min(pm, float(control.stability_margins(
                linear.open_loop(sp, omega=MARGIN_OMEGA_RAD_S))[1]))
        else:
            pm = -math.inf
    return ref, dist, pm


__all__ = [
    "InfeasibleTuningError",
    "RobustTuneResult",
    "plant_set",
    "robust_tune",
    "worst_costs",
]
