"""Where the wall time and the CPU time of ``acc sweep`` go, phase by phase, on this tree.

``python benchmarks/bench_sweep_phases.py [--runs 100000] [--chunks 8] [--write FILE]``

Three measurements, each in a fresh process, on ``bench_loop.py``'s speed campaign (noisy
``dob_adaptive_pi`` runs of 30 s with random radial and axial depths, chunks of 250 runs):

1. ``acc sweep`` of ``--runs`` runs (2 workers, metrics only, figures included) with the
   parent's phases stamped: imports and campaign, building and checking every run (with the
   engine loaded meanwhile), simulating the chunks, and the summary, figures and report;
   its wall time and the CPU time of its process tree.
2. ``--chunks`` chunks of 250 runs simulated one after the other in one process, after one
   chunk that loads the engine, with the CPU time of each part of a chunk: drawing the runs'
   values, building their scenarios, building the loop's records, the compiled loop (and the
   arrays of its result), the summary table and its CSV text; and one run's checks
   (:func:`acc.campaigns.sweep.validate_runs` over the same runs, per run).
3. The hand-fused loop of ``../shared/bench/limit_kernel.py`` (4000 noise-free runs of 30 s,
   2 threads), the figure the ratios of ``bench_sweep_limit.py`` are taken against, before
   the sweep and after the chunks (the mean of the two: the machine is shared, and one
   figure can be an outlier).

The last lines put them together: the compiled loop's rate per core against the hand-fused
loop's, and the Python work a run costs outside the loop (checks, then its chunk's share),
as a part of the sweep's CPU time.  A sweep cannot be faster than its loop; this says how
much of the rest there is to take.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_cli import cpu_children, finish_report  # noqa: E402
from bench_loop import SWEEP_CAMPAIGN  # noqa: E402
from bench_sweep_limit import STEPS, hand_fused  # noqa: E402

SCENARIO = ROOT / "experiments" / "kim_chung_2001.toml"
CHUNK_RUNS = 250

#: ``acc sweep`` in this process with the parent's phases stamped (perf_counter, seconds).
_TIMELINE = """
import json, sys, time
t0 = time.perf_counter()
stamps = {{}}
import acc.campaigns.sweep as sw
from acc.cli.main import main

def stamped(name):
    f = getattr(sw, name)
    def g(*a, **k):
        stamps.setdefault(name + " start", time.perf_counter() - t0)
        try:
            return f(*a, **k)
        finally:
            stamps[name + " end"] = time.perf_counter() - t0
    setattr(sw, name, g)

for name in ("_validate", "assemble_summary"):
    stamped(name)
execute = sw._execute
def chunks(*a, **k):
    stamps["_execute start"] = time.perf_counter() - t0
    yield from execute(*a, **k)
    stamps["_execute end"] = time.perf_counter() - t0
sw._execute = chunks
rc = main(["sweep", {campaign!r}, "--out", {out!r}, "--workers", "2", "--no-progress", "-q"])
if rc:
    sys.exit(f"acc sweep exited with {{rc}}")
print(json.dumps(stamps))
"""

#: ``--chunks`` chunks in one process, CPU time per part of a chunk (process_time, seconds).
_CHUNKS = """
import json, time
import acc.campaigns.sweep as sw
import acc.engine.simulate as sim
from acc.campaigns.campaign import Campaign, load_campaign

campaign = load_campaign({campaign!r})
sw.simulate_chunk(campaign, list(range({size})), True)  # loads the engine
spent = {{}}

def timed(owner, name, key, exclude=()):
    f = getattr(owner, name)
    def g(*a, **k):
        inner = sum(spent.get(x, 0.0) for x in exclude)
        t = time.process_time()
        try:
            return f(*a, **k)
        finally:
            nested = sum(spent.get(x, 0.0) for x in exclude) - inner
            spent[key] = spent.get(key, 0.0) + time.process_time() - t - nested
    setattr(owner, name, g)

timed(Campaign, "values", "values")
timed(Campaign, "scenario", "scenarios", exclude=("values",))
timed(sim, "_group_inputs", "records")
timed(sim, "_simulate_group", "loop", exclude=("records",))
timed(sw, "result_table", "table")
timed(sw, "_csv_text", "csv")
t = time.process_time()
for c in range({chunks}):
    first = {size} * (c + 1)
    sw.simulate_chunk(campaign, list(range(first, first + {size})), True)
spent["chunk"] = time.process_time() - t
runs = {size} * {chunks}
out = {{k: v / runs for k, v in spent.items()}}
t = time.process_time()
sw.validate_runs(campaign, {size}, {size} + runs)
out["checks"] = (time.process_time() - t) / runs
print(json.dumps(out))
"""


def _child(code: str, env: dict[str, str]) -> tuple[dict[str, float], float]:
    """Run ``code`` in a fresh interpreter; its last line's JSON and the CPU time of its
    process tree [s]."""
    before = cpu_children()
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, cwd=ROOT)
    cpu = cpu_children() - before
    if done.returncode != 0:
        raise RuntimeError(f"benchmark child failed: {done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1]), cpu


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100_000, help="runs of the timed sweep")
    ap.add_argument("--chunks", type=int, default=8, help="chunks of 250 runs timed apart")
    ap.add_argument("--write", type=Path, help="also write the table to this file")
    args = ap.parse_args(argv)
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        w = Path(tmp)
        small, big = w / "small.toml", w / "big.toml"
        small.write_text(SWEEP_CAMPAIGN.format(scenario=SCENARIO, runs=4), encoding="utf-8")
        big.write_text(SWEEP_CAMPAIGN.format(scenario=SCENARIO, runs=args.runs),
                       encoding="utf-8")
        # compiled or loaded once, outside the timing
        _child(_TIMELINE.format(campaign=str(small), out=str(w / "warm")), env)
        limit = [hand_fused()]
        t0 = time.perf_counter()
        stamps, sweep_cpu = _child(_TIMELINE.format(campaign=str(big), out=str(w / "out")), env)
        wall = time.perf_counter() - t0
        part = CHUNK_RUNS * (args.chunks + 1)  # the engine's chunk, then the timed ones
        small.write_text(SWEEP_CAMPAIGN.format(scenario=SCENARIO, runs=part), encoding="utf-8")
        per_run, _ = _child(_CHUNKS.format(campaign=str(small), size=CHUNK_RUNS,
                                           chunks=args.chunks), env)
        limit.append(hand_fused())
    load_after = os.getloadavg()[0]
    hf = statistics.median(limit)  # before and after: one figure can be an outlier

    def span(name: str) -> float:
        return stamps[f"{name} end"] - stamps[f"{name} start"]

    us = {k: 1e6 * v for k, v in per_run.items()}
    python_chunk = us["chunk"] - us["loop"]
    python_us = us["checks"] + python_chunk
    loop_ns = 1e3 * us["loop"] / STEPS
    hand_ns = 2e9 / hf  # two threads: a core's nanoseconds per run-step
    ratio = args.runs * STEPS / wall / hf
    lines = [
        "| quantity | value |", "|---|---|",
        f"| acc sweep of {args.runs} runs: wall time, the process's own [s] | {wall:.1f} |",
        f"| of which: imports, campaign [s] | {stamps['_validate start']:.2f} |",
        f"| of which: building and checking every run, the engine loaded meanwhile [s] | "
        f"{span('_validate'):.2f} |",
        f"| of which: simulating the chunks [s] | {span('_execute'):.2f} |",
        f"| of which: summary, figures, report, exit [s] | "
        f"{wall - stamps['_execute end']:.2f} |",
        f"| acc sweep: CPU time of its process tree [s] | {sweep_cpu:.1f} |",
        f"| acc sweep / hand-fused loop (2 threads, {hf:.3g} run-steps/s, the mean of "
        f"{limit[0]:.3g} before and {limit[1]:.3g} after) [-] | {ratio:.3f} |",
        f"| a chunk of {CHUNK_RUNS} runs, CPU per run [us]: all | {us['chunk']:.0f} |",
        f"| of which: values drawn [us] | {us['values']:.1f} |",
        f"| of which: scenarios built [us] | {us['scenarios']:.1f} |",
        f"| of which: the loop's records [us] | {us['records']:.1f} |",
        f"| of which: the compiled loop and its result arrays [us] | {us['loop']:.0f} |",
        f"| of which: the summary table [us] | {us['table']:.1f} |",
        f"| of which: its CSV text [us] | {us['csv']:.1f} |",
        f"| before the sweep: building and checking a run [us] | {us['checks']:.1f} |",
        f"| the compiled loop, one core [ns a run-step] | {loop_ns:.1f} |",
        f"| the hand-fused loop, one core of two [ns a run-step] | {hand_ns:.1f} |",
        f"| hand-fused / compiled loop, per core [-] | {hand_ns / loop_ns:.3f} |",
        f"| Python work a run costs outside the loop (checks + chunk) [us] | {python_us:.0f} |",
        f"| that work as a part of the runs' CPU (loop included) [-] | "
        f"{python_us / (python_us + us['loop']):.3f} |",
    ]
    return finish_report(lines, "bench_sweep_phases.py", argv, (load_before, load_after),
                         args.write)


if __name__ == "__main__":
    raise SystemExit(main())
