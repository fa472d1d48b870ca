"""``acc compile``: compile the simulation loops' configurations into the on-disk cache, once.

The compiled loops are specialised per configuration (the controller kind, the force model,
the lab's axes and controllers: the types of the records in the loop; one specialisation
serves ``acc run`` with traces and ``acc sweep`` without), and each is compiled the first
time a command needs it (1-8 s on a 2-core machine, said once for the force loop), then
loaded from numba's cache on disk.  ``acc compile`` does that work up front, on every core,
with a line per configuration, e.g. after an install or before a timed sweep or a CI gate:

* ``acc compile``: every controller kind on the shipped scenario (``kim_chung_2001``), the
  geometric force model of ``current_sensing_geometric`` (average and tooth-passing force),
  and every other shipped example scenario's own configuration (the LinuxCNC drive, the
  breakage monitor in the loop, the axis and XY contouring labs);
* ``acc compile FILE ...``: each scenario's own configuration (a force-loop, axis or XY
  contouring scenario); ``--kinds KIND,...`` (or ``all``) compiles those kinds on each
  force-loop file instead;
* ``--jobs N``: processes compiling at once (default: the cores).

A configuration already in the cache is loaded instead of compiled (about 0.1 s).
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass

from acc.cli.common import CommandError
from acc.cli.main import COMMANDS, say
from acc.errors import AccError

#: Simulated time of a compiling run [s] (a few control periods: what compiles is the loop).
COMPILE_RUN_S = 0.05


@dataclass(frozen=True)
class Configuration:
    """One configuration to compile: a scenario file, the kind and values set on it, and a
    label for the progress lines."""

    path: str
    values: tuple[tuple[str, object], ...]
    label: str


def configurations(files: Sequence[str], kinds: Sequence[str] | None) -> list[Configuration]:
    """What to compile: for each file, its own configuration or each of ``kinds``; without
    files, every kind on the shipped scenario, the two geometric force models and every other
    shipped example scenario (its own configuration).

    Raises
    ------
    CommandError
        An unknown kind, or no shipped scenario to compile (without files).
    """
    from acc.examples import ExampleError, find_example, list_examples
    from controllers.registry import controller_kinds

    known = list(controller_kinds())
    if kinds is not None:
        unknown = [k for k in kinds if k not in known]
        if unknown:
            raise CommandError(f"--kinds: unknown controller kind(s) {', '.join(unknown)}; "
                               f"known: {', '.join(sorted(known))}")
    out: list[Configuration] = []
    if not files:
        try:
            found = [find_example(n) for n in ("kim_chung_2001", "current_sensing_geometric")]
            others = [e for e in list_examples() if e.kind == "scenario"]
        except ExampleError:
            found = [None]
        if None in found:
            raise CommandError("the shipped scenarios are not installed; name scenario files "
                               "instead (acc compile FILE ...)")
        shipped, geometric = (str(e.path) for e in found if e is not None)
        for kind in kinds if kinds is not None else known:
            out.append(Configuration(shipped, (("controller.kind", kind),), kind))
        for tooth_passing in (False, True):
            force = "tooth-passing" if tooth_passing else "average"
            out.append(Configuration(
                geometric, (("geometry.tooth_passing", tooth_passing),),
                f"geometric force model ({force} force)"))
        if kinds is None:
            out.extend(Configuration(str(e.path), (), f"{e.name} ({_LABS[e.model or 'force']})")
                       for e in others if str(e.path) not in (shipped, geometric))
        return out
    for path in files:
        name = os.path.basename(path)
        if kinds is None:
            out.append(Configuration(path, (), name))
        else:
            out.extend(Configuration(path, (("controller.kind", k),), f"{k} on {name}")
                       for k in kinds)
    return out


#: The loop a scenario of each ``[simulation] model`` runs in, for the progress lines.
_LABS = {"force": "force loop", "axis": "axis loop", "xy_contour": "XY contouring loop"}


def compile_configuration(config: Configuration) -> float:
    """Compile (or load) a configuration's loop by simulating it briefly; seconds taken.

    A force-loop scenario runs for :data:`COMPILE_RUN_S`, an axis scenario for one control
    period, an XY contouring scenario as given (its path sets its length; a few
    milliseconds of simulation once compiled).

    Raises
    ------
    acc.errors.AccError
        The file cannot be read, or a value set is not one of the scenario's keys (e.g.
        ``--kinds`` on a lab scenario).
    """
    from acc import scenarios

    t0 = time.perf_counter()
    scenario = scenarios.load(config.path, [])
    model = scenarios.model_of_scenario(scenario)
    values = dict(config.values)
    if model == "force":
        from acc.engine.simulate import simulate

        values["simulation.time_limit_s"] = COMPILE_RUN_S
        simulate(scenario.with_values(values), record_every_steps=1, threads=1)
    elif "controller.kind" in values:
        raise CommandError(f"{config.path}: --kinds names kinds of the force loop's controller; "
                           f"this scenario runs in the {_LABS[model]} (compile it without --kinds)")
    elif model == "axis":
        values["simulation.duration_s"] = scenario.simulation.control_period_s
        scenario.with_values(values).simulate(record_every_steps=1)
    else:
        scenario.with_values(values).simulate()
    return time.perf_counter() - t0


def _quiet_worker() -> None:
    """A compiling process says nothing itself (the parent reports each configuration) and
    compiles its loop in process: every core already compiles a configuration, and a child
    compiling the loop aside would compile the helpers it shares with the ``init``
    functions a second time (:func:`acc.engine.loop_compile.compiled_aside`)."""
    import logging
    import os
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    logging.getLogger("acc").setLevel(logging.WARNING)
    os.environ["ACC_COMPILE_IN_PROCESS"] = "1"


def _add_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenarios", nargs="*", metavar="SCENARIO",
                   help="scenario files: force loop, axis or XY contouring (default: every "
                        "kind on the shipped scenario, the geometric force model and every "
                        "other shipped example scenario)")
    p.add_argument("--kinds", help="comma-separated controller kinds to compile on each "
                   "force-loop scenario, or 'all' (default: each file's own kind)")
    p.add_argument("--jobs", type=int, default=None,
                   help="processes compiling at once (default: the cores)")


def _cmd_compile(args: argparse.Namespace) -> int:
    from controllers.registry import controller_kinds

    if args.jobs is not None and args.jobs < 1:
        raise CommandError(f"--jobs must be at least 1, got {args.jobs}")
    kinds = None
    if args.kinds:
        kinds = (list(controller_kinds()) if args.kinds.strip() == "all"
                 else [k.strip() for k in args.kinds.split(",") if k.strip()])
    todo = configurations(args.scenarios, kinds)
    jobs = min(args.jobs or os.cpu_count() or 1, len(todo))
    say(args, f"compiling {len(todo)} configuration{'s' * (len(todo) != 1)} of the simulation "
              f"loops in {jobs} process{'es' * (jobs != 1)} (cached on disk)")
    t0 = time.perf_counter()
    done = 0
    failed: list[str] = []

    def report(config: Configuration, seconds: float | None, error: str | None) -> None:
        nonlocal done
        done += 1
        if error is None:
            say(args, f"  {done}/{len(todo)} {config.label}: {seconds:.1f} s")
        else:
            failed.append(f"{config.label}: {error}")
            say(args, f"  {done}/{len(todo)} {config.label}: FAILED: {error}")

    if jobs == 1:
        for config in todo:
            try:
                report(config, compile_configuration(config), None)
            except (AccError, ValueError) as exc:
                report(config, None, str(exc))
    else:
        with ProcessPoolExecutor(max_workers=jobs, initializer=_quiet_worker) as pool:
            running = {pool.submit(compile_configuration, c): c for c in todo}
            while running:
                finished, _ = wait(running, return_when=FIRST_COMPLETED)
                for fut in finished:
                    config = running.pop(fut)
                    try:
                        report(config, fut.result(), None)
                    except (AccError, ValueError) as exc:
                        report(config, None, str(exc))
    seconds = time.perf_counter() - t0
    if failed:
        raise CommandError(f"{len(failed)} of {len(todo)} configurations did not compile; "
                           f"first: {failed[0]}")
    say(args, f"compiled {len(todo)} configurations in {seconds:.1f} s; later runs load "
              "them from the cache")
    return 0


COMMANDS["compile"] = (
    "compile the simulation loops' configurations (every kind and shipped example by default) "
    "into the on-disk cache, on every core, so that later commands load them",
    _add_args, _cmd_compile,
)
