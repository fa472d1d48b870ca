"""Time of the casadi tuner on the shipped problem (``acc tune`` defaults), median of runs.

``python benchmarks/bench_tune.py [--repeats 3] [--objective iae]``: ``pi`` (kp, ki; 9 plants:
3 depths x dead time 0.08/0.1/0.12 s; reference and disturbance step unrolled over 3 s) and
``dob_pi`` (kp, ki and a 5-value tau scan), in one process after one warm-up call (imports and
first-call costs excluded), with the result's figures.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--objective", choices=("iae", "itae", "ise"), default="iae")
    args = ap.parse_args(argv)
    from acc.design.robust_tuning import robust_tune
    from acc.scenarios.force import load_scenario

    base = load_scenario(ROOT / "experiments" / "kim_chung_2001.toml")
    name = args.objective.upper()
    print(f"| kind | median time [s] (target 20) | worst reference-step {name} before -> after "
          f"| worst disturbance-step {name} before -> after | max abs(S) | max abs(T) | tuned |")
    print("|---|---|---|---|---|---|---|")
    for kind in ("pi", "dob_pi"):
        sc = base.with_values({"controller.kind": kind})
        robust_tune(sc, objective=args.objective)
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            r = robust_tune(sc, objective=args.objective)
            times.append(time.perf_counter() - t0)
        tuned = ", ".join(f"{k.split('.')[-1]} {v:.4g}" for k, v in r.values.items())
        print(f"| {kind} | {statistics.median(times):.1f} | {r.initial_cost[0]:.3f} -> "
              f"{r.cost[0]:.3f} | {r.initial_cost[1]:.3f} -> {r.cost[1]:.3f} | "
              f"{r.max_sensitivity:.3f} | {r.max_complementary_sensitivity:.3f} | {tuned} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
