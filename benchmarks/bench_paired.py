"""The compiled loop's time a plant step in this tree against a baseline tree, in short trials
that alternate between the two: a change of a few per cent measured on a machine whose speed
moves by more than that within minutes.

``python benchmarks/bench_paired.py --baseline DIR [--kind KIND] [--noise N]
[--estimator rls] [--runs 40] [--seconds 30] [--pairs 20] [--write FILE]``

Two worker processes, one per tree (``PYTHONPATH``), load the loop once (compiling it into
the tree's numba cache if needed) and then simulate the same batch of ``--runs`` runs
(``--seconds`` each) on one thread whenever asked.  The trials alternate A, B, A, B, ...
(every other pair as B, A, so that neither tree always goes first), and each pair gives the
ratio of B's time to A's; the median ratio and its quartiles are reported with each tree's
median time.  A pair spans a second or two, so the machine's speed changes little within it,
while one long run of each tree (``bench_loop.py --baseline``) can land in different hours.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "experiments" / "kim_chung_2001.toml"
sys.path.insert(0, str(ROOT / "benchmarks"))

from profile_engine import emit, loop_arguments, loop_changes  # noqa: E402

_WORKER = """
import json, sys, time
import numba
from acc.scenarios.force import load_scenario
from acc.engine.simulate import simulate

base = load_scenario({scenario!r}).with_values({changes!r})
runs = [base.with_values({{"simulation.seed": i}}) for i in range({runs})]
numba.set_num_threads(1)
simulate(runs[:2], record_every_steps=None, threads=1)
print("ready", flush=True)
for _ in sys.stdin:
    t0 = time.perf_counter()
    simulate(runs, record_every_steps=None, threads=1)
    print(json.dumps((time.perf_counter() - t0) / ({runs} * base.simulation.max_steps) * 1e9),
          flush=True)
"""


class _Worker:
    """A process of one tree that times the batch on request [ns a plant step]."""

    def __init__(self, tree: Path, changes: dict, runs: int) -> None:
        code = _WORKER.format(scenario=str(SCENARIO), changes=changes, runs=runs)
        env = {**os.environ, "PYTHONPATH": str(tree)}
        self.proc = subprocess.Popen([sys.executable, "-c", code], cwd=tree, env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.proc.stdin is not None and self.proc.stdout is not None
        if self.proc.stdout.readline().strip() != "ready":
            raise SystemExit(f"bench_paired: the worker of {tree} failed")

    def trial(self) -> float:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write("go\n")
        self.proc.stdin.flush()
        return float(json.loads(self.proc.stdout.readline()))

    def close(self) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        self.proc.wait()


def paired(baseline: Path, changes: dict, runs: int, pairs: int
           ) -> tuple[list[float], list[float], list[float]]:
    """Times [ns a plant step] of the baseline (A) and this tree (B), and B/A per pair."""
    a, b = _Worker(baseline, changes, runs), _Worker(ROOT, changes, runs)
    try:
        ta, tb, ratios = [], [], []
        for i in range(pairs):
            if i % 2:
                y, x = b.trial(), a.trial()
            else:
                x, y = a.trial(), b.trial()
            ta.append(x)
            tb.append(y)
            ratios.append(y / x)
    finally:
        a.close()
        b.close()
    return ta, tb, ratios


def main() -> None:
    parser = loop_arguments(__doc__, runs=40)
    parser.add_argument("--baseline", type=Path, required=True, help="the tree to compare with")
    parser.add_argument("--estimator", help="the adaptive kinds' estimator (default: the kind's)")
    parser.add_argument("--pairs", type=int, default=20)
    args = parser.parse_args()
    changes = loop_changes(args.kind, args.noise, args.seconds)
    if args.estimator:
        changes["controller.estimator"] = args.estimator
    ta, tb, ratios = paired(args.baseline.resolve(), changes, args.runs, args.pairs)
    q1, _, q3 = statistics.quantiles(ratios, n=4)
    what = args.kind + (f", {args.estimator} estimator" if args.estimator else "")
    emit([f"{what}, {args.noise:g} N sensor noise, {args.runs} runs of {args.seconds:g} s a "
          f"trial, one thread, {args.pairs} pairs: baseline {statistics.median(ta):.2f} ns a "
          f"plant step, this tree {statistics.median(tb):.2f}; this tree / baseline "
          f"{statistics.median(ratios):.3f} (quartiles {q1:.3f}-{q3:.3f})"], args.write)


if __name__ == "__main__":
    main()
