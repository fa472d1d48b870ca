"""Wall time of ``acc run`` of the shipped scenario as a user runs it: warm, cold, compile-all.

``python benchmarks/bench_cli.py [--repeats 7] [--cold 2] [--compile-all] [--baseline DIR]
[--write FILE]``

* **warm**: ``python -m acc run experiments/kim_chung_2001.toml --out TMP -q`` in a fresh
  process with the numba cache and Python's bytecode (``.pyc``) filled by one earlier run,
  as on a user's machine; median of ``--repeats`` runs;
* **cold**: the same with ``NUMBA_CACHE_DIR`` pointed at a new empty directory each time
  (everything the run needs compiled); median of ``--cold`` runs;
* **compile-all** (``--compile-all``): every built-in controller kind, the geometric force
  model (average and tooth passing) and current sensing simulated once with and once
  without traces in one fresh process on an empty cache (``bench_loop.py``'s probe),
  compile time without the imports; and ``acc compile`` (the same configurations in one
  process per core, imports included) on another empty cache, wall time.

The source trees are copied first (``acc``, ``plants``, ``controllers``, ``experiments``)
and each copy gets its own numba cache, so that an edit in the working tree during the
benchmark neither recompiles nor changes what is measured.  With ``--baseline DIR`` (an
older tree, e.g. ``git archive <commit> | tar -x -C DIR``) the two trees alternate run by
run, and the ratios are of medians taken in the same run; the ``summary.csv`` of the two
must agree.  The load average (1 min) is reported before and after: the machine is shared.
"""

from __future__ import annotations

import argparse
import csv
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = Path("experiments") / "kim_chung_2001.toml"
COPIED = ("acc", "plants", "controllers", "experiments")

_COMPILE_ALL = """
import time
t0 = time.perf_counter()
from acc.scenarios.force import load_scenario
from acc.engine.simulate import simulate
from controllers.registry import controller_kinds
base = load_scenario("experiments/kim_chung_2001.toml").with_values(
    {"simulation.time_limit_s": 0.05})
variants = [base.with_values({"controller.kind": k}) for k in controller_kinds()]
geo = load_scenario("experiments/current_sensing_geometric.toml")
variants.append(geo.with_values({"simulation.time_limit_s": 0.05}))
variants.append(variants[-1].with_values({"geometry.tooth_passing": True}))
t1 = time.perf_counter()
for sc in variants:
    simulate(sc, record_every_steps=1, threads=1)
    simulate(sc, record_every_steps=None, threads=1)
print(t1 - t0, time.perf_counter() - t1)
"""


def copy_tree(source: Path, dest: Path) -> Path:
    """Copy the packages and the scenario files of a source tree (no caches)."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc")
    for name in COPIED:
        shutil.copytree(source / name, dest / name, ignore=ignore)
    return dest


def copy_trees(baseline: Path | None, work: Path) -> dict[str, Path]:
    """This tree (``"this tree"``) and, when given, ``baseline`` (``"baseline"``), copied
    under ``work`` (:func:`copy_tree`)."""
    trees = {"this tree": copy_tree(ROOT, work / "this")}
    if baseline:
        trees["baseline"] = copy_tree(baseline.resolve(), work / "baseline")
    return trees


def add_tree_args(ap: argparse.ArgumentParser, baseline_help: str) -> None:
    """The ``--baseline DIR`` and ``--write FILE`` options of the benchmarks that compare
    this tree with an older one."""
    ap.add_argument("--baseline", type=Path, help=baseline_help)
    ap.add_argument("--write", type=Path, help="also write the report to this Markdown file")


def bench_env(tree: Path, cache: Path) -> dict[str, str]:
    """The environment of a measured command: ``tree`` first on the path, ``cache`` as the
    numba cache, and bytecode written (``PYTHONDONTWRITEBYTECODE`` dropped) as it is on a
    user's machine, where ``pip install`` or the first run leaves ``.pyc`` files."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return {**env, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(cache), "MPLBACKEND": "Agg"}


def cpu_children() -> float:
    """CPU time (user + system) [s] of this process's waited-for children so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_once(tree: Path, cache: Path, out: Path) -> tuple[float, float]:
    """Wall time and CPU time (user + system, the figure process included) [s] of
    ``acc run`` of the shipped scenario on ``tree`` with ``cache``."""
    c0, t0 = cpu_children(), time.perf_counter()
    subprocess.run([sys.executable, "-m", "acc", "run", str(SCENARIO), "--out", str(out), "-q"],
                   cwd=tree, env=bench_env(tree, cache), check=True, capture_output=True)
    return time.perf_counter() - t0, cpu_children() - c0


def compile_all(tree: Path, cache: Path) -> float:
    """Compile time [s] of every kind and force model on an empty cache (imports apart)."""
    done = subprocess.run([sys.executable, "-c", _COMPILE_ALL], cwd=tree,
                          env=bench_env(tree, cache), check=True, capture_output=True, text=True)
    return float(done.stdout.split()[1])


def compile_command(tree: Path, cache: Path) -> float | None:
    """Wall time [s] of ``acc compile`` (every kind, one process per core) on an empty cache;
    None for a tree without the command."""
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "acc", "compile", "-q"], cwd=tree,
                          env=bench_env(tree, cache), capture_output=True, text=True)
    if done.returncode != 0:
        return None
    return time.perf_counter() - t0


def summary_difference(a: Path, b: Path) -> float:
    """Largest relative difference between the numeric cells of two ``summary.csv``."""
    rows_a, rows_b = list(csv.DictReader(a.open())), list(csv.DictReader(b.open()))
    assert len(rows_a) == len(rows_b), "different rows"
    worst = 0.0
    for ra, rb in zip(rows_a, rows_b, strict=True):
        for key in ra.keys() & rb.keys():
            try:
                fx, fy = float(ra[key]), float(rb[key])
            except ValueError:
                assert ra[key] == rb[key], (key, ra[key], rb[key])
                continue
            if fx != fy and not (fx != fx and fy != fy):
                worst = max(worst, abs(fx - fy) / max(abs(fx), abs(fy)))
    return worst


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7, help="warm runs per tree")
    ap.add_argument("--cold", type=int, default=2, help="cold runs (empty cache) per tree")
    ap.add_argument("--compile-all", action="store_true", help="also compile every kind")
    add_tree_args(ap, "an older source tree, run alternately")
    args = ap.parse_args(argv)
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as work:
        w = Path(work)
        trees = copy_trees(args.baseline, w)
        warm: dict[str, list[tuple[float, float]]] = {t: [] for t in trees}
        cold: dict[str, list[tuple[float, float]]] = {t: [] for t in trees}
        every: dict[str, float] = {}
        command: dict[str, float | None] = {}
        for label, tree in trees.items():  # fill each tree's warm cache (and its .pyc)
            run_once(tree, w / f"cache-{label}", w / f"out-{label}-first")
        for i in range(args.repeats):
            for label, tree in trees.items():
                warm[label].append(run_once(tree, w / f"cache-{label}", w / f"out-{label}-{i}"))
        for i in range(args.cold):
            for label, tree in trees.items():
                cold[label].append(
                    run_once(tree, w / f"cold-{label}-{i}", w / f"cold-out-{label}-{i}"))
        if args.compile_all:
            for label, tree in trees.items():
                every[label] = compile_all(tree, w / f"all-{label}")
                command[label] = compile_command(tree, w / f"command-{label}")
        diff = (summary_difference(w / "out-this tree-first" / "summary.csv",
                                   w / "out-baseline-first" / "summary.csv")
                if args.baseline else None)
    load_after = os.getloadavg()[0]
    def med(runs: list[tuple[float, float]], i: int) -> float:
        return statistics.median(r[i] for r in runs)

    lines = ["| quantity | wall [s] | CPU, user + system [s] |", "|---|---|---|"]
    for label in trees:
        tag = "" if label == "this tree" else f" ({label}: {args.baseline.name})"
        lines.append(f"| acc run of the shipped scenario, warm{tag}, median of {args.repeats} "
                     f"(target 1.0 s) | {med(warm[label], 0):.2f} | {med(warm[label], 1):.2f} |")
        if args.cold:
            lines.append(f"| acc run of the shipped scenario, cold (empty numba cache){tag}, "
                         f"median of {args.cold} (target 5 s) | {med(cold[label], 0):.2f} | "
                         f"{med(cold[label], 1):.2f} |")
        if label in every:
            lines.append(f"| compile of every kind and force model, empty cache{tag}, imports "
                         f"apart (target 15 s) | {every[label]:.1f} | |")
            if command.get(label) is not None:
                lines.append(f"| acc compile, every kind and force model, empty cache{tag}, "
                             f"{os.cpu_count()} processes | {command[label]:.1f} | |")
    if args.baseline:
        for what, runs in (("warm", warm), ("cold", cold)):
            if runs["this tree"]:
                lines.append(
                    f"| {what}: baseline / this tree [-] | "
                    f"{med(runs['baseline'], 0) / med(runs['this tree'], 0):.2f} | "
                    f"{med(runs['baseline'], 1) / med(runs['this tree'], 1):.2f} |")
        lines.append(f"| summary.csv, largest relative difference to the baseline [-] | "
                     f"{diff:.3g} | |")
    return finish_report(lines, "bench_cli.py", argv, (load_before, load_after), args.write)


def finish_report(lines: list[str], script: str, argv: list[str] | None,
                  loads: tuple[float, float], write: Path | None, note: str = "") -> int:
    """Append the load, machine and command to a benchmark's table; print it, and write it to
    ``write`` when given.

    Parameters
    ----------
    lines : list of str
        The Markdown table's lines.
    script : str
        The benchmark's file name, for the command line shown.
    argv : list of str or None
        Its arguments (None: ``sys.argv[1:]``).
    loads : (float, float)
        1-minute load average before and after the measurement.
    write : Path or None
        Markdown file to write as well.
    note : str
        Words put before the load (e.g. ``"Medians of 3 rounds. "``).

    Returns
    -------
    int
        0, the exit status.
    """
    shown = " ".join(argv if argv is not None else sys.argv[1:])
    lines = [*lines, "",
             f"{note}Load average (1 min) before the run: {loads[0]:.2f}, after: {loads[1]:.2f}.",
             f"Machine: {os.cpu_count()} cores, {platform.machine()}, Python "
             f"{platform.python_version()}.",
             f"Command: `python benchmarks/{script} {shown}`"]
    report = "\n".join(lines)
    print(report)
    if write:
        write.write_text(report + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
