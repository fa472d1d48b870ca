"""Time of ``acc tune`` on the shipped problem (its defaults), median of runs.

``python benchmarks/bench_tune.py [--repeats 3] [--objective iae] [--only casadi nelder-mead]
[--baseline DIR] [--baseline-repeats 1] [--write FILE]``:

``casadi``       ``pi`` (kp, ki; 9 plants: 3 depths x dead time 0.08/0.1/0.12 s; reference and
                 disturbance step unrolled over 3 s) and ``dob_pi`` (kp, ki and a 5-value tau
                 scan), in one process after one warm-up call (imports and first-call costs
                 excluded), with the result's figures.
``nelder-mead``  every other tunable kind (``adaptive_pi``, ``dob_adaptive_pi``, ``fsp_pi``,
                 ``fsp_adaptive_pi``): :func:`acc.design.tuning.tune` with its defaults (300
                 evaluations at most, 45 deg, the 9 plants), each run in a fresh process
                 (imports excluded from the time).  With ``--baseline DIR`` (an older source
                 tree, e.g. ``git archive <commit> | tar -x -C DIR``) the same run on that tree
                 alternates with this tree's (``--baseline-repeats`` of them), and the tuned
                 values of the two are compared.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SCENARIO = Path("experiments") / "kim_chung_2001.toml"
NELDER_MEAD_KINDS = ("adaptive_pi", "dob_adaptive_pi", "fsp_pi", "fsp_adaptive_pi")

_PROBE = textwrap.dedent(
    """
    import json, time
    try:
        from acc.scenarios.force import load_scenario
    except ImportError:  # a tree from before acc.scenarios
        from acc.scenario import load_scenario
    from acc.design.tuning import tune
    sc = load_scenario({scenario!r}).with_values({{"controller.kind": {kind!r}}})
    lines = []
    t0 = time.perf_counter()
    r = tune(sc, progress=lines.append)
    seconds = time.perf_counter() - t0
    print(json.dumps({{"seconds": seconds, "evaluations": getattr(r, "evaluations", None),
                      "progress_lines": len(lines), "cost": r.cost_s,
                      "initial": r.initial_cost_s, "pm": r.min_phase_margin_deg,
                      "values": r.values}}))
    """
)


def nelder_mead_probe(tree: Path, kind: str) -> dict:
    """One ``tune`` of ``kind`` on the shipped scenario, in a fresh process on ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    code = _PROBE.format(scenario=str(SCENARIO), kind=kind)
    done = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env,
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def bench_casadi(repeats: int, objective: str) -> list[str]:
    from acc.design.robust_tuning import InfeasibleTuningError, robust_tune
    from acc.scenarios.force import load_scenario

    base = load_scenario(ROOT / SCENARIO)
    name = objective.upper()
    lines = [f"| kind | median time [s] (target 20) | worst reference-step {name} before -> "
             f"after | worst disturbance-step {name} before -> after | max abs(S) | "
             "max abs(T) | tuned |", "|---|---|---|---|---|---|---|"]
    for kind in ("pi", "dob_pi"):
        sc = base.with_values({"controller.kind": kind})
        times = []
        for i in range(repeats + 1):  # the first is a warm-up
            t0 = time.perf_counter()
            try:
                r = robust_tune(sc, objective=objective)
            except InfeasibleTuningError as exc:  # acc tune's exit 1: timed too
                r = exc
            if i:
                times.append(time.perf_counter() - t0)
        if isinstance(r, InfeasibleTuningError):
            lines.append(f"| {kind} | {statistics.median(times):.1f} | refused: {r} | | | | |")
            continue
        tuned = ", ".join(f"{k.split('.')[-1]} {v:.4g}" for k, v in r.values.items())
        lines.append(
            f"| {kind} | {statistics.median(times):.1f} | {r.initial_cost[0]:.3f} -> "
            f"{r.cost[0]:.3f} | {r.initial_cost[1]:.3f} -> {r.cost[1]:.3f} | "
            f"{r.max_sensitivity:.3f} | {r.max_complementary_sensitivity:.3f} | {tuned} |")
    return lines


def bench_nelder_mead(repeats: int, baseline: Path | None, baseline_repeats: int) -> list[str]:
    head = "| kind | median time [s] (target 60) | evaluations | worst step IAE before -> " \
        "after [s] | min PM [deg] | tuned |"
    if baseline:
        head += f" baseline {baseline.name}: median time [s] | baseline / this tree | " \
            "tuned values, largest relative difference |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for kind in NELDER_MEAD_KINDS:
        mine, theirs = [], []
        for i in range(repeats):
            mine.append(nelder_mead_probe(ROOT, kind))
            if baseline and i < baseline_repeats:
                theirs.append(nelder_mead_probe(baseline, kind))
        t = statistics.median(r["seconds"] for r in mine)
        r = mine[-1]
        tuned = ", ".join(f"{k.split('.')[-1]} {v:.4g}" for k, v in r["values"].items())
        row = (f"| {kind} | {t:.1f} | {r['evaluations']} | {r['initial']:.4f} -> "
               f"{r['cost']:.4f} | {r['pm']:.1f} | {tuned} |")
        if baseline:
            tb = statistics.median(x["seconds"] for x in theirs)
            diff = max(abs(v - theirs[-1]["values"][k]) / abs(v) for k, v in r["values"].items())
            row += f" {tb:.1f} | {tb / t:.1f} | {diff:.2g} |"
        lines.append(row)
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--objective", choices=("iae", "itae", "ise"), default="iae")
    ap.add_argument("--only", nargs="+", choices=("casadi", "nelder-mead"),
                    default=["casadi", "nelder-mead"])
    ap.add_argument("--baseline", type=Path, help="nelder-mead: an older source tree too")
    ap.add_argument("--baseline-repeats", type=int, default=1)
    ap.add_argument("--write", help="also write the report to this Markdown file")
    args = ap.parse_args(argv)
    load = os.getloadavg()
    lines: list[str] = []
    if "casadi" in args.only:
        lines += bench_casadi(args.repeats, args.objective) + [""]
    if "nelder-mead" in args.only:
        baseline = args.baseline.resolve() if args.baseline else None
        lines += bench_nelder_mead(args.repeats, baseline, args.baseline_repeats) + [""]
    lines += [
        f"Load average before the run: {load[0]:.2f}, after: {os.getloadavg()[0]:.2f} (1 min).",
        f"Machine: {os.cpu_count()} cores, {platform.processor() or platform.machine()}, "
        f"Python {platform.python_version()}.",
        f"Command: `python benchmarks/bench_tune.py {' '.join(argv or sys.argv[1:])}`",
    ]
    report = "\n".join(lines)
    print(report)
    if args.write:
        Path(args.write).write_text(report + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
