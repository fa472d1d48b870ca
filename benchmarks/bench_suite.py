"""The test suite's wall time as CI runs it, beside the machine's speed in the same run.

``python benchmarks/bench_suite.py [--rounds 1] [--fresh-clone] [--fast] [--write FILE]``

The suite is CPU-bound on two cores (about two CPU seconds a second of wall time), so its wall
time moves with the shared machine's speed: from one hour to the next the hand-fused loop of
``../shared/bench/limit_kernel.py`` has run at 6e7 to 1.15e8 run-steps/s, and the suite with
it.  Each round therefore measures, in this order: the hand-fused loop (4000 noise-free runs
of 30 s, 2 threads, a fresh process), the README's test command (the second command of its
first code block, which ``.ci/run`` calls), then the hand-fused loop again.  Reported per
round: the wall time and the CPU time (user + system) of the suite's process tree, the two
hand-fused figures, and the wall time scaled to a machine where the hand-fused loop runs at
``--reference-rate`` (1.1e8 run-steps/s, this machine's usual figure in a quiet hour: the
wall time times the round's mean hand-fused figure over the reference).

``--fresh-clone``: as CI runs it, on a ``git clone`` of the committed tree (uncommitted changes
are not measured) with an empty numba cache, the clone first on the path: the install's
``python3 -m acc compile`` (timed, reported apart), then the suite.  Without it the suite runs
on this checkout with its cache as it is.  ``--fast``: also the README's fast subset
(``python3 -m pytest -q -m "not slow"``, one worker).
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_cli import cpu_children, finish_report  # noqa: E402
from bench_sweep_limit import hand_fused  # noqa: E402

#: The README's fast subset (its text names this command).
FAST = [sys.executable, "-m", "pytest", "-q", "-m", "not slow", "-p", "no:cacheprovider"]
#: pytest's last line: ``1213 passed, 2 skipped in 190.32s (0:03:10)``.
_SUMMARY = re.compile(r"^=*\s*(\d+ passed.*) in [\d.]+s")


def readme_test_command(root: Path = ROOT) -> list[str]:
    """The README's test command (the second line of its first ``bash`` block) as an argument
    list, its environment assignments dropped (see :func:`readme_test_env`), ``python3``
    replaced by this interpreter."""
    words = shlex.split(_readme_commands(root)[1])
    words = [w for w in words if not re.match(r"^[A-Z_]+=", w)]
    if words[0].startswith("python"):
        words[0] = sys.executable
    return [*words, "-p", "no:cacheprovider"]


def readme_test_env(root: Path = ROOT) -> dict[str, str]:
    """The environment assignments at the start of the README's test command."""
    out: dict[str, str] = {}
    for word in shlex.split(_readme_commands(root)[1]):
        m = re.match(r"^([A-Z_]+)=(.*)$", word)
        if not m:
            break
        out[m.group(1)] = m.group(2)
    return out


def _readme_commands(root: Path) -> list[str]:
    text = (root / "README.md").read_text(encoding="utf-8")
    block = re.search(r"```bash\n(.*?)```", text, re.S)
    if block is None:
        raise SystemExit("bench_suite: the README has no bash block")
    return [line for line in block.group(1).splitlines() if line.strip()]


def timed(cmd: list[str], cwd: Path, env: dict[str, str]) -> tuple[float, float, str]:
    """Wall and CPU time [s] of ``cmd`` (its process tree) and its last output line; a failing
    command stops the benchmark with its output's tail."""
    c0, t0 = cpu_children(), time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, cpu_children() - c0
    if done.returncode != 0:
        raise SystemExit(f"bench_suite: {' '.join(cmd)} exited {done.returncode}:\n"
                         + (done.stdout + done.stderr)[-3000:])
    last = done.stdout.strip().splitlines()[-1] if done.stdout.strip() else ""
    return wall, cpu, last


def fresh_clone(work: Path) -> Path:
    """A ``git clone`` of this checkout's committed tree under ``work``."""
    dest = work / "clone"
    subprocess.run(["git", "clone", "-q", "--no-hardlinks", str(ROOT), str(dest)], check=True)
    return dest


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=1, help="rounds (default 1)")
    ap.add_argument("--fresh-clone", action="store_true",
                    help="a git clone with an empty numba cache, compiled as the install does")
    ap.add_argument("--fast", action="store_true", help="also the fast subset, one worker")
    ap.add_argument("--reference-rate", type=float, default=1.1e8,
                    help="hand-fused run-steps/s the scaled wall time refers to")
    ap.add_argument("--write", type=Path, help="also write the report to this Markdown file")
    args = ap.parse_args(argv)
    if args.rounds < 1:
        ap.error("--rounds must be >= 1")

    lines = ["| round | hand-fused before, after [run-steps/s] | what | tests | wall [s] | "
             "CPU [s] | CPU / wall | wall scaled to "
             f"{args.reference_rate:.3g} run-steps/s [s] |",
             "|---|---|---|---|---|---|---|---|"]
    load_before = os.getloadavg()[0]
    scaled: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory(prefix="bench_suite_") as tmp:
        for rnd in range(1, args.rounds + 1):
            tree = fresh_clone(Path(tmp) / str(rnd)) if args.fresh_clone else ROOT
            env = {**os.environ, **readme_test_env(tree)}
            if args.fresh_clone:
                env["PYTHONPATH"] = str(tree)
            before = hand_fused()
            rows: list[tuple[str, float, float, str]] = []
            if args.fresh_clone:
                wall, cpu, _ = timed([sys.executable, "-m", "acc", "compile", "-q"], tree, env)
                rows.append(("`acc compile` (the install's)", wall, cpu, ""))
            wall, cpu, last = timed(readme_test_command(tree), tree, env)
            rows.append(("the README's test command", wall, cpu, last))
            if args.fast:
                wall, cpu, last = timed(FAST, tree, env)
                rows.append(("the fast subset, one worker", wall, cpu, last))
            after = hand_fused()
            rate = 0.5 * (before + after)
            for what, wall, cpu, last in rows:
                m = _SUMMARY.match(last)
                s = wall * rate / args.reference_rate
                scaled.setdefault(what, []).append(s)
                lines.append(f"| {rnd} | {before:.3g}, {after:.3g} | {what} | "
                             f"{m.group(1) if m else ''} | {wall:.1f} | {cpu:.1f} | "
                             f"{cpu / wall:.2f} | {s:.1f} |")
                print(lines[-1], flush=True)
    if args.rounds > 1:
        lines.append("")
        lines.extend(f"Median scaled wall time, {what}: {statistics.median(v):.1f} s."
                     for what, v in scaled.items())
    where = "a fresh clone, empty numba cache. " if args.fresh_clone else "this checkout. "
    return finish_report(lines, "bench_suite.py", argv, (load_before, os.getloadavg()[0]),
                         args.write, note=f"On {where}")


if __name__ == "__main__":
    raise SystemExit(main())
