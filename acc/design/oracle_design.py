"""Per-cell oracle designs of the robust design study: what an adaptive law could converge to.

An adaptive PI identifies the plant it cuts and re-designs its gains from the estimate, so at
best it converges to the PI designed with full knowledge of that plant.  A campaign *cell* is
one plant: a table depth x a material multiplier (the disturbance class changes the events,
not the plant).  The oracle designs, per cell:

* ``pi``: the casadi tuner (:func:`acc.design.robust_tuning.robust_tune`, IAE of the reference
  and disturbance steps, ``|S| <= Ms``, ``|T| <= Mt``) restricted to the cell's plant, at the
  exact dead time by default (the oracle knows the plant; the most favourable set, so the
  lowest cost the tuner can reach);
* ``fsp_pi``: the filtered Smith predictor whose delay-free model *is* the cell's plant (what
  ``fsp_adaptive_pi`` converges to), with its PI designed by the delay-free rule at a phase
  margin and a robustness filter time constant, both scanned (the casadi tuner does not cover
  the predictor).

Running the campaign with each run's cell design on the same noise ids gives the oracle's p95
IAE: if it is above the target (70 % of the co-designed fixed PI's p95), no adaptive law of
that structure reaches the target on the campaign, however well it identifies.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from acc.scenarios.force import Scenario

#: A campaign cell: (radial depth [mm], material gain multiplier [-]).
Cell = tuple[float, float]


def cell_of(scenario: Scenario) -> Cell:
    """The cell (depth [mm], material multiplier [-]) of a one-depth run's scenario.

    Raises
    ------
    ValueError
        A part of more than one depth.
    """
    depths = {float(d) for d in scenario.workpiece.radial_depth_mm}
    if len(depths) != 1:
        raise ValueError(f"workpiece.radial_depth_mm: a cell has one depth, got {sorted(depths)}")
    return depths.pop(), float(scenario.force_process.gain_multiplier)


def oracle_pi(
    base: Scenario,
    cell: Cell,
    max_sensitivity: float = 2.0,
    max_complementary_sensitivity: float = 1.5,
    dead_time_range_s: tuple[float, float] | None = None,
    start: dict[str, float] | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict[str, object]:
    """The casadi-tuned PI of one cell's plant: ``{"controller.kind": "pi", kp, ki}``.

    Parameters
    ----------
    base : Scenario
        Any run's scenario (its table, drive, sensor, feed, period); its material multiplier
        and controller are replaced.
    cell : (float, float)
        Depth [mm] (interpolated in the table) and material multiplier [-].
    max_sensitivity, max_complementary_sensitivity : float
        ``Ms``, ``Mt`` [-].
    dead_time_range_s : (float, float), optional
        Dead times of the set [s] (default: the scenario's dead time alone).
    start : dict, optional
        Start ``kp_per_N``, ``ki_per_N_s`` of the tuner (default: the PI designed on the
        nominal plant; the study starts from the co-designed PI, which meets the constraints
        on every cell's plant).
    progress : callable, optional
        Passed to the tuner.

    Raises
    ------
    acc.design.robust_tuning.InfeasibleTuningError
        No PI meets the constraints on the cell's plant.
    """
    from acc.design.robust_tuning import robust_tune

    depth_mm, material = cell
    scn = base.with_values({"controller.kind": "pi", "force_process.gain_multiplier": 1.0})
    dead = base.feed_drive.dead_time_s
    r = robust_tune(
        scn, max_sensitivity, max_complementary_sensitivity,
        material_range=(material, material),
        dead_time_range_s=dead_time_range_s if dead_time_range_s is not None else (dead, dead),
        start=start, radial_depths_mm=(depth_mm,), progress=progress,
    )
    return {"controller.kind": "pi", **r.values}


def oracle_fsp(
    base: Scenario, cell: Cell, phase_margin_deg: float, filter_time_constant_s: float
) -> dict[str, object]:
    """``fsp_pi`` whose delay-free model is the cell's plant (drive, ``K2`` x material,
    ``p2`` at the depth; sensor low-pass modelled), PI by the delay-free rule at
    ``phase_margin_deg`` [deg], robustness filter ``filter_time_constant_s`` [s]: the values
    to set on a run."""
    depth_mm, material = cell
    table = base.with_values({"force_process.gain_multiplier": material})
    k2, p2 = table.force_process.parameters([depth_mm])
    return {
        "controller.kind": "fsp_pi",
        "nominal_plant.k2_N_min_per_mm_s": float(k2[0]),
        "nominal_plant.p2_rad_s": float(p2[0]),
        "controller.design_phase_margin_deg": float(phase_margin_deg),
        "controller.fsp_filter_time_constant_s": float(filter_time_constant_s),
        "controller.fsp_sensor_cutoff_hz": float(base.sensor.lowpass_cutoff_hz),
    }


def per_run_values(run_cells: Sequence[Cell], designs: dict[Cell, dict[str, object]]
                   ) -> list[dict[str, object]]:
    """Each run's values: the design of its cell (``KeyError`` naming a cell without one)."""
    out = []
    for cell in run_cells:
        if cell not in designs:
            raise KeyError(f"no oracle design for the cell {cell}")
        out.append(designs[cell])
    return out


def best_per_cell(run_cells: Sequence[Cell], iae_N_s: ArrayLike, oscillating: ArrayLike
                  ) -> tuple[dict[Cell, int], np.ndarray, np.ndarray]:
    """Per cell, the candidate (row of the arrays) with the lowest mean IAE among those with no
    oscillating run in the cell (all candidates if none), and the runs' IAE and flags with it.

    Parameters
    ----------
    run_cells : sequence of (float, float), length n
    iae_N_s, oscillating : array_like, shape (candidates, n)

    Returns
    -------
    choice : dict of cell to int
    iae_N_s : ndarray, shape (n,)
    oscillating : ndarray of bool, shape (n,)
    """
    iae = np.asarray(iae_N_s, dtype=float)
    osc = np.asarray(oscillating, dtype=bool)
    keys = list(dict.fromkeys(run_cells))
    label = np.array([keys.index(c) for c in run_cells])
    choice: dict[Cell, int] = {}
    out_iae, out_osc = np.empty(iae.shape[1]), np.zeros(iae.shape[1], bool)
    for i, cell in enumerate(keys):
        idx = np.flatnonzero(label == i)
        mean = iae[:, idx].mean(axis=1)
        calm = ~osc[:, idx].any(axis=1)
        pick = int(np.argmin(np.where(calm, mean, np.inf)) if calm.any() else np.argmin(mean))
        choice[cell] = pick
        out_iae[idx], out_osc[idx] = iae[pick, idx], osc[pick, idx]
    return choice, out_iae, out_osc


def tail_summary(iae_N_s: ArrayLike, reference_p95_N_s: float, oscillating: ArrayLike
                 ) -> dict[str, float]:
    """p95 of the runs' IAE [N s], its ratio to a reference p95, and the oscillating runs."""
    iae = np.asarray(iae_N_s, dtype=float)
    p95 = float(np.percentile(iae, 95))
    return {"p95_iae_N_s": p95, "ratio": p95 / reference_p95_N_s,
            "oscillating_runs": int(np.count_nonzero(oscillating))}


__all__ = [
    "Cell",
    "best_per_cell",
    "cell_of",
    "oracle_fsp",
    "oracle_pi",
    "per_run_values",
    "tail_summary",
]
