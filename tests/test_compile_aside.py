"""The force loop compiled by a child process while the parent builds the records
(:func:`acc.engine.loop_compile.compiled_aside`).

The child compiles the specialisation the parent's records will need, known from records
built without their ``init`` functions; the parent then loads it from numba's cache.  The
subprocess test reads the parent's dispatcher statistics on an empty cache: a cache hit and
no miss when the child compiled (a miss when it compiled in process, or when the probed
types were not the built ones; ``tests/test_compile_command.py`` sees the miss of a process
that compiles alone), and the same metrics as the run in the test's process.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from acc import scenarios
from acc.engine import simulate as simulate_module
from acc.engine.element import inits_skipped
from acc.engine.loop_compile import specialisation_key
from tests.cli_run import ROOT, SHIPPED

_RUN = """
import json, sys
from acc.scenarios.force import load_scenario
from acc.engine.simulate import simulate
from acc.engine import force_loop
sc = load_scenario(sys.argv[1]).with_values({"simulation.time_limit_s": 0.3,
                                             "controller.kind": "pi"})
result = simulate(sc, record_every_steps=None, threads=1)
stats = force_loop.run_runs.stats
print(json.dumps({"hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values()),
                  "iae": float(result.metrics["iae_N_s"][0]),
                  "peak": float(result.metrics["peak_force_N"][0])}))
"""


def _run_cold(cache: Path, in_process: bool) -> dict[str, float]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    env.pop("ACC_COMPILE_IN_PROCESS", None)
    if in_process:
        env["ACC_COMPILE_IN_PROCESS"] = "1"
    done = subprocess.run([sys.executable, "-c", _RUN, SHIPPED], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not hasattr(os, "fork") or (os.cpu_count() or 1) < 2,
                    reason="the loop is compiled aside only where fork and 2 cores are")
def test_a_new_configuration_is_compiled_by_a_child_and_loaded_by_the_parent(
    tmp_path: Path,
) -> None:
    aside = _run_cold(tmp_path / "aside", in_process=False)
    assert (aside["hits"], aside["misses"]) == (1, 0)  # the child wrote it, the parent read it
    # the same run here, the loop compiled (or loaded) by this process
    sc = scenarios.load(SHIPPED, ["simulation.time_limit_s=0.3", 'controller.kind="pi"'])
    here = simulate_module.simulate(sc, record_every_steps=None, threads=1).metrics
    assert aside["iae"] == float(here["iae_N_s"][0]) > 0.0
    assert aside["peak"] == float(here["peak_force_N"][0])


def _key(batch: list, skipped: bool) -> str:
    """The loop's specialisation key for a batch of one engine group, from records built
    with or without their ``init`` functions (nothing compiles or runs but the inits)."""
    noise_ids = np.arange(len(batch), dtype=np.int64)
    if skipped:
        with inits_skipped():
            return specialisation_key(simulate_module._group_inputs(batch, noise_ids, 1).args)
    return specialisation_key(simulate_module._group_inputs(batch, noise_ids, 1).args)


@pytest.mark.parametrize("overrides", [
    [],
    ["feed_drive.kind=\"servo_axis\""],
    ["current_sensing.enabled=true"],
])
def test_records_built_without_inits_have_the_built_types(overrides: list[str]) -> None:
    """What the child compiles is what the parent runs: the same key, for a batch whose
    runs need delay lines of different capacities (the largest is taken for all)."""
    base = scenarios.load(SHIPPED, ["simulation.time_limit_s=0.5", *overrides])
    batch = [base.with_values({"feed_drive.dead_time_s": t, "nominal_plant.dead_time_s": t})
             for t in (0.01, 0.4)]
    assert _key(batch, skipped=True) == _key(batch, skipped=False)
    # (the key does see the capacity: the short delay alone is another specialisation)
    assert _key(batch[:1], skipped=True) != _key(batch, skipped=False)
