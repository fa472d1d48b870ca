"""``acc compile``: the simulation loops' configurations compiled into numba's on-disk cache.

The cache test compiles a force-loop and an axis scenario in two processes into an empty
cache directory, then a fresh process simulates both and finds them in the cache (numba's
dispatcher statistics: cache hits, no misses); without ``acc compile`` the same process
compiles them (misses), so the test fails if the command stops compiling or compiles
elsewhere.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.cli_run import ROOT, SHIPPED, acc

AXIS = str(ROOT / "experiments" / "peng_servo_axis.toml")

_PROBE = """
import json, sys
from acc import scenarios
from acc.engine import axis_loop, force_loop
from acc.engine.simulate import simulate
force = scenarios.load(sys.argv[1], []).with_values({"simulation.time_limit_s": 0.05})
simulate(force, record_every_steps=None, threads=1)
axis = scenarios.load(sys.argv[2], [])
axis.with_values({"simulation.duration_s": axis.simulation.control_period_s}).simulate()
print(json.dumps({name: {"hits": sum(d.stats.cache_hits.values()),
                         "misses": sum(d.stats.cache_misses.values())}
                  for name, d in (("force", force_loop.run_runs), ("axis", axis_loop.run_runs))}))
"""


def _env(cache: Path, in_process: bool = True) -> dict[str, str]:
    """An empty numba cache; ``in_process``: the loop compiles in the process that needs it
    (no child compiling it aside, whose misses the parent's statistics would not count)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    env.pop("ACC_COMPILE_IN_PROCESS", None)
    if in_process:
        env["ACC_COMPILE_IN_PROCESS"] = "1"
    return env


def test_compiled_configurations_are_loaded_from_the_cache_by_a_later_process(
    tmp_path: Path,
) -> None:
    """A force-loop and an axis scenario compiled in two processes; a fresh process then
    finds both loops in the cache."""
    done = subprocess.run(
        [sys.executable, "-m", "acc", "compile", SHIPPED, AXIS, "--jobs", "2"],
        env=_env(tmp_path / "cache"), cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == ("compiling 2 configurations of the simulation loops in 2 processes "
                        "(cached on disk)")
    progress = [line.split(":")[0].strip().split(" ", 1) for line in lines[1:3]]
    assert [n for n, _ in progress] == ["1/2", "2/2"]
    assert sorted(label for _, label in progress) == ["kim_chung_2001.toml",
                                                      "peng_servo_axis.toml"]
    assert lines[3].startswith("compiled 2 configurations in ")
    # (the cache directory is new: without the command both would be misses; a compile that
    # writes nowhere fails here)
    probe = subprocess.run([sys.executable, "-c", _PROBE, SHIPPED, AXIS],
                           env=_env(tmp_path / "cache"), cwd=ROOT, capture_output=True,
                           text=True, check=True)
    assert json.loads(probe.stdout.strip().splitlines()[-1]) == {
        "force": {"hits": 1, "misses": 0}, "axis": {"hits": 1, "misses": 0}}


def test_an_unknown_kind_is_one_line_naming_the_known_ones() -> None:
    r = acc("compile", "--kinds", "pi,pid_typo")
    assert r.status == 2
    assert r.err_lines == [
        "acc: error: --kinds: unknown controller kind(s) pid_typo; known: adaptive_pi, "
        "constant, dob_adaptive_pi, dob_pi, fsp_adaptive_pi, fsp_pi, pi"]


def test_no_jobs_is_refused() -> None:
    r = acc("compile", "--jobs", "0")
    assert (r.status, r.err_lines) == (2, ["acc: error: --jobs must be at least 1, got 0"])


def test_kinds_on_a_lab_scenario_are_refused_in_one_line() -> None:
    axis = AXIS
    r = acc("compile", axis, "--kinds", "pi", "--jobs", "1")
    assert r.status == 2
    assert r.err_lines == [
        f"acc: error: 1 of 1 configurations did not compile; first: pi on "
        f"peng_servo_axis.toml: {axis}: --kinds names kinds of the force loop's controller; "
        "this scenario runs in the axis loop (compile it without --kinds)"]


def test_without_files_every_shipped_scenario_is_compiled() -> None:
    """The default list: every kind on the shipped scenario, both geometric force models,
    and each other shipped example scenario once, whichever lab it belongs to."""
    from acc.cli.compile import configurations
    from acc.examples import list_examples
    from controllers.registry import controller_kinds

    todo = configurations([], None)
    kinds = list(controller_kinds())
    assert [c.label for c in todo[:len(kinds)]] == kinds
    assert {Path(c.path).name for c in todo} == {
        e.name for e in list_examples() if e.kind == "scenario"}
    own = {Path(c.path).name: c.label for c in todo[len(kinds) + 2:]}
    assert own["briquez_huron_axis.toml"] == "briquez_huron_axis.toml (axis loop)"
    assert own["lacerda_circle_40.toml"] == "lacerda_circle_40.toml (XY contouring loop)"
    assert own["linuxcnc_kim_chung.toml"] == "linuxcnc_kim_chung.toml (force loop)"
    assert "kim_chung_2001.toml" not in own  # its kinds are all above
    # --kinds: those kinds on each file instead of its own
    picked = configurations([SHIPPED], ["pi", "constant"])
    assert [(c.label, c.values) for c in picked] == [
        ("pi on kim_chung_2001.toml", (("controller.kind", "pi"),)),
        ("constant on kim_chung_2001.toml", (("controller.kind", "constant"),))]


_ONE_KIND = """
import json, sys
from acc.scenarios.force import load_scenario
from acc.engine.simulate import simulate
from acc.engine import force_loop
sc = load_scenario(sys.argv[1]).with_values({"simulation.time_limit_s": 0.05,
                                             "controller.kind": "constant"})
simulate(sc, record_every_steps=None, threads=1)
stats = force_loop.run_runs.stats
print(json.dumps({"hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values())}))
"""


def test_processes_that_need_a_new_configuration_at_once_compile_it_once(
    tmp_path: Path,
) -> None:
    # two processes started together on an empty cache: one compiles (a miss) while the
    # other waits on the configuration's lock, then loads what the first wrote (a hit);
    # without the lock both compile (two misses: the compilation takes seconds)
    procs = [subprocess.Popen([sys.executable, "-c", _ONE_KIND, SHIPPED],
                              env=_env(tmp_path / "cache"), cwd=ROOT, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outcomes = []
    for proc in procs:
        out, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
        outcomes.append(json.loads(out.strip().splitlines()[-1]))
    assert sorted(outcomes, key=lambda o: o["hits"]) == [{"hits": 0, "misses": 1},
                                                          {"hits": 1, "misses": 0}]
