"""Throughput of the compiled XY-table loop (two elastic axes, two PIDs, the CEC).

``python benchmarks/bench_xy.py [--runs 1000] [--write benchmarks/RESULTS_xy.md]``

The E1-2 circle of ``experiments/reproduce_lacerda_belo.py`` (Ø40 mm at 10 m/min, 0.754 s at
a 0.1 ms plant step, 1 ms controller) with Coulomb friction, the constant-angle cutting
force and CEC-(16); ``runs`` runs with the y carriage mass swept per run, metrics only, all
cores.  A run-step is one plant step of both axes.  Each figure is the median of three timed
calls after a warm-up call (compilation excluded).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from bench_report import median_time, write_report

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def bench(runs: int) -> dict[str, float]:
    from dataclasses import replace

    from acc.engine.xy_simulate import XYReference, simulate_xy
    from controllers.axis.pid import AxisPIDParams
    from controllers.contouring.cross_coupled import CrossCoupledParams
    from controllers.contouring.interpolator import PathParams, interpolate
    from plants.axis.constant_angle_force import ConstantAngleForceParams
    from plants.axis.elastic_axis import xy_table_defaults

    dt = 1e-4
    path = interpolate(PathParams(kind="circle", radius_mm=20.0, feed_mm_s=10000 / 60,
                                  direction="ccw"), dt)
    ref = XYReference.from_path(path)
    speed = np.hypot(ref.velocity_x_mm_s, ref.velocity_y_mm_s)
    fx, fy = ConstantAngleForceParams(100.0, 30.0).loads(ref.tangent_angle_rad, speed)
    ax, ay = xy_table_defaults()
    ys = [replace(ay, carriage_mass_kg=m) for m in np.linspace(40.0, 80.0, runs)]
    pid = AxisPIDParams(p_gain_per_mm=3.0, i_gain_per_mm_s=50.0, d_gain_s_per_mm=0.01,
                        max_output=10.0)
    out: dict[str, float] = {}
    for label, cec in (("PID only", None),
                       ("PID + CEC-16", CrossCoupledParams(kp_V_per_mm=2.0))):
        def run(cec=cec) -> None:  # noqa: ANN001
            simulate_xy(ax, ys, pid, pid, ref, cec=cec, load_x_N=fx, load_y_N=fy,
                        plant_step_s=dt, record_every_steps=None)

        out[f"XY table, {label}: {runs} runs [run-steps/s]"] = (
            runs * ref.samples / median_time(run))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--write", type=Path)
    args = ap.parse_args(argv)
    res = bench(args.runs)
    write_report(res, f"python benchmarks/bench_xy.py --runs {args.runs}", args.write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
