"""The ``acc`` command line.

``acc run SCENARIO --out DIR [--set section.key=value ...]`` simulates one scenario and writes
``summary.csv``, ``manifest.json``, ``traces.csv``/``traces.npz`` and ``response.png``.

Bad input (missing file, unknown key, wrong type, impossible value) prints one line
``acc: error: <file or --set>: <section.key>: <message>`` and exits with status 2; an
unusable ``--out`` is refused the same way before any work.  Ctrl-C prints one line and exits
with status 130.  A failed or interrupted command leaves no output directory behind.

Options of every command (before or after the subcommand): ``--version``; ``-q/--quiet``
(only warnings and errors: no progress, no result lines, the files are written as usual);
``-v/--verbose`` (debug notes of the ``acc`` logger as well).  ``acc --help`` imports no
numerical library.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TextIO

from acc.cli.common import EXIT_INTERRUPTED, EXIT_USAGE, CommandError, say
from acc.errors import AccError

if TYPE_CHECKING:
    from acc.engine.result import SimulationResult
    from acc.scenarios.force import Scenario


def load_with_overrides(path: str, assignments: Sequence[str],
                        command: str | None = None) -> Scenario:
    """Load a cutting-force-loop scenario file and apply ``--set section.key=value``.

    An error in an override names ``--set`` as its source (the file alone is valid).  A file
    of another lab (``[simulation] model``) is refused in one line naming ``command``.
    """
    from acc import scenarios

    scenario = scenarios.load(path, assignments)
    model = scenarios.model_of_scenario(scenario)
    if model != "force":
        raise CommandError(
            f"{path}: {'acc ' + command if command else 'this command'} takes cutting-force-loop "
            f"scenarios; this file is {scenarios.MODELS[model]} ([simulation] model = "
            f"{model!r})")
    return scenario


def simulate_or_fail(
    scenario: Scenario, record_every_steps: int | None = 1
) -> SimulationResult:
    """Simulate one scenario; an exception inside the simulation is a one-line
    :class:`CommandError` (validation should have caught it; this is the safety net)."""
    from acc.engine.simulate import check_batch_memory, simulate
    from acc.limits import shorten

    check_batch_memory([scenario], 1, record_every_steps)
    try:
        return simulate(scenario, record_every_steps=record_every_steps)
    except AccError:
        raise
    except (Exception, MemoryError) as exc:  # noqa: BLE001 - reported in one line
        raise CommandError(
            f"{scenario.source}: the simulation failed: {type(exc).__name__}: "
            f"{shorten(str(exc))}"
        ) from None


def _cmd_run(args: argparse.Namespace) -> int:
    from acc.output import check_output_dir

    check_output_dir(args.out)
    from acc import scenarios
    from acc.examples import resolve_scenario_argument

    args.scenario = resolve_scenario_argument(args.scenario)  # a bare name: a shipped example
    scenario = scenarios.load(args.scenario, args.set)
    model = scenarios.model_of_scenario(scenario)
    if model == "axis":
        from acc.cli.axis import run_axis

        return run_axis(args, scenario)
    if model == "xy_contour":
        from acc.cli.contour import run_contour

        return run_contour(args, scenario)
    from acc.cli.figure_process import FigureProcess
    from acc.output import staged_directory, write_csv, write_manifest, write_traces

    # the figures are drawn in a second process that imports matplotlib meanwhile
    with FigureProcess() as figures:
        result = simulate_or_fail(scenario, record_every_steps=1)
        out = Path(args.out)
        with staged_directory(out) as stage:
            jobs = [("response_figure", stage / "response.png",
                     f"{Path(args.scenario).name}: {scenario.controller.kind}")]
            if scenario.tool_breakage.enabled:
                jobs.append(("breakage_figure", stage / "breakage.png",
                             f"{Path(args.scenario).name}: tool breakage"))
            figures.draw(result, jobs)
            write_csv(stage / "summary.csv", result.summary_rows())
            write_manifest(stage / "manifest.json", result, {"overrides": list(args.set)})
            csv_every = scenario.simulation.steps_per_control
            write_traces(stage, result, every=csv_every)
            figures.wait()
    m = result.metrics
    say(
        args,
        f"{args.scenario} ({scenario.controller.kind}): machining "
        f"{m['machining_time_s'][0]:.2f} s "
        f"(constant safe feed {m['conventional_time_s'][0]:.2f} s, "
        f"productivity {m['productivity_gain_pct'][0]:+.1f} %), "
        f"RMS force error {m['rms_error_N'][0]:.1f} N, peak {m['peak_force_N'][0]:.0f} N"
        + (" [FAILED: the force diverged]" if m["failed"][0] else ""),
        *([_breakage_line(m)] if scenario.tool_breakage.enabled else []),
        f"wrote {out}/summary.csv, manifest.json, traces.csv, traces.npz, response.png"
        + (", breakage.png" if scenario.tool_breakage.enabled else ""),
    )
    return 0


def _breakage_line(m: Any) -> str:
    """One line on the in-loop breakage monitor's outcome."""
    alarm, broke = int(m["breakage_alarm_period"][0]), int(m["breakage_period"][0])
    if m["breakage_detected"][0]:
        what = (f"breakage at tooth period {broke} detected at {alarm} (delay "
                f"{m['detection_delay_tooth_periods'][0]:.0f} tooth periods)")
    elif m["breakage_false_alarm"][0]:
        what = f"false alarm at tooth period {alarm}"
    elif broke >= 0:
        what = f"breakage at tooth period {broke} missed"
    else:
        what = "no breakage, no alarm"
    return (f"tool breakage: {what}; {m['monitored_healthy_cut_m'][0] * 1000:.1f} mm of "
            f"healthy cut monitored; peak force {m['breakage_overshoot_pct'][0]:+.1f} % after "
            "the break")


#: Subcommands: name -> (help, add-arguments function, handler).
COMMANDS: dict[
    str, tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]
] = {}


def add_scenario_args(p: argparse.ArgumentParser, out_help: str = "output directory") -> None:
    """The arguments every scenario command takes: the file, ``--out`` and ``--set``."""
    p.add_argument("scenario", help="scenario TOML file")
    p.add_argument("--out", required=True, help=out_help)
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help="override a scenario value (repeatable); the value is read as TOML",
    )


COMMANDS["run"] = ("simulate one scenario and write its results", add_scenario_args, _cmd_run)


# --- options of every command: --version, --quiet, --verbose ------------------------------
def version_text() -> str:
    """``acc X.Y.Z`` and the versions of Python and the numerical libraries (no imports)."""
    import platform
    from importlib import metadata

    def version(dist: str) -> str:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return "not installed"

    libs = ", ".join(f"{d} {version(d)}" for d in ("numpy", "scipy", "control", "numba"))
    return f"acc {version('acc')} (Python {platform.python_version()}; {libs})"


class _VersionAction(argparse.Action):
    """``--version``: the text is built only when asked for (``acc --help`` stays fast)."""

    def __init__(self, option_strings: Sequence[str], dest: str, **kwargs: object) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="print the versions of acc and its numerical libraries and exit")

    def __call__(self, parser: argparse.ArgumentParser, *args: object) -> None:
        print(version_text())
        parser.exit()


def _add_verbosity(p: argparse.ArgumentParser, top: bool) -> None:
    # given to the top parser and to every subcommand; a subcommand's default is SUPPRESS
    # so that `acc -q run ...` is not undone by the subcommand's own default
    group = p.add_mutually_exclusive_group()
    default = 0 if top else argparse.SUPPRESS
    group.add_argument("-q", "--quiet", dest="verbosity", action="store_const", const=-1,
                       default=default, help="only warnings and errors (no progress, no "
                       "result lines)")
    group.add_argument("-v", "--verbose", dest="verbosity", action="store_const", const=1,
                       default=default, help="also debug notes")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered subcommand."""
    _register_optional_commands()
    parser = argparse.ArgumentParser(
        prog="acc", description="Adaptive cutting-force control workbench for end milling."
    )
    parser.add_argument("--version", action=_VersionAction)
    _add_verbosity(parser, top=True)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (help_text, add_args, handler) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        add_args(p)
        _add_verbosity(p, top=False)
        p.set_defaults(handler=handler)
    return parser


def _register_optional_commands() -> None:
    """Import the modules that register further subcommands (analysis, campaigns...)."""
    import importlib

    for module in ("acc.cli.design", "acc.cli.campaigns", "acc.cli.identify", "acc.cli.examples",
                   "acc.cli.linuxcnc", "acc.cli.compile"):
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name != module:
                raise


class _CurrentStderr(logging.StreamHandler):
    """A handler that writes to whatever ``sys.stderr`` is when a record is emitted (callers
    that run ``main`` several times in one process may swap it in between)."""

    @property
    def stream(self) -> TextIO:  # type: ignore[override]
        return sys.stderr

    @stream.setter
    def stream(self, value: TextIO) -> None:  # the base class sets it; ignore
        pass


def _log_to_stderr(verbosity: int = 0) -> None:
    """Progress notes of the ``acc`` logger (e.g. a first compilation) on stderr, once; the
    level follows ``--quiet`` (WARNING), default (INFO) or ``--verbose`` (DEBUG)."""
    log = logging.getLogger("acc")
    if not any(isinstance(h, _CurrentStderr) for h in log.handlers):
        handler = _CurrentStderr()
        handler.setFormatter(logging.Formatter("acc: %(message)s"))
        log.addHandler(handler)
    log.setLevel({-1: logging.WARNING, 0: logging.INFO}.get(verbosity, logging.DEBUG))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``acc`` command; returns the exit status.

    0: done; 1: a gate check failed (``acc check``); 2: bad input or an unusable output,
    one line on stderr; 130: interrupted (Ctrl-C), one line on stderr.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except KeyboardInterrupt:  # pragma: no cover - Ctrl-C while importing
        print("acc: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    from acc.engine.threads import limit_blas_threads

    limit_blas_threads()
    _log_to_stderr(args.verbosity)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            return int(args.handler(args))
    except AccError as exc:
        print(f"acc: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        hint = getattr(args, "interrupt_hint", None)
        print(f"acc: interrupted{'; ' + hint if hint else ''}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # e.g. `acc kinds | head`: the reader left
        with contextlib.suppress(OSError):
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - silence the exit flush
        return 0
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"acc: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE


def exit_without_teardown(status: int) -> NoReturn:
    """End the process with ``status`` once a command is done, without the interpreter's
    teardown.

    After numba has loaded compiled code, Python's finalisation (freeing every module and
    the compiler's objects) takes 0.1-0.15 s, a tenth of a warm ``acc run``, and does
    nothing the command needs.  The exit handlers still run first (logging, temporary
    directories, multiprocessing) and the standard streams are flushed; then the process
    ends with :func:`os._exit`.  When another thread is still running, its end is waited
    for as usual (:func:`sys.exit`).
    """
    import atexit
    import threading

    if threading.active_count() > 1:
        sys.exit(status)
    atexit._run_exitfuncs()  # what the interpreter would run at exit, in the same order
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, OSError, ValueError):  # none, closed, no reader
            stream.flush()
    os._exit(status)


def entry() -> NoReturn:
    """The ``acc`` executable and ``python -m acc``: :func:`main`, then
    :func:`exit_without_teardown`."""
    exit_without_teardown(main())


def _one_line(exc: BaseException) -> str:
    """The message on one line, and never longer than a screenful (values are abbreviated
    where they are named; this is the last guard)."""
    from acc.limits import shorten

    return shorten(str(exc), 1000)


if __name__ == "__main__":  # pragma: no cover
    # ``python -m acc.cli.main``: run the imported module's ``main``, whose COMMANDS the
    # subcommand modules register into (this file runs as ``__main__``, a second copy).
    from acc.cli.main import entry as _entry

    _entry()
