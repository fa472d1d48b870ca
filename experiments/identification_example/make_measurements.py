"""Play acc excite's schedules on the example machine and write the logs acc identify reads.

The machine (``machine.toml``) is simulated by the workbench (``acc.simulate``): the
override schedule becomes feed steps (``[[disturbance]] kind = "feed"``) of the
``"constant"`` controller at the schedule's first override, so the drive sees exactly the
schedule held over each 10 ms update.  Each log has what a CNC and a dynamometer record:

* ``time_s`` and ``override`` (the schedule as played);
* ``feed_velocity_mm_min``: a 17-bit encoder on a 10 mm-pitch screw (0.076 um per count),
  velocity as the backward difference of the counted position over the 1 ms servo period
  (so it lags by half a servo period: ``acc identify --velocity-delay-s 0.0005``);
* ``force_N`` (cutting logs): the simulator's measured force (5 N noise per 1 ms through a
  20 Hz low-pass, ``[sensor]`` of machine.toml).

Usage (from the repository root)::

    acc excite prbs --duration-s 20 --out exc_air
    acc excite feed-steps --out exc_cut
    python experiments/identification_example/make_measurements.py \\
        --air exc_air --cut exc_cut --out experiments/identification_example/data

writes ``air_prbs.csv`` (the drive test, in air) and ``cut_2mm.csv``, ``cut_3mm.csv``,
``cut_4mm.csv`` (one feed-step cut per radial depth, 10 mm axial); every test runs for two
seconds at the schedule's first override before the log starts (a steady feed, the tool
engaged).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import acc
from acc.identify import read_excitation

HERE = Path(__file__).resolve().parent
COUNT_MM = 10.0 / 2**17  # encoder count [mm]
LEAD_S = 2.0  # at the first override before the schedule (steady cut)


def _disturbances(time_s: np.ndarray, override: np.ndarray, feed: float,
                  start_s: float) -> list[dict]:
    """The schedule as feed steps relative to its first override, one per constant stretch."""
    changes = np.flatnonzero(np.diff(override) != 0) + 1
    starts = np.concatenate([[0], changes])
    ends = np.concatenate([changes, [len(override)]])
    out = []
    for i, (a, b) in enumerate(zip(starts, ends, strict=True)):
        if override[a] == override[0]:
            continue
        entry = {"name": f"u{i}", "kind": "feed", "shape": "step",
                 "amplitude_mm_min": float((override[a] - override[0]) * feed),
                 "start_s": round(start_s + float(time_s[a]), 6)}
        if b < len(override):
            entry["end_s"] = round(start_s + float(time_s[b]), 6)
        out.append(entry)
    return out


def play(machine: acc.Scenario, design_dir: Path, radial_depth_mm: float, lead_s: float
         ) -> dict[str, np.ndarray]:
    """Simulate one test; the log's columns on the 10 ms grid, from the schedule's start."""
    design = read_excitation(design_dir)
    feed = machine.controller.programmed_feed_mm_min
    duration = lead_s + design.duration_s
    travel = feed * float(design.override.max()) * duration / 60.0 + 10.0
    if radial_depth_mm > 0:
        part = {"segment_length_mm": [travel], "radial_depth_mm": [radial_depth_mm],
                "axial_depth_mm": [10.0]}
    else:  # air, with a short cut far beyond the travel (a part must cut somewhere)
        part = {"segment_length_mm": [travel, 1.0], "radial_depth_mm": [0.0, 2.0],
                "axial_depth_mm": [10.0, 10.0]}
    scenario = machine.with_values({
        "simulation.time_limit_s": round(duration, 6),
        "controller.constant_override": float(design.override[0]),
        "workpiece.segment_length_mm": part["segment_length_mm"],
        "workpiece.radial_depth_mm": part["radial_depth_mm"],
        "workpiece.axial_depth_mm": part["axial_depth_mm"],
        "disturbance": _disturbances(design.time_s, design.override, feed, lead_s),
    })
    result = acc.simulate(scenario, record_every_steps=1)
    dt = scenario.simulation.plant_step_s
    every = int(round(design.limits.sample_time_s / dt))
    first = int(round(lead_s / dt))
    idx = np.arange(first, first + len(design.time_s) * every, every)
    idx = idx[idx < len(result.time_s)]
    counted = np.round(result.signals["position_mm"][0] / COUNT_MM) * COUNT_MM
    velocity = (counted[idx] - counted[idx - 1]) / dt * 60.0
    log = {"time_s": result.time_s[idx] - lead_s,
           "override": design.override[: len(idx)],
           "feed_velocity_mm_min": velocity}
    if radial_depth_mm > 0:
        log["force_N"] = result.signals["measured_force_N"][0, idx]
    return log


def write_log(path: Path, log: dict[str, np.ndarray]) -> None:
    """CSV with the units in the column names."""
    names = list(log)
    table = np.column_stack([log[n] for n in names])
    np.savetxt(path, table, delimiter=",", header=",".join(names), comments="",
               fmt=["%.2f", "%.4f"] + ["%.2f"] * (len(names) - 2))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--air", required=True, help="acc excite's directory of the drive test")
    parser.add_argument("--cut", required=True, help="acc excite's directory of the cuts")
    parser.add_argument("--out", required=True, help="directory of the logs")
    parser.add_argument("--machine", default=str(HERE / "machine.toml"))
    args = parser.parse_args()
    machine = acc.load_scenario(args.machine)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_log(out / "air_prbs.csv", play(machine, Path(args.air), 0.0, LEAD_S))
    for depth in machine.force_process.radial_depth_mm:
        write_log(out / f"cut_{depth:g}mm.csv", play(machine, Path(args.cut), depth, LEAD_S))
    print(f"wrote {out}/air_prbs.csv and cut_*mm.csv")


if __name__ == "__main__":
    main()
