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
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import control
import numpy as np
from scipy.optimize import minimize

from acc.design.analysis import is_stable, loop_spec, margins, sampled_closed_loop
from acc.scenario import Scenario
from controllers.registry import OBSERVER_KINDS

#: Horizon of the step response in the cost [s].
HORIZON_S = 3.0
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
    """

    scenario: Scenario
    values: dict[str, float]
    cost_s: float
    initial_cost_s: float
    min_phase_margin_deg: float


def _specs(scenario: Scenario, dead_times: tuple[float, ...]):
    kind = scenario.controller.kind
    out = []
    for d in scenario.force_process.radial_depth_mm:
        for L in dead_times:
            out.append(dataclasses.replace(loop_spec(scenario, d, kind), dead_time_s=L))
    return out


def worst_case(specs, kp: float, ki: float, tau: float | None) -> tuple[float, float]:
    """Worst IAE [s] and smallest phase margin [deg] over the plants for given values."""
    worst, pm_min = 0.0, math.inf
    for s in specs:
        s = dataclasses.replace(s, kp_per_N=kp, ki_per_N_s=ki, dob_tau_s=tau)
        cl = sampled_closed_loop(s)
        if not is_stable(cl):
            return UNSTABLE_COST_S, -math.inf
        n = int(round(HORIZON_S / s.control_period_s))
        resp = control.step_response(cl, T=np.arange(n) * s.control_period_s)
        y = np.asarray(resp.outputs).ravel()
        worst = max(worst, float(np.sum(np.abs(1.0 - y)) * s.control_period_s))
        pm_min = min(pm_min, margins(s).phase_margin_deg)
    return worst, pm_min


def tune(
    scenario: Scenario,
    min_phase_margin_deg: float = 45.0,
    dead_time_range_s: tuple[float, float] | None = None,
    max_evaluations: int = 300,
) -> TuneResult:
    """Tune ``kp_per_N``, ``ki_per_N_s`` (and ``dob_tau_s`` for observer kinds).

    Parameters
    ----------
    scenario : Scenario
        Starting point: its gains (designed if not given) and ``dob_tau_s``.
    min_phase_margin_deg : float
        Constraint on every plant [deg].
    dead_time_range_s : (float, float), optional
        Dead times covered [s]; default the scenario's +-20 %.
    max_evaluations : int
        Budget of cost evaluations.
    """
    L = scenario.feed_drive.dead_time_s
    lo, hi = dead_time_range_s if dead_time_range_s is not None else (0.8 * L, 1.2 * L)
    if not 0 <= lo <= hi:
        raise ValueError(f"dead-time range must satisfy 0 <= min <= max, got {lo}, {hi}")
    specs = _specs(scenario, tuple(sorted({lo, L, hi})))
    has_dob = scenario.controller.kind in OBSERVER_KINDS
    s0 = specs[0]
    x0 = [math.log(s0.kp_per_N), math.log(s0.ki_per_N_s)]
    if has_dob:
        x0.append(math.log(scenario.controller.dob_tau_s))

    def unpack(x):
        return math.exp(x[0]), math.exp(x[1]), math.exp(x[2]) if has_dob else None

    def cost(x):
        iae, pm = worst_case(specs, *unpack(x))
        return iae + PENALTY_PER_DEG_S * max(0.0, min_phase_margin_deg - pm)

    initial = cost(np.array(x0))
    opt = minimize(
        cost,
        np.array(x0),
        method="Nelder-Mead",
        options={"maxfev": max_evaluations, "xatol": 1e-3, "fatol": 1e-5},
    )
    x = opt.x if opt.fun <= initial else np.array(x0)
    kp, ki, tau = unpack(x)
    iae, pm = worst_case(specs, kp, ki, tau)
    values: dict[str, Any] = {"controller.kp_per_N": kp, "controller.ki_per_N_s": ki}
    if has_dob:
        values["controller.dob_tau_s"] = tau
    return TuneResult(scenario.with_values(values), values, iae, initial, pm)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} to TOML")


def scenario_toml(scenario: Scenario) -> str:
    """A scenario as TOML text with every key resolved (reads back to an equal scenario)."""
    lines = []
    for section, values in scenario.to_dict().items():
        lines.append(f"[{section}]")
        lines += [f"{k} = {_toml_value(v)}" for k, v in values.items()]
        lines.append("")
    return "\n".join(lines)


def write_scenario_toml(path: Path, scenario: Scenario) -> None:
    """Write :func:`scenario_toml` to ``path``."""
    Path(path).write_text(scenario_toml(scenario), encoding="utf-8")


__all__ = ["HORIZON_S", "TuneResult", "scenario_toml", "tune", "worst_case", "write_scenario_toml"]
