"""Where the compiled force loop spends its time: a sampling profile by compiled function.

``python benchmarks/profile_engine.py [--scenario FILE] [--kind KIND] [--noise N]
[--runs 2000] [--seconds 30] [--write FILE]``

Runs ``--runs`` runs of the scenario on one thread under Linux ``perf record`` and reports,
for each compiled function of the loop that LLVM did not inline into its caller, its share
of the loop's samples and what that is in nanoseconds per plant step (the share times the CPU
time of the timed batch over its run-steps).  A function inlined into its caller counts as
the caller's (``run_runs`` holds the plant step's elements).

Numba's compiled code has no symbols ``perf`` can read; the profiled process writes
``/tmp/perf-PID.map`` (perf's map of JIT code) from the addresses of the functions of its
compiled loop.  Those are known only for code compiled in that process, so the loop is
compiled afresh into a temporary numba cache (about a minute).  Needs ``perf`` (Debian:
``linux-perf``) and permission to sample (root, or ``kernel.perf_event_paranoid <= 1``).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "experiments" / "kim_chung_2001.toml"

_CHILD = """
import json, os, re, sys, time
import numba
from acc.scenarios.force import load_scenario
from acc.engine.simulate import simulate
from acc.engine import force_loop

changes = {changes!r}
base = load_scenario({scenario!r}).with_values(changes)
simulate([base, base], record_every_steps=None)  # compiled here: its addresses are known
entries = []
for cres in force_loop.run_runs.overloads.values():
    lib = cres.library
    for fn in lib._final_module.functions:
        if not fn.is_declaration:
            address = lib.get_pointer_to_function(fn.name)
            if address:
                entries.append((address, fn.name))
entries.sort()
with open(f"/tmp/perf-{{os.getpid()}}.map", "w") as out:
    for (a, name), (b, _) in zip(entries, entries[1:] + [(entries[-1][0] + 4096, "")]):
        out.write(f"{{a:x}} {{b - a:x}} {{name}}\\n")
numba.set_num_threads(1)
t0 = time.process_time()
simulate([base] * {runs}, record_every_steps=None, threads=1)
seconds = time.process_time() - t0
print(json.dumps({{"cpu_s": seconds, "run_steps": {runs} * base.simulation.max_steps}}))
"""


def demangle(symbol: str) -> str:
    """``module.function`` of a numba-mangled name (``_ZN<len><part>...``), else the name."""
    if not symbol.startswith("_ZN"):
        return symbol
    parts, i = [], 3
    while i < len(symbol) and symbol[i].isdigit():
        j = i
        while symbol[j].isdigit():
            j += 1
        n = int(symbol[i:j])
        parts.append(symbol[j : j + n])
        i = j + n
    return ".".join(parts) if parts else symbol


def profile(scenario: Path, kind: str, noise_N: float, runs: int, seconds: float
            ) -> tuple[list[tuple[str, float, float]], dict[str, float]]:
    """Run the profile; returns rows ``(function, share, ns per plant step)`` (largest
    first) and the timed batch's CPU seconds and run-steps."""
    if shutil.which("perf") is None:
        raise SystemExit("profile_engine: needs Linux perf (Debian: apt-get install linux-perf)")
    code = _CHILD.format(changes=loop_changes(kind, noise_N, seconds), scenario=str(scenario),
                         runs=runs)
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "perf.data"
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba"),
               "PYTHONPATH": str(ROOT),
               "ACC_COMPILE_IN_PROCESS": "1"}  # its addresses known here
        done = subprocess.run(
            ["perf", "record", "-q", "-o", str(data), "--", sys.executable, "-c", code],
            capture_output=True, text=True, env=env, cwd=ROOT)
        if done.returncode != 0:
            raise SystemExit(f"profile_engine: perf record failed: {done.stderr.strip()[-300:]}")
        timed = json.loads(done.stdout.strip().splitlines()[-1])
        report = subprocess.run(
            ["perf", "report", "-i", str(data), "--stdio", "--sort", "sym"],
            capture_output=True, text=True, check=True).stdout
    shares: dict[str, float] = {}
    for line in report.splitlines():
        m = re.match(r"\s*([\d.]+)%\s+\[\.\]\s+(_ZN\S+)", line)
        if m:
            name = demangle(m.group(2))
            shares[name] = shares.get(name, 0.0) + float(m.group(1))
    total = sum(shares.values())
    if total == 0:
        raise SystemExit("profile_engine: no samples in the compiled loop (perf map not read?)")
    ns_per_step = 1e9 * timed["cpu_s"] / timed["run_steps"]
    rows = sorted(((n, s / total, s / total * ns_per_step) for n, s in shares.items()),
                  key=lambda r: -r[1])
    return rows, timed


def loop_arguments(doc: str | None, runs: int) -> argparse.ArgumentParser:
    """A parser with the options of a benchmark of the force loop's batch: ``--kind``,
    ``--noise`` [N], ``--runs`` (default ``runs``), ``--seconds`` [s] and ``--write``."""
    parser = argparse.ArgumentParser(description=(doc or "").splitlines()[0])
    parser.add_argument("--kind", default="dob_adaptive_pi")
    parser.add_argument("--noise", type=float, default=5.0, metavar="N",
                        help="sensor noise [N] (default 5, what the sweeps carry)")
    parser.add_argument("--runs", type=int, default=runs)
    parser.add_argument("--seconds", type=float, default=30.0, help="run length [s]")
    parser.add_argument("--write", type=Path, help="also write the table to this file")
    return parser


def loop_changes(kind: str, noise_N: float, seconds: float) -> dict:
    """The changes to the shipped scenario of a benchmark of the loop's batch: controller
    ``kind``, sensor noise [N], run length [s], three segments of 40 mm."""
    return {"simulation.time_limit_s": seconds, "sensor.noise_std_N": noise_N,
            "controller.kind": kind, "workpiece.segment_length_mm": [40.0, 40.0, 40.0]}


def emit(lines: list[str], write: Path | None) -> None:
    """Print a report's lines, and write them to ``write`` when given."""
    text = "\n".join(lines)
    print(text)
    if write:
        write.write_text(text + "\n", encoding="utf-8")


def main() -> None:
    parser = loop_arguments(__doc__, runs=2000)
    parser.add_argument("--scenario", type=Path, default=SCENARIO)
    args = parser.parse_args()
    rows, timed = profile(args.scenario, args.kind, args.noise, args.runs, args.seconds)
    per_step = 1e9 * timed["cpu_s"] / timed["run_steps"]
    lines = [
        f"{args.kind}, {args.noise:g} N sensor noise, {args.runs} runs of {args.seconds:g} s, "
        f"one thread: {per_step:.1f} ns a plant step",
        "",
        "| compiled function (with what LLVM inlined into it) | share | ns a plant step |",
        "|---|---|---|",
        *(f"| `{n}` | {s:.1%} | {ns:.2f} |" for n, s, ns in rows if s >= 0.001),
        "",
        f"Command: `python benchmarks/profile_engine.py --kind {args.kind} --noise {args.noise:g} "
        f"--runs {args.runs}`",
    ]
    emit(lines, args.write)


if __name__ == "__main__":
    main()
