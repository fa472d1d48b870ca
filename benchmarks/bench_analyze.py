"""Time of ``acc analyze`` on the shipped scenario, as a user runs it, median of runs.

``python benchmarks/bench_analyze.py [--repeats 5] [--baseline DIR] [--write FILE]``: the
command ``python -m acc analyze experiments/kim_chung_2001.toml --out TMP -q`` in a fresh
process (imports, the table, the corners and the seven figures included), wall time.  With
``--baseline DIR`` (an older source tree, e.g. ``git archive <commit> | tar -x -C DIR``) the
same command on that tree alternates with this tree's, and the largest relative difference
between the two ``analysis.csv`` is reported (same numbers to that tolerance).
"""

from __future__ import annotations

import argparse
import csv
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = Path("experiments") / "kim_chung_2001.toml"


def run_analyze(tree: Path, out: Path) -> float:
    """Wall time [s] of ``acc analyze`` of the shipped scenario on the source tree ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "acc", "analyze", str(SCENARIO), "--out", str(out),
                    "-q"], cwd=tree, env=env, check=True, capture_output=True)
    return time.perf_counter() - t0


def csv_difference(a: Path, b: Path) -> float:
    """Largest relative difference between the numeric cells of two ``analysis.csv``
    (rows and text cells must be equal)."""
    rows_a = list(csv.DictReader(a.open()))
    rows_b = list(csv.DictReader(b.open()))
    assert len(rows_a) == len(rows_b), "different rows"
    worst = 0.0
    for ra, rb in zip(rows_a, rows_b, strict=True):
        assert ra.keys() == rb.keys(), "different columns"
        for key, x in ra.items():
            y = rb[key]
            try:
                fx, fy = float(x), float(y)
            except ValueError:
                assert x == y, (key, x, y)
                continue
            if fx != fy and not (fx != fx and fy != fy):
                worst = max(worst, abs(fx - fy) / max(abs(fx), abs(fy)))
    return worst


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--baseline", type=Path, help="an older source tree, run alternately")
    ap.add_argument("--write", help="also write the report to this Markdown file")
    args = ap.parse_args(argv)
    trees = {"this tree": ROOT, **({"baseline": args.baseline.resolve()} if args.baseline
                                   else {})}
    load = os.getloadavg()
    times: dict[str, list[float]] = {t: [] for t in trees}
    with tempfile.TemporaryDirectory() as d:
        for i in range(args.repeats):
            for label, tree in trees.items():
                times[label].append(run_analyze(tree, Path(d) / f"{label}-{i}"))
        diff = (csv_difference(Path(d) / "this tree-0" / "analysis.csv",
                               Path(d) / "baseline-0" / "analysis.csv")
                if args.baseline else None)
    lines = ["| quantity | value |", "|---|---|"]
    for label, tree in trees.items():
        tag = "" if label == "this tree" else f" ({label}: {tree.name})"
        lines.append(f"| acc analyze of the shipped scenario{tag}, median of {args.repeats} "
                     f"[s] (target 10) | {statistics.median(times[label]):.2f} |")
    if args.baseline:
        ratio = statistics.median(times["baseline"]) / statistics.median(times["this tree"])
        lines.append(f"| baseline / this tree [-] | {ratio:.2f} |")
        lines.append(f"| analysis.csv, largest relative difference to the baseline [-] | "
                     f"{diff:.3g} |")
    lines += [
        "",
        f"Load average before the run: {load[0]:.2f}, after: {os.getloadavg()[0]:.2f} (1 min).",
        f"Machine: {os.cpu_count()} cores, {platform.processor() or platform.machine()}, "
        f"Python {platform.python_version()}.",
        f"Command: `python benchmarks/bench_analyze.py {' '.join(argv or sys.argv[1:])}`",
    ]
    report = "\n".join(lines)
    print(report)
    if args.write:
        Path(args.write).write_text(report + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
