"""Processes that compile specialisations of one function at once all keep them in the cache.

numba adds a specialisation to a function's on-disk cache by reading its index, adding the
entry and writing the index back; two processes doing that at once lose one entry, which
then compiles again in every later process (``acc compile`` on two cores lost one of two
configurations in two runs of three).  Here four processes compile four specialisations of
a function made with :func:`acc.engine.element.jit` into one empty cache, with numba's index
write slowed down (0.4 s, a slow disk) so that their read-add-write steps overlap; a later
process must find all four in the cache.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_MODULE = """
from acc.engine.element import jit


@jit(python_entry=True)
def twice(x):
    return x + x
"""

_WORKER = """
import sys, time
from numba.core import caching

write = caching.IndexDataCacheFile._save_index


def slow_write(self, overloads):  # a slow disk: the index is read long before it is written
    time.sleep(0.4)
    write(self, overloads)


caching.IndexDataCacheFile._save_index = slow_write
sys.path.insert(0, sys.argv[1])
import numpy as np
import twice_module

start = float(sys.argv[3])
while time.time() < start:
    time.sleep(0.001)
twice_module.twice({"i": 1, "f": 1.0, "c": 1j, "s": np.int16(1)}[sys.argv[2]])
"""

_PROBE = """
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
import twice_module

for value in (1, 1.0, 1j, np.int16(1)):
    twice_module.twice(value)
stats = twice_module.twice.stats
print(sum(stats.cache_hits.values()), sum(stats.cache_misses.values()))
"""


def test_four_processes_compiling_at_once_keep_all_four_specialisations(tmp_path):
    (tmp_path / "twice_module.py").write_text(_MODULE)
    (tmp_path / "worker.py").write_text(_WORKER)
    (tmp_path / "probe.py").write_text(_PROBE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT)}
    start = time.time() + 2.0  # every process imported and waiting: they compile together
    workers = [subprocess.Popen([sys.executable, str(tmp_path / "worker.py"), str(tmp_path),
                                 kind, repr(start)], env=env, cwd=tmp_path) for kind in "ifcs"]
    assert [w.wait(timeout=300) for w in workers] == [0, 0, 0, 0]
    probe = subprocess.run([sys.executable, str(tmp_path / "probe.py"), str(tmp_path)], env=env,
                           cwd=tmp_path, capture_output=True, text=True, check=True, timeout=300)
    hits, misses = map(int, probe.stdout.split())
    assert (hits, misses) == (4, 0)
