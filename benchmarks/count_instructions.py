"""Instructions the compiled force loop executes a plant step, by compiled function: a measure
of the loop's work that does not move with the machine's load.

``python benchmarks/count_instructions.py [--kind KIND] [--noise N] [--runs 6]
[--seconds 30] [--baseline DIR] [--write FILE]``

On a shared machine the loop's wall and CPU times move by up to 2x within an hour, so a
change of a few per cent cannot be timed in one run.  The instructions it executes do not
move: this counts them with valgrind's ``callgrind``, switched on for the timed batch only
(a client request from a small C shim compiled here), and sums them over the address ranges
of the loop's compiled functions.  Instructions are not time (the processor runs several a
cycle, and a call's saves and restores cost less than their count), so a change is kept on
its times, side by side (``bench_loop.py --baseline``); the count says where the work is
and whether a change removed any.

Each tree (this one, and ``--baseline DIR`` if given, e.g. a ``git archive`` of an earlier
commit) is measured in its own process under valgrind: the loop is compiled there, into an
empty numba cache, so that its functions' addresses are known (about a minute a tree).
Needs valgrind with its headers (Debian: ``apt-get install valgrind``), a C compiler and
binutils' ``nm``.
"""

from __future__ import annotations

import collections
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
sys.path.insert(0, str(ROOT / "benchmarks"))

from profile_engine import demangle, emit, loop_arguments, loop_changes  # noqa: E402

_SHIM = """
#include <valgrind/callgrind.h>
void count_start(void) { CALLGRIND_ZERO_STATS; CALLGRIND_START_INSTRUMENTATION; }
void count_stop(void) { CALLGRIND_STOP_INSTRUMENTATION; CALLGRIND_DUMP_STATS_AT("timed"); }
"""

_CHILD = """
import ctypes, json, sys
import numba
from acc.scenarios.force import load_scenario
from acc.engine.simulate import simulate
from acc.engine import force_loop

base = load_scenario({scenario!r}).with_values({changes!r})
runs = [base.with_values({{"simulation.seed": i}}) for i in range({runs})]
numba.set_num_threads(1)
simulate(runs[:1], record_every_steps=None, threads=1)  # compiled here: addresses known
functions = {{}}
for cres in force_loop.run_runs.overloads.values():
    lib = cres.library
    with open({obj!r}, "wb") as out:
        out.write(lib._codegen._tm.emit_object(lib._final_module))
    for fn in lib._final_module.functions:
        if not fn.is_declaration and lib.get_pointer_to_function(fn.name):
            functions[fn.name] = lib.get_pointer_to_function(fn.name)
shim = ctypes.CDLL({shim!r})
shim.count_start()
simulate(runs, record_every_steps=None, threads=1)
shim.count_stop()
print(json.dumps({{"functions": functions, "run_steps": {runs} * base.simulation.max_steps}}))
"""


def _costs(callgrind_out: Path) -> collections.Counter[int]:
    """Instructions by address from a ``--dump-instr=yes`` callgrind file (positions
    ``instr line``; a cost line after ``calls=`` is the call's inclusive cost: skipped)."""
    costs: collections.Counter[int] = collections.Counter()
    address, skip = 0, False
    for line in callgrind_out.read_text().splitlines():
        if line.startswith("calls="):
            skip = True
            continue
        m = re.match(r"^(0x[0-9a-f]+|[+-][0-9]+|\*)\s+\S+\s+(\d+)", line)
        if not m:
            continue
        p = m.group(1)
        address = int(p, 16) if p.startswith("0x") else address + int(p) if p != "*" else address
        if skip:
            skip = False
            continue
        costs[address] += int(m.group(2))
    return costs


def _sizes(obj: Path) -> dict[str, int]:
    """Size [bytes] of each function defined in an object file (``nm -S``)."""
    out = subprocess.run(["nm", "-S", "--defined-only", str(obj)], capture_output=True,
                         text=True, check=True).stdout
    sizes = {}
    for line in out.splitlines():
        fields = line.split()
        if len(fields) == 4 and fields[2] in "tTwW":  # functions (LLVM links callees weak)
            sizes[fields[3]] = int(fields[1], 16)
    return sizes


def count(tree: Path, changes: dict, runs: int, tmp: Path) -> tuple[dict[str, float], float]:
    """Instructions a plant step by compiled function of ``tree``'s loop (demangled name ->
    count), and their total."""
    shim = tmp / "libcount.so"
    if not shim.exists():
        (tmp / "shim.c").write_text(_SHIM)
        subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-o", str(shim), str(tmp / "shim.c")],
                       check=True)
    tag = str(abs(hash(str(tree))))
    obj, out = tmp / f"loop-{tag}.o", tmp / f"callgrind-{tag}.out"
    code = _CHILD.format(scenario=str(SCENARIO), changes=changes, runs=runs, obj=str(obj),
                         shim=str(shim))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp / f"numba-{tag}"), "PYTHONPATH": str(tree),
           "ACC_COMPILE_IN_PROCESS": "1"}
    done = subprocess.run(
        ["valgrind", "--tool=callgrind", "--instr-atstart=no", "--dump-instr=yes",
         f"--callgrind-out-file={out}", sys.executable, "-c", code],
        capture_output=True, text=True, env=env, cwd=tree)
    if done.returncode != 0:
        raise SystemExit(f"count_instructions: the child failed: {done.stderr.strip()[-400:]}")
    timed = json.loads(done.stdout.strip().splitlines()[-1])
    dumps = sorted(tmp.glob(f"callgrind-{tag}.out.*"))
    if not dumps:
        raise SystemExit("count_instructions: callgrind wrote no dump of the timed batch")
    costs, sizes = _costs(dumps[-1]), _sizes(obj)
    per_function: dict[str, float] = collections.defaultdict(float)
    for name, start in timed["functions"].items():
        end = start + sizes.get(name, 0)
        n = sum(c for a, c in costs.items() if start <= a < end)
        if n:
            per_function[demangle(name)] += n / timed["run_steps"]
    return dict(per_function), sum(per_function.values())


def main() -> None:
    parser = loop_arguments(__doc__, runs=6)
    parser.add_argument("--baseline", type=Path, help="a second tree, counted the same way")
    args = parser.parse_args()
    for tool in ("valgrind", "cc", "nm"):
        if shutil.which(tool) is None:
            raise SystemExit(f"count_instructions: needs {tool} (Debian: apt-get install "
                             f"{'valgrind' if tool == 'valgrind' else 'gcc binutils'})")
    changes = loop_changes(args.kind, args.noise, args.seconds)
    trees = {"this tree": ROOT, **({args.baseline.name: args.baseline} if args.baseline else {})}
    with tempfile.TemporaryDirectory() as tmp:
        results = {label: count(tree.resolve(), changes, args.runs, Path(tmp))
                   for label, tree in trees.items()}
    names = sorted({n for per, _ in results.values() for n in per},
                   key=lambda n: -results["this tree"][0].get(n, 0.0))
    labels = list(results)
    lines = [
        f"{args.kind}, {args.noise:g} N sensor noise, {args.runs} runs of {args.seconds:g} s, "
        "instructions a plant step in the compiled loop's functions (callgrind)",
        "",
        "| compiled function (with what LLVM inlined into it) | " + " | ".join(labels) + " |",
        "|---|" + "---|" * len(labels),
        *(f"| `{n}` | " + " | ".join(f"{results[lb][0].get(n, 0.0):.1f}" for lb in labels)
          + " |" for n in names if max(results[lb][0].get(n, 0.0) for lb in labels) >= 0.05),
        "| total | " + " | ".join(f"{results[lb][1]:.1f}" for lb in labels) + " |",
        "",
        f"Command: `python benchmarks/count_instructions.py --kind {args.kind} "
        f"--noise {args.noise:g} --runs {args.runs}"
        + (" --baseline DIR`" if args.baseline else "`"),
    ]
    emit(lines, args.write)


if __name__ == "__main__":
    main()
