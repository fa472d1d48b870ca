"""acc run's and acc sweep's figures drawn in a forked process: the same PNG bytes as drawn
in-process, a failure in the child as one line, no child left behind."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_SCRIPT = textwrap.dedent(
    """
    import os, sys
    from pathlib import Path
    from acc.cli.common import CommandError
    from acc.cli.figure_process import FigureProcess, draw_figures
    from acc.engine.simulate import simulate
    from acc.scenarios.force import load_scenario

    out = Path(sys.argv[1])
    sc = load_scenario({scenario!r}).with_values(
        {{"simulation.plant_step_s": 0.002, "simulation.time_limit_s": 1.0}})
    with FigureProcess() as figures:
        forked = figures.forked
        result = simulate(sc)
        figures.draw(result, [("response_figure", out / "forked.png", "t")])
        figures.wait()
    draw_figures(result, [("response_figure", out / "here.png", "t")])
    print("forked", forked)
    try:
        with FigureProcess() as figures:
            figures.draw(result, [("no_such_figure", out / "x.png", "t")])
            figures.wait()
    except CommandError as exc:
        print("error", str(exc))
    try:
        os.waitpid(-1, os.WNOHANG)
        print("children left")
    except ChildProcessError:
        print("no children")
    """
)


def test_forked_figure_equals_in_process_and_failure_is_one_line(tmp_path: Path) -> None:
    code = _SCRIPT.format(scenario=str(ROOT / "experiments" / "kim_chung_2001.toml"))
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True,
                          text=True, check=True, timeout=600,
                          env={**__import__("os").environ, "MPLBACKEND": "Agg"})
    lines = done.stdout.splitlines()
    assert "forked True" in lines
    assert (tmp_path / "forked.png").read_bytes() == (tmp_path / "here.png").read_bytes()
    errors = [line for line in lines if line.startswith("error ")]
    assert len(errors) == 1
    assert "drawing the figures failed: AttributeError" in errors[0]
    assert "no_such_figure" in errors[0]
    assert not (tmp_path / "x.png").exists()
    assert lines[-1] == "no children"
    assert done.stderr.strip() == ""


_SWEEP_SCRIPT = textwrap.dedent(
    """
    import os, sys
    from pathlib import Path
    import acc.cli.campaigns as cc

    campaign, out, pid_file, fail = sys.argv[1:5]
    drawn = cc._figures

    def spy(*args, **kwargs):  # forked after this patch: the child runs it too
        Path(pid_file).write_text(str(os.getpid()))
        if fail == "1":
            raise RuntimeError("no figure today")
        return drawn(*args, **kwargs)

    cc._figures = spy
    from acc.cli.main import main
    rc = main(["sweep", campaign, "--out", out, "--workers", "1", "--no-progress", "-q"])
    print("parent", os.getpid(), "rc", rc)
    try:
        os.waitpid(-1, os.WNOHANG)
        print("children left")
    except ChildProcessError:
        print("no children")
    """
)


def _sweep(tmp_path: Path, name: str, fail: bool) -> tuple[subprocess.CompletedProcess, Path]:
    from tests.campaign_files import SMALL, write

    campaign = write(tmp_path, "small.toml", SMALL)
    out = tmp_path / name
    done = subprocess.run(
        [sys.executable, "-c", _SWEEP_SCRIPT, str(campaign), str(out),
         str(tmp_path / f"{name}.pid"), "1" if fail else "0"],
        capture_output=True, text=True, timeout=600, cwd=ROOT,
        env={**__import__("os").environ, "MPLBACKEND": "Agg"},
    )
    return done, out


def test_sweep_figures_are_drawn_by_the_second_process_as_in_process(tmp_path: Path) -> None:
    import numpy as np

    from acc.campaigns.campaign import load_campaign
    from acc.campaigns.report import report_columns
    from acc.campaigns.summary_columns import summary_for_report
    from acc.cli.campaigns import _figures

    done, out = _sweep(tmp_path, "forked", fail=False)
    _, parent, _, rc = done.stdout.split()[:4]
    assert rc == "0", done.stderr
    assert (tmp_path / "forked.pid").read_text() != parent  # drawn by another process
    assert done.stdout.splitlines()[-1] == "no children"
    assert "metrics.png" in (out / "report.txt").read_text()
    # the same bytes as the figure drawn here from the same summary
    campaign = load_campaign(tmp_path / "small.toml")
    summary = summary_for_report(out / "summary.csv", report_columns(campaign))
    here = tmp_path / "here"
    here.mkdir()
    swept = tuple(k for k in campaign.swept_keys if k in summary)
    names = _figures(here, summary, swept, None, campaign.model)
    assert "metrics.png" in names
    for name in names:
        assert (out / name).read_bytes() == (here / name).read_bytes(), name
    assert np.all(summary["failed"] == 0)


def test_a_sweep_figure_failing_in_the_second_process_leaves_no_output(tmp_path: Path) -> None:
    done, out = _sweep(tmp_path, "failed", fail=True)
    _, parent, _, rc = done.stdout.split()[:4]
    assert rc == "2"  # the command's error status
    assert (tmp_path / "failed.pid").read_text() != parent
    assert done.stdout.splitlines()[-1] == "no children"
    errors = [line for line in done.stderr.splitlines() if "no figure today" in line]
    assert errors and "drawing the figures failed: RuntimeError: no figure today" in errors[0]
    assert not (out / "summary.csv").exists()
    assert not (out / "report.txt").exists()
    assert not list(out.glob("*.png"))
