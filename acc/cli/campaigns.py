"""``acc sweep`` and ``acc check``: registered into :data:`acc.cli.COMMANDS` on import.

``acc sweep CAMPAIGN --out DIR [--resume] [--backend local|dask --scheduler ADDRESS]``
simulates a campaign in chunks and writes ``DIR/summary.csv``, ``DIR/report.txt`` and the
figures ``metrics.png``, ``failure_rate.png`` and (with traces) ``force_bands.png``.

``acc check GATE [--out DIR] [--junit PATH]`` sweeps the gate's campaigns, prints the pass/fail
table, writes JUnit XML and exits 1 if a check fails; re-run into the same ``--out`` it
continues interrupted sweeps and reuses finished ones.

Options, ``--out`` and ``--junit`` are checked before any work; Ctrl-C prints one line and
exits with status 130.
"""

from __future__ import annotations

import argparse
import functools
import sys
import tempfile
from collections import ChainMap
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from acc.cli.main import COMMANDS, EXIT_INTERRUPTED, say

if TYPE_CHECKING:  # numpy stays out of `acc --help`
    import numpy as np

    from acc.cli.figure_process import FigureProcess

EXIT_FAILED_CHECK = 1


def _add_execution_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--backend", choices=("local", "dask"), default="local", help="where runs are simulated"
    )
    p.add_argument(
        "--scheduler", help="Dask scheduler address, e.g. tcp://host:8786 (with --backend dask)"
    )
    p.add_argument(
        "--workers", type=int, help="local worker processes (default: all cores; 1: in-process)"
    )
    p.add_argument("--chunk-runs", type=int, help="runs per chunk (default: the campaign's)")
    p.add_argument(
        "--no-progress",
        action="store_true",
        help="no progress (default: a bar on a terminal, a line per tenth of the runs or "
        "30 s otherwise)",
    )


def _add_sweep_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("campaign", help="campaign TOML file")
    p.add_argument("--out", required=True, help="sweep directory")
    p.add_argument("--resume", action="store_true", help="continue an interrupted sweep in --out")
    p.add_argument("--no-figures", action="store_true", help="write no figures")
    _add_execution_args(p)


def _sweep_options(args: argparse.Namespace) -> dict:
    """The execution options, checked (one-line error before any work)."""
    from acc.campaigns.sweep import check_execution

    check_execution(args.backend, args.workers, args.scheduler, args.chunk_runs)
    return {
        "backend": args.backend,
        "scheduler": args.scheduler,
        "workers": args.workers,
        "chunk_runs": args.chunk_runs,
        "progress": not args.no_progress and getattr(args, "verbosity", 0) >= 0,
    }


def _figures(
    out: Path,
    summary: Mapping[str, np.ndarray],
    swept: tuple[str, ...],
    written: list[Path] | None = None,
    model: str = "force",
) -> list[str]:
    """Draw the sweep's figures into ``out``; each path is appended to ``written`` first.
    The runs are grouped and measured as the lab's report does (:data:`LAB_REPORTS`)."""
    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acc.campaigns.plots import failure_rate_figure, force_bands_figure, metrics_figure

    written = [] if written is None else written
    names: list[str] = []

    def save(fig: object, name: str) -> None:
        written.append(out / name)
        try:
            fig.savefig(out / name, dpi=110)  # type: ignore[attr-defined]
        finally:
            plt.close(fig)  # type: ignore[arg-type]
        names.append(name)

    from acc.campaigns.report import LAB_REPORTS, is_number_column

    by, reported = LAB_REPORTS[model]
    if by not in summary:  # (every run raised)
        summary = ChainMap({by: np.full(len(summary["failed"]), "(all)")}, summary)
    metrics = [m for m in reported if m in summary and is_number_column(summary, m)]
    if metrics:  # (none when every run raised)
        save(metrics_figure(summary, metrics, by=by, swept=swept), "metrics.png")
    numeric = [k for k in swept if is_number_column(summary, k)]
    if numeric:
        save(failure_rate_figure(summary, numeric[0], by=by), "failure_rate.png")
    traces = None
    if any((out / "chunks").glob("*.npz")):  # (the sweep module only when there are traces)
        from acc.campaigns.sweep import read_traces

        traces = read_traces(out)
    if traces is not None and traces["time_s"].size and np.isfinite(traces["force_N"]).any():
        save(force_bands_figure(traces, summary, by=by), "force_bands.png")
    return names


#: What :func:`_figures` draws with, besides matplotlib.
FIGURE_MODULES = ("acc.campaigns.plots",)


#: The figures a sweep may draw (all removed if the sweep fails: no figure without a summary).
FIGURE_NAMES = ("metrics.png", "failure_rate.png", "force_bands.png")


def _cmd_sweep(args: argparse.Namespace) -> int:
    import contextlib

    from acc.cli.figure_process import FigureProcess

    with contextlib.ExitStack() as stack:
        # the figures are drawn by a second process that imports matplotlib now, on the
        # core this one leaves free while it imports and loads the campaign
        figures = None
        if not args.no_figures:
            figures = stack.enter_context(FigureProcess(imports=FIGURE_MODULES))
        return _sweep_command(args, figures)


def _sweep_command(args: argparse.Namespace, figures: FigureProcess | None) -> int:
    from acc.campaigns.campaign import load_campaign
    from acc.campaigns.report import report_columns, report_text, write_report
    from acc.campaigns.summary_columns import summary_for_report
    from acc.campaigns.sweep import run_sweep
    from acc.output import check_output_dir

    options = _sweep_options(args)
    out = check_output_dir(args.out)
    campaign = load_campaign(args.campaign)
    written: list[Path] = []
    report: list[str] = []

    def finish(summary_path: Path) -> None:
        """Report and figures from the finished summary, before it becomes summary.csv."""
        # a large summary is read a column at a time: the report holds one number column
        summary = summary_for_report(summary_path, report_columns(campaign))
        swept = tuple(k for k in campaign.swept_keys if k in summary)
        names: list[str] = []
        if figures is not None:
            written.extend(out / name for name in FIGURE_NAMES)  # whoever draws them
            figures.call("acc.cli.campaigns:_figures", out, summary, swept, None,
                         campaign.model)
            names = figures.wait()
        text = report_text(campaign.name, summary, names, campaign.model)
        written.append(out / "report.txt")
        write_report(out / "report.txt", text)
        report[:] = [text, *names]

    # matplotlib imported while the last chunks run (a core is free then), when no second
    # process does it
    ahead: Callable[[], None] | None = None
    if figures is not None and not figures.forked:
        from acc.cli.figure_process import import_plotting

        ahead = functools.partial(import_plotting, FIGURE_MODULES)
    try:
        outcome = run_sweep(campaign, out, resume=args.resume, before_commit=finish,
                            ahead=ahead, **options)
    except KeyboardInterrupt:
        _remove(written)
        kept = (out / "chunks").is_dir()
        print(
            "acc: interrupted; "
            + (
                f"finished chunks are kept in {out}/chunks, continue with "
                f"`acc sweep {args.campaign} --out {out} --resume`"
                if kept
                else "nothing was kept"
            ),
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    except BaseException:
        _remove(written)  # all or nothing: no report or figure without summary.csv
        raise
    text, *names = report
    say(
        args,
        text.rstrip("\n"),
        f"simulated {outcome.simulated_runs} of {outcome.runs} runs; "
        f"wrote {out}/summary.csv, report.txt" + "".join(f", {f}" for f in names),
    )
    return 0


def _remove(paths: list[Path]) -> None:
    for path in paths:
        path.unlink(missing_ok=True)


def _add_check_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("gate", help="gate TOML file")
    p.add_argument(
        "--out",
        help="directory for the sweeps and junit.xml (default: none: the sweeps go to a "
        "temporary directory, removed at the end, and nothing is written unless --junit is "
        "given); re-running into the same directory continues interrupted sweeps and reuses "
        "finished ones",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue the gate's sweeps in --out (what re-running does anyway; for symmetry "
        "with acc sweep)",
    )
    p.add_argument("--junit", help="JUnit XML path (default: OUT/junit.xml with --out; "
                   "without --out, none)")
    _add_execution_args(p)


def _cmd_check(args: argparse.Namespace) -> int:
    from acc.campaigns.gate import load_gate, outcome_table, run_gate, write_junit
    from acc.errors import OutputError
    from acc.output import check_output_dir, check_output_file

    options = _sweep_options(args)
    if args.resume and not args.out:
        raise OutputError("--resume needs --out (the directory holding the gate's sweeps)")
    if args.out:
        check_output_dir(args.out)
        junit = Path(args.junit) if args.junit else Path(args.out) / "junit.xml"
        if args.junit or Path(args.out).is_dir():
            check_output_file(junit, "--junit")
    elif args.junit:
        junit = Path(args.junit)
        check_output_file(junit, "--junit")
    else:
        junit = None  # a quick look: nothing written
    gate = load_gate(args.gate)
    args.interrupt_hint = (
        f"finished sweeps are kept; re-run `acc check {args.gate} --out {args.out}` to continue"
        if args.out
        else "nothing was kept (no --out)"
    )
    if args.out:
        outcomes = run_gate(gate, Path(args.out), **options)
    else:
        with tempfile.TemporaryDirectory(prefix="acc-check-") as tmp:
            outcomes = run_gate(gate, Path(tmp), **options)
    if junit is not None:
        write_junit(junit, gate, outcomes)
    failed = sum(not o.passed for o in outcomes)
    # --quiet keeps the verdict line when a check fails
    say(args, outcome_table(outcomes))
    written = (f"wrote {junit}" if junit is not None
               else "nothing written (--out DIR keeps the sweeps and junit.xml)")
    verdict = f"{gate.name}: {len(outcomes) - failed} passed, {failed} failed; {written}"
    if failed or getattr(args, "verbosity", 0) >= 0:
        print(verdict)
    return EXIT_FAILED_CHECK if failed else 0


COMMANDS["sweep"] = (
    "simulate a campaign (grid / random sweep) in resumable chunks",
    _add_sweep_args,
    _cmd_sweep,
)
COMMANDS["check"] = (
    "run a gate: campaigns against metric thresholds, JUnit XML, exit 1 on failure",
    _add_check_args,
    _cmd_check,
)
