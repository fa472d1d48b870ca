"""Benchmark of ``acc sweep``'s worker default and memory: 1 worker (in-process) against 2.

Run on demand (never in the test suite)::

    python benchmarks/bench_sweep_workers.py                     # 1e4 and 1e5 runs
    python benchmarks/bench_sweep_workers.py --runs 10000 --write benchmarks/RESULTS_sweep.md

Each configuration is ``acc sweep`` in a subprocess (imports included) of the same campaign:
``dob_adaptive_pi`` on Kim & Chung's scenario, runs of 5 s, random hardness and sensor noise,
metrics only, chunks of 500 runs.  Reported side by side: wall time, the parent's peak
resident memory, and the peak of the whole process tree (PSS: pages the forked workers share
with the parent counted once), sampled every 0.2 s.  The configurations alternate within each
repeat; the figures are medians.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_report import tree_memory_bytes, write_report  # noqa: E402

CAMPAIGN = """
[campaign]
name = "workers"
base = "{scenario}"
seed = 1
samples_per_point = {runs}
chunk_runs = 500

[set]
simulation.time_limit_s = 5.0
controller.kind = "dob_adaptive_pi"

[random]
force_process.gain_multiplier = {{ dist = "uniform", low = 0.8, high = 1.25 }}
sensor.noise_std_N = {{ dist = "uniform", low = 0.0, high = 10.0 }}
"""


def sweep(runs: int, workers: int) -> tuple[float, float, float]:
    """One ``acc sweep``: (wall [s], parent peak RSS [MiB], tree peak PSS [MiB])."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "c.toml"
        scenario = ROOT / "experiments" / "kim_chung_2001.toml"
        path.write_text(CAMPAIGN.format(scenario=scenario, runs=runs), encoding="utf-8")
        cmd = [sys.executable, "-m", "acc", "sweep", str(path), "--out", str(Path(d) / "o"),
               "--workers", str(workers), "--no-progress", "--no-figures"]
        peak = [0, 0]
        stop = threading.Event()
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd)

        def sample() -> None:
            while not stop.is_set():
                parent, _, tree = tree_memory_bytes(proc.pid)
                peak[0], peak[1] = max(peak[0], parent), max(peak[1], tree)
                time.sleep(0.2)

        sampler = threading.Thread(target=sample)
        sampler.start()
        status = proc.wait()
        seconds = time.perf_counter() - t0
        stop.set()
        sampler.join()
        if status != 0:
            raise RuntimeError(f"acc sweep exited with {status}")
    return seconds, peak[0] / 2**20, peak[1] / 2**20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--write", type=Path)
    args = parser.parse_args()
    results: dict[str, float] = {}
    for runs in args.runs:
        got: dict[int, list[tuple[float, float, float]]] = {1: [], 2: []}
        for _ in range(args.repeats):
            for workers in (1, 2):
                got[workers].append(sweep(runs, workers))
        for workers, rows in got.items():
            wall, parent, tree = (statistics.median(r[i] for r in rows) for i in range(3))
            results[f"{runs} runs, {workers} worker(s): wall [s]"] = wall
            results[f"{runs} runs, {workers} worker(s): parent peak RSS [MiB]"] = parent
            results[f"{runs} runs, {workers} worker(s): tree peak PSS [MiB]"] = tree
        results[f"{runs} runs: wall 1 worker / 2 workers"] = (
            results[f"{runs} runs, 1 worker(s): wall [s]"]
            / results[f"{runs} runs, 2 worker(s): wall [s]"])
        results[f"{runs} runs: tree peak PSS 2 workers / 1 worker"] = (
            results[f"{runs} runs, 2 worker(s): tree peak PSS [MiB]"]
            / results[f"{runs} runs, 1 worker(s): tree peak PSS [MiB]"])
    command = "python benchmarks/bench_sweep_workers.py --runs " + " ".join(map(str, args.runs))
    print(write_report(results, command, args.write))


if __name__ == "__main__":
    main()
