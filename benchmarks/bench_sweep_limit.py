"""``acc sweep`` end to end against the hand-fused loop, this tree and an older one in one run.

``python benchmarks/bench_sweep_limit.py [--runs 10000] [--rounds 2] [--baseline DIR]
[--write FILE]``

Each round runs, in fresh processes and in this order (the hand-fused loop once more after
the last round, its figure the median of all): the hand-fused numba loop of
``../shared/bench/limit_kernel.py`` (4000 noise-free runs of 30 s, 2 threads: what this
machine can do for the observer + adaptive PI force loop), then ``acc sweep`` of
``bench_loop.py``'s speed campaign (``--runs`` noisy ``dob_adaptive_pi`` runs of 30 s with
random radial and axial depths per segment, metrics only, 2 workers, imports, validation and
the report included) on this tree, then on ``DIR`` (the other way round in every second
round, so that neither tree always runs first after the hand-fused loop).  Throughput is
run-steps per second of
wall time; the ratios are of the medians over the rounds.  The trees are copied first
(``acc``, ``plants``, ``controllers``, ``experiments``), each with its own numba cache filled
by a small sweep before the first round.  The load average (1 min) is reported: the machine
is shared.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_cli import add_tree_args, bench_env, copy_trees, finish_report  # noqa: E402
from bench_loop import LIMIT_KERNEL_DIR, SWEEP_CAMPAIGN  # noqa: E402

SCENARIO = Path("experiments") / "kim_chung_2001.toml"
#: Plant steps of one run of the campaign (30 s at 1 ms).
STEPS = 30_000

_HAND_FUSED = """
import json, sys
sys.path.insert(0, {kernel_dir!r})
import limit_kernel
limit_kernel.bench(2, t_end=0.1)
print(json.dumps(limit_kernel.bench({runs}, t_end=30.0)[0]))
"""


def hand_fused(runs: int = 4000) -> float:
    """Throughput of the hand-fused loop [run-steps/s], in a fresh process."""
    code = _HAND_FUSED.format(kernel_dir=str(LIMIT_KERNEL_DIR), runs=runs)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    return float(json.loads(done.stdout.strip().splitlines()[-1]))


def sweep(tree: Path, cache: Path, work: Path, runs: int) -> tuple[float, float]:
    """Wall time [s] of ``acc sweep`` of the speed campaign with ``runs`` runs on ``tree``,
    and the peak proportional set size of its process tree [bytes] (sampled every 0.2 s;
    pages the forked workers share with the parent counted once)."""
    from bench_report import wait_sampling_memory

    d = Path(tempfile.mkdtemp(dir=work))
    path = d / "sweep.toml"
    path.write_text(SWEEP_CAMPAIGN.format(scenario=tree / SCENARIO, runs=runs),
                    encoding="utf-8")
    env = bench_env(tree, cache)  # bytecode written, as on a user's machine
    t0 = time.perf_counter()
    with (d / "stderr.txt").open("w") as err:
        proc = subprocess.Popen([sys.executable, "-m", "acc", "sweep", str(path), "--out",
                                 str(d / "out"), "--workers", "2", "--no-progress", "-q"],
                                cwd=tree, env=env, stdout=subprocess.DEVNULL, stderr=err)
        _, peak = wait_sampling_memory(proc)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"acc sweep exited with {proc.returncode}: "
                           f"{(d / 'stderr.txt').read_text()[-2000:]}")
    rows = sum(1 for _ in (d / "out" / "summary.csv").open()) - 1
    assert rows == runs, (rows, runs)
    shutil.rmtree(d, ignore_errors=True)
    return seconds, peak


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10_000, help="runs of the sweep")
    ap.add_argument("--rounds", type=int, default=2)
    add_tree_args(ap, "an older source tree, run alternately")
    args = ap.parse_args(argv)
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        w = Path(tmp)
        trees = copy_trees(args.baseline, w)
        for label, tree in trees.items():  # compile or load once, outside the timing
            sweep(tree, w / f"cache-{label}", w, 4)
        limit: list[float] = []
        rates: dict[str, list[float]] = {t: [] for t in trees}
        memory: dict[str, list[float]] = {t: [] for t in trees}
        for i in range(args.rounds):
            limit.append(hand_fused())
            for label, tree in list(trees.items())[:: -1 if i % 2 else 1]:
                seconds, peak = sweep(tree, w / f"cache-{label}", w, args.runs)
                rates[label].append(args.runs * STEPS / seconds)
                memory[label].append(peak)
        limit.append(hand_fused())  # after the last round too: one figure can be an outlier
    load_after = os.getloadavg()[0]
    hf = statistics.median(limit)
    lines = ["| quantity | value |", "|---|---|",
             f"| hand-fused numba loop (limit_kernel.py), 4000 runs of 30 s, median of "
             f"{len(limit)} (before each round and after the last; range {min(limit):.3g}-"
             f"{max(limit):.3g}) [run-steps/s] | {hf:.3g} |"]
    for label in trees:
        tag = "" if label == "this tree" else f" ({label}: {args.baseline.name})"
        r = statistics.median(rates[label])
        lines.append(f"| acc sweep of {args.runs} noisy dob_adaptive_pi runs of 30 s, random "
                     f"depths, 2 workers{tag} [run-steps/s] | {r:.3g} |")
        lines.append(f"| acc sweep of {args.runs} runs{tag}: wall time [s] | "
                     f"{args.runs * STEPS / r:.1f} |")
        lines.append(f"| acc sweep{tag} / hand-fused loop [-] | {r / hf:.3f} |")
        lines.append(f"| acc sweep of {args.runs} runs{tag}: peak PSS of the process tree, "
                     f"largest over the rounds [MiB] | {max(memory[label]) / 2**20:.0f} |")
    return finish_report(lines, "bench_sweep_limit.py", argv, (load_before, load_after),
                         args.write, note=f"Medians of {args.rounds} rounds. ")


if __name__ == "__main__":
    raise SystemExit(main())
