"""Compiled helpers without a Python entry (:func:`acc.engine.element.jit`).

A function made with ``jit`` is compiled for compiled callers only: numba's Python entry
wrapper is not compiled with it (nor linked into every caller, and optimised there again).  A
call from Python still works, through a twin compiled with the entry, whose specialisations
sit in the same cache index under keys of their own.  Were they under the same key, a later
process calling the function from Python would load the specialisation without an entry and
crash; the processes below would then die with a signal.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_MODULE = """
from acc.engine.element import jit


@jit
def inc(x):
    return x + 1.0


@jit(python_entry=True)
def outer(x):
    return inc(x) * 2.0
"""

# argv[2]: what the process calls from Python; prints its result and the cache statistics
_PROCESS = """
import sys
sys.path.insert(0, sys.argv[1])
import helpers

fn = getattr(helpers, sys.argv[2])
value = fn(1.5)
stats = (fn if sys.argv[2] == "outer" else fn._python_twin).stats
print(value, sum(stats.cache_hits.values()), sum(stats.cache_misses.values()))
"""


def _run(tmp_path: Path, name: str) -> tuple[float, int, int]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, str(tmp_path / "process.py"), str(tmp_path), name],
                          env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
    value, hits, misses = done.stdout.split()
    return float(value), int(hits), int(misses)


def test_helper_has_no_python_entry_and_python_calls_go_to_a_cached_twin(tmp_path):
    (tmp_path / "helpers.py").write_text(_MODULE)
    (tmp_path / "process.py").write_text(_PROCESS)
    # 1: only the compiled caller is called from Python: inc is compiled for it alone
    assert _run(tmp_path, "outer") == (5.0, 0, 1)
    # 2: inc from Python: its twin compiles (the cached inc has no entry to call)
    assert _run(tmp_path, "inc") == (2.5, 0, 1)
    # 3: both are loaded from the cache
    assert _run(tmp_path, "inc") == (2.5, 1, 0)
    assert _run(tmp_path, "outer") == (5.0, 1, 0)


def test_only_the_python_entry_function_compiles_the_entry(tmp_path, monkeypatch):
    (tmp_path / "helpers_ir.py").write_text(_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    import helpers_ir

    assert helpers_ir.outer(1.5) == 5.0
    (inc,) = helpers_ir.inc.overloads.values()
    (outer,) = helpers_ir.outer.overloads.values()
    assert outer.fndesc.llvm_cpython_wrapper_name in outer.library.get_llvm_str()
    assert inc.fndesc.llvm_cpython_wrapper_name not in inc.library.get_llvm_str()
    assert helpers_ir.inc(1.5) == 2.5  # from Python: the twin
    (twin,) = helpers_ir.inc._python_twin.overloads.values()
    assert twin.fndesc.llvm_cpython_wrapper_name in twin.library.get_llvm_str()
