"""The ``acc`` command line.

``acc run SCENARIO --out DIR [--set section.key=value ...]`` simulates one scenario and writes
``summary.csv``, ``manifest.json``, ``traces.csv``/``traces.npz`` and ``response.png``.

Bad input (missing file, unknown key, wrong type, impossible value) prints one line
``acc: error: ...`` naming the file and key, and exits with status 2.

Options of every command (before or after the subcommand): ``--version``; ``-q/--quiet``
(only warnings and errors: no progress, no result lines, the files are written as usual);
``-v/--verbose`` (debug notes of the ``acc`` logger as well).  ``acc --help`` imports no
numerical library.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from acc.errors import ScenarioError

if TYPE_CHECKING:
    from acc.scenario import Scenario

EXIT_USAGE = 2


class CommandError(Exception):
    """A user error that the command line reports in one line (exit status 2)."""


def load_with_overrides(path: str, assignments: Sequence[str]) -> Scenario:
    """Load a scenario file and apply ``--set section.key=value`` overrides."""
    from acc.scenario import load_scenario, parse_assignment

    scenario = load_scenario(path)
    if assignments:
        scenario = scenario.with_values(dict(parse_assignment(a) for a in assignments))
    return scenario


def _cmd_run(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acc.engine.simulate import simulate
    from acc.output import write_csv, write_manifest, write_traces
    from acc.plots import response_figure

    scenario = load_with_overrides(args.scenario, args.set)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result = simulate(scenario, record_every_steps=1)
    write_csv(out / "summary.csv", result.summary_rows())
    write_manifest(out / "manifest.json", result, {"overrides": list(args.set)})
    csv_every = scenario.simulation.steps_per_control
    write_traces(out, result, every=csv_every)
    fig = response_figure(result, title=f"{Path(args.scenario).name}: {scenario.controller.kind}")
    fig.savefig(out / "response.png", dpi=120)
    plt.close(fig)
    m = result.metrics
    say(
        args,
        f"{args.scenario}: machining {m['machining_time_s'][0]:.2f} s "
        f"(constant safe feed {m['conventional_time_s'][0]:.2f} s, "
        f"productivity {m['productivity_gain_pct'][0]:+.1f} %), "
        f"RMS force error {m['rms_error_N'][0]:.1f} N, peak {m['peak_force_N'][0]:.0f} N",
        f"wrote {out}/summary.csv, manifest.json, traces.csv, traces.npz, response.png",
    )
    return 0


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


def say(args: argparse.Namespace, *lines: str) -> None:
    """Print result lines on stdout unless ``--quiet``."""
    if getattr(args, "verbosity", 0) >= 0:
        for line in lines:
            print(line)


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

    for module in ("acc.cli.design", "acc.cli.campaigns"):
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name != module:
                raise


def _log_to_stderr(verbosity: int = 0) -> None:
    """Progress notes of the ``acc`` logger (e.g. a first compilation) on stderr, once; the
    level follows ``--quiet`` (WARNING), default (INFO) or ``--verbose`` (DEBUG)."""
    import logging

    class StderrHandler(logging.StreamHandler):
        # writes to the sys.stderr of the moment (one replaced after the first command, as
        # by pytest's capture, is followed instead of written to after it is closed)
        @property
        def stream(self) -> object:
            return sys.stderr

        @stream.setter
        def stream(self, value: object) -> None:
            pass

    log = logging.getLogger("acc")
    if not any(type(h).__name__ == "StderrHandler" for h in log.handlers):
        handler = StderrHandler()
        handler.setFormatter(logging.Formatter("acc: %(message)s"))
        log.addHandler(handler)
    log.setLevel({-1: logging.WARNING, 0: logging.INFO}.get(verbosity, logging.DEBUG))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``acc`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    from acc.engine.threads import limit_blas_threads

    limit_blas_threads()
    _log_to_stderr(args.verbosity)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            return int(args.handler(args))
    except (ScenarioError, CommandError) as exc:
        print(f"acc: error: {exc}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    # `python -m acc.cli.main`: run the importable module's main, whose COMMANDS the command
    # modules register into (this file, run as __main__, is a second copy of the module)
    from acc.cli.main import main as _main

    sys.exit(_main())
