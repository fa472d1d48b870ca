"""Worst-case tuning of the PI gains (and the Q-filter ``tau``) of a scenario's loop.

Problem.  Over every table depth and a dead-time range (three values: min, nominal, max),
minimise the worst integral absolute error of the sampled closed loop's response to a unit
reference step over :data:`HORIZON_S`,

.. math:: J = \\max_{d, L} \\sum_k |1 - y_{d,L}[k]|\\, T_c  \\quad [s],

subject to a minimum phase margin (exact delay, :func:`acc.design.analysis.margins`) and to
closed-loop stability on every one of those plants.  The loop is the one the simulator
runs (:func:`acc.design.analysis.sampled_closed_loop`), linear, clamps inactive.

Solver.  ``scipy.optimize.minimize`` (Nelder-Mead) on the logarithms of ``kp``, ``ki`` (and
``tau``), with the constraints as a penalty; the cost is a max of simulated responses,
non-smooth and without symbolic form, so casadi's automatic differentiation adds nothing.

Cost of an evaluation.  The plants' loops are assembled from cached plant and observer blocks
(:func:`acc.design.linear.connect`), their step responses run in one batched recursion
(:func:`step_responses`) and only the phase margin is computed
(:func:`acc.design.analysis.phase_margin`): some 20-50 ms for the shipped nine plants, where
python-control's interconnect, step response and full margins took over a second.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import control
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from acc.design.analysis import is_stable, loop_spec, phase_margin, sampled_closed_loop
from acc.scenarios.force import Scenario, ScenarioError
from controllers.linear_loop import LoopSpec
from controllers.registry import controller_kind

#: Horizon of the step response in the cost [s].
HORIZON_S = 3.0
#: Least time between two progress lines [s].
PROGRESS_INTERVAL_S = 2.0
#: Penalty per degree of phase-margin shortfall, and for an unstable plant [s].
PENALTY_PER_DEG_S = 0.1
UNSTABLE_COST_S = 1e3


@dataclass(frozen=True)
class TuneResult:
    """Outcome of :func:`tune`.

    Attributes
    ----------
    scenario : Scenario
        The scenario with the tuned values.
    values : dict of str to float
        Tuned ``controller.*`` keys.
    cost_s, initial_cost_s : float
        Worst-case IAE after and before tuning [s] (per unit reference).
    min_phase_margin_deg : float
        Smallest phase margin over the plants at the tuned values [deg].
    evaluations : int
        Cost evaluations spent (the start included).
    """

    scenario: Scenario
    values: dict[str, float]
    cost_s: float
    initial_cost_s: float
    min_phase_margin_deg: float
    evaluations: int = 0


class NotTunableError(ValueError):
    """A controller kind that ``acc tune`` cannot tune (no linear model or no tunables)."""


def _specs(scenario: Scenario, dead_times: tuple[float, ...]) -> list[LoopSpec]:
    """The scenario's loop on every table depth and dead time."""
    out = []
    for d in scenario.force_process.radial_depth_mm:
        spec = loop_spec(scenario, d)
        for L in dead_times:
            out.append(spec.replace(dead_time_s=L))
    return out


def step_responses(loops: list[control.StateSpace], steps: int) -> NDArray[np.float64]:
    """Unit-step responses of discrete SISO systems from rest, all in one recursion.

    ``y[k] = C x[k] + D``, ``x[k + 1] = A x[k] + B`` (what :func:`control.step_response`
    gives on ``T = k T_c``), the systems padded with inert states to one size so that every
    step is one batched product.

    Parameters
    ----------
    loops : list of control.StateSpace
        One input and one output each.
    steps : int

    Returns
    -------
    ndarray, shape (len(loops), steps)
    """
    n = max((cl.nstates for cl in loops), default=0)
    A = np.zeros((len(loops), n, n))
    B = np.zeros((len(loops), n))
    C = np.zeros((len(loops), n))
    D = np.zeros(len(loops))
    for i, cl in enumerate(loops):
        m = cl.nstates
        A[i, :m, :m] = cl.A
        B[i, :m] = np.asarray(cl.B)[:, 0]
        C[i, :m] = np.asarray(cl.C)[0]
        D[i] = np.asarray(cl.D)[0, 0]
    x = np.zeros((len(loops), n))
    y = np.empty((len(loops), steps))
    for k in range(steps):
        y[:, k] = np.einsum("pi,pi->p", C, x) + D
        x = np.einsum("pij,pj->pi", A, x) + B
    return y


def worst_case(specs: list[LoopSpec]) -> tuple[float, float]:
    """Worst IAE [s] and smallest phase margin [deg] over a set of loops (inf and -inf if
    one is unstable).

    The IAE of each loop's reference step over :data:`HORIZON_S` (:func:`step_responses`
    of the sampled loops, all plants in one recursion); the phase margin of
    :func:`acc.design.analysis.phase_margin`.
    """
    if not specs:
        return 0.0, math.inf
    loops = []
    for s in specs:
        cl = sampled_closed_loop(s)
        if not is_stable(cl):
            return UNSTABLE_COST_S, -math.inf
        loops.append(cl)
    tc = specs[0].control_period_s
    if any(s.control_period_s != tc for s in specs):
        raise ValueError("the loops of one evaluation share a control period")
    y = step_responses(loops, int(round(HORIZON_S / tc)))
    worst = float(np.max(np.sum(np.abs(1.0 - y), axis=1)) * tc)
    return worst, min(phase_margin(s) for s in specs)


def tunable_start(scenario: Scenario) -> dict[str, float]:
    """The kind's tunable ``[controller]`` keys and their start values.

    A key the scenario leaves unset (e.g. designed PI gains) starts from the field of the
    same name of the kind's linear loop.

    Raises
    ------
    NotTunableError
        The kind has no linear model or declares no tunable keys.
    """
    kind = controller_kind(scenario.controller.kind)
    if kind.linear_loop is None or not kind.tunables:
        raise NotTunableError(
            f"controller kind {kind.name!r} cannot be tuned (it registers "
            f"{'no linear model' if kind.linear_loop is None else 'no tunable keys'})"
        )
    spec = loop_spec(scenario)
    start = {}
    for key in kind.tunables:
        value = getattr(scenario.controller, key)
        start[key] = float(value if value is not None else getattr(spec, key))
    return start


def tune(
    scenario: Scenario,
    min_phase_margin_deg: float = 45.0,
    dead_time_range_s: tuple[float, float] | None = None,
    max_evaluations: int = 300,
    progress: Callable[[str], None] | None = None,
) -> TuneResult:
    """Tune the kind's tunable keys (e.g. ``kp_per_N``, ``ki_per_N_s``, ``dob_tau_s``).

    Parameters
    ----------
    scenario : Scenario
        Starting point: its values (designed gains if not given).
    min_phase_margin_deg : float
        Constraint on every plant [deg].
    dead_time_range_s : (float, float), optional
        Dead times covered [s]; default the ``[design]`` range
        (:meth:`plants.design_set.DesignSet.dead_times_s` of the nominal dead time).
    max_evaluations : int
        Budget of cost evaluations.
    progress : callable, optional
        Receives a line stating the budget, then one at most every
        :data:`PROGRESS_INTERVAL_S`: evaluations done / budget, best cost so far [s] (IAE
        plus the phase-margin penalty) and elapsed time [s].
    """
    L = scenario.feed_drive.dead_time_s
    lo, hi = dead_time_range_s if dead_time_range_s is not None else (
        scenario.design.dead_times_s(scenario.nominal_plant.dead_time_s))
    if not 0 <= lo <= hi:
        raise ValueError(f"dead-time range must satisfy 0 <= min <= max, got {lo}, {hi}")
    dead_times = tuple(sorted({lo, L, hi}))
    start = tunable_start(scenario)
    keys = list(start)
    x0 = np.log([start[k] for k in keys])

    def candidate(x: NDArray) -> Scenario:
        return scenario.with_values(
            {f"controller.{k}": float(math.exp(v)) for k, v in zip(keys, x, strict=True)}
        )

    say = progress or (lambda _line: None)
    t0 = time.perf_counter()
    seen = {"evaluations": 0, "best": math.inf, "said": t0}
    plants = len(scenario.force_process.radial_depth_mm) * len(dead_times)
    say(f"Nelder-Mead on {', '.join(keys)}: budget {max_evaluations} evaluations of the "
        f"worst step IAE over {plants} plants")

    def cost(x: NDArray) -> float:
        try:
            trial = candidate(x)
        except ScenarioError:  # a step outside the keys' accepted values: never chosen
            value = math.inf
        else:
            iae, pm = worst_case(_specs(trial, dead_times))
            value = iae + PENALTY_PER_DEG_S * max(0.0, min_phase_margin_deg - pm)
        seen["evaluations"] += 1
        seen["best"] = min(seen["best"], value)
        now = time.perf_counter()
        if now - seen["said"] >= PROGRESS_INTERVAL_S:
            seen["said"] = now
            say(f"evaluation {seen['evaluations']}/{max_evaluations}, best cost "
                f"{seen['best']:.4f} s, {now - t0:.0f} s elapsed")
        return value

    initial = cost(x0)
    opt = minimize(
        cost, x0, method="Nelder-Mead",
        options={"maxfev": max_evaluations, "xatol": 1e-3, "fatol": 1e-5},
    )
    x = opt.x if opt.fun <= initial else x0
    best = candidate(x)
    iae, pm = worst_case(_specs(best, dead_times))
    values = {f"controller.{k}": float(math.exp(v)) for k, v in zip(keys, x, strict=True)}
    return TuneResult(best, values, iae, initial, pm, seen["evaluations"])


def scenario_toml(scenario: Scenario, comment: str = "") -> str:
    """A scenario as TOML text with every key resolved (reads back to an equal scenario).

    Written by ``tomli_w``; ``comment`` (one or more lines) goes on top as ``#`` lines.
    """
    import tomli_w

    head = "".join(f"# {line}\n" for line in comment.splitlines())
    return head + tomli_w.dumps(scenario.to_dict())


def write_scenario_toml(path: Path, scenario: Scenario, comment: str = "") -> None:
    """Write :func:`scenario_toml` to ``path`` (a temporary file renamed: all or nothing)."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.tmp")
    try:
        tmp.write_text(scenario_toml(scenario, comment), encoding="utf-8")
        tmp.replace(p)
    finally:
        tmp.unlink(missing_ok=True)


__all__ = [
    "HORIZON_S",
    "NotTunableError",
    "TuneResult",
    "scenario_toml",
    "step_responses",
    "tunable_start",
    "tune",
    "worst_case",
    "write_scenario_toml",
]
