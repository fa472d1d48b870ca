"""Throughput of the compiled axis loop beside the force loop's, measured in one run.

``python benchmarks/bench_axis.py [--runs 10000] [--write benchmarks/RESULTS_axis.md]``

* axis loop: Peng's servo axis under the lead-lag filter on a ramp with a load step (the
  shipped ``experiments/peng_servo_axis.toml``), ``runs`` identical runs of 1 s at 1 ms,
  metrics only, all cores;
* the same under the LinuxCNC PID, and Briquez's oscillating axis under restricted state
  control (observer source);
* the force loop: ``pi`` on the shipped part, noise-free, the same number of runs;
* the XY table of ``bench_xy.py`` (two elastic axes under PIDs, ``--xy-runs`` runs).

Each figure is the median of three timed calls after a warm-up call (compilation excluded).
Per state: run-steps/s times the continuous states of the plant (:data:`PLANT_STATES`, from
the models' definitions; controllers, delay lines and metrics apart), against the force
loop's, since the loops differ in size: the axis and XY loops advance more states a step.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from bench_report import median_time, write_report

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


#: Continuous states of each loop's plant (the models' docstrings): the force loop's feed
#: velocity, tool position, chip load (the first-order force process) and force-sensor
#: filter (its 0.1 s dead time, a 100-step delay line, apart); the servo axis's armature
#: current, motor speed and table position (``plants/axis/servo_axis.py``); the oscillating
#: axis's speed-loop output, deflection, slide speed and position
#: (``plants/axis/oscillating_axis.py``); two elastic axes of five (``theta_1, omega_1,
#: theta_2, omega_2, i_a``, ``plants/axis/elastic_axis.py``).
PLANT_STATES = {
    "servo axis + lead-lag": 3,
    "servo axis + LinuxCNC pid": 3,
    "oscillating axis + restricted state control (observer)": 4,
    "force loop, pi, noise-free": 4,
    "XY table, PID only": 10,
}


def bench(runs: int, xy_runs: int = 200) -> dict[str, float]:
    from acc.engine.axis_simulate import simulate_axis
    from acc.engine.simulate import simulate
    from acc.scenarios.axis import load_axis_scenario
    from acc.scenarios.force import load_scenario

    out: dict[str, float] = {}
    axis = load_axis_scenario(ROOT / "experiments" / "peng_servo_axis.toml")
    variants = {
        "servo axis + lead-lag": axis,
        "servo axis + LinuxCNC pid": axis.with_values(
            {"position_controller.kind": "pid", "pid.p_gain_per_mm": 50.0,
             "pid.ff1_s_per_mm": 0.0}
        ),
        "oscillating axis + restricted state control (observer)": axis.with_values(
            {"axis.kind": "oscillating", "position_controller.kind": "state_control",
             "state_control.source": "observer", "cutting_load.kind": "none"}
        ),
    }
    for label, sc in variants.items():
        sim = sc.simulation
        steps = round(sim.duration_s / sim.plant_step_s)
        load = sc.cutting_load if sc.cutting_load.kind != "none" else None

        def run(sc=sc, load=load) -> None:  # noqa: ANN001
            simulate_axis(
                sc.axis_params, sc.controller_params, sc.trajectory, load=load,
                duration_s=sc.simulation.duration_s, plant_step_s=sc.simulation.plant_step_s,
                control_period_s=sc.simulation.control_period_s, runs=runs,
                record_every_steps=None,
            )

        out[f"{label}: {runs} runs [run-steps/s]"] = runs * steps / median_time(run)
    force = load_scenario(ROOT / "experiments" / "kim_chung_2001.toml").with_values(
        {"sensor.noise_std_N": 0.0, "simulation.time_limit_s": 1.0,
         "workpiece.segment_length_mm": [100.0, 100.0, 100.0]}
    )
    f_steps = round(1.0 / force.simulation.plant_step_s)

    def force_run() -> None:
        result = simulate([force] * runs, record_every_steps=None)
        assert np.all(np.isnan(result.metrics["machining_time_s"]))  # every run lasts 1 s

    out[f"force loop, pi, noise-free: {runs} runs [run-steps/s]"] = (
        runs * f_steps / median_time(force_run)
    )
    base = out[f"force loop, pi, noise-free: {runs} runs [run-steps/s]"]
    for label in variants:
        out[f"{label} / force loop [-]"] = out[f"{label}: {runs} runs [run-steps/s]"] / base
    from bench_xy import bench as bench_xy

    xy = f"XY table, PID only: {xy_runs} runs [run-steps/s]"
    out[xy] = bench_xy(xy_runs)[xy]
    rates = {label: out[f"{label}: {runs} runs [run-steps/s]"] for label in variants}
    rates["force loop, pi, noise-free"] = base
    rates["XY table, PID only"] = out[xy]
    force_per_state = base * PLANT_STATES["force loop, pi, noise-free"]
    for label, rate in rates.items():
        n = PLANT_STATES[label]
        out[f"{label}: plant state-steps/s ({n} states) [1/s]"] = rate * n
        out[f"{label}: per state / force loop per state [-]"] = rate * n / force_per_state
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--xy-runs", type=int, default=200, help="runs of the XY table")
    ap.add_argument("--write", type=Path, help="also write the report to this Markdown file")
    args = ap.parse_args(argv)
    results = bench(args.runs, args.xy_runs)
    write_report(results, "python benchmarks/bench_axis.py", args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
