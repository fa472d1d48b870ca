"""Every command handles Ctrl-C as ``acc sweep`` does (one line, exit 130, no partial output);
bad ``acc tune`` arguments are one-line errors before any work."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import acc.campaigns.sweep as sweep_module
import acc.design.analysis as analysis_module
import acc.design.robust_tuning as robust_tuning_module
import acc.design.tuning as tuning_module
import acc.engine.simulate as engine_simulate
from tests.cli_run import ROOT, SHIPPED, SHORT, acc, assert_one_line_error
from tests.test_input_loader import TINY_CAMPAIGN


def _interrupt(*args, **kwargs):
    raise KeyboardInterrupt


@pytest.mark.parametrize("command", ["run", "analyze", "tune", "sweep", "check"])
def test_ctrl_c_is_one_line_exit_130_and_leaves_no_output(tmp_path, monkeypatch, command):
    (tmp_path / "c.toml").write_text(TINY_CAMPAIGN)
    (tmp_path / "g.toml").write_text(
        '[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nmax = 0\n'
    )
    monkeypatch.setattr(engine_simulate, "simulate", _interrupt)
    monkeypatch.setattr(sweep_module, "simulate_chunk", _interrupt)
    monkeypatch.setattr(analysis_module, "analysis_table", _interrupt)
    monkeypatch.setattr(tuning_module, "tune", _interrupt)
    monkeypatch.setattr(robust_tuning_module, "robust_tune", _interrupt)
    out = tmp_path / ("tuned.toml" if command == "tune" else "out")
    source = {"sweep": tmp_path / "c.toml", "check": tmp_path / "g.toml"}.get(command, SHIPPED)
    extra = ["--workers", "1", "--no-progress"] if command in ("sweep", "check") else SHORT
    result = acc(command, source, "--out", out, *extra)
    assert result.status == 130, result.err
    assert len(result.err_lines) == 1 and result.err_lines[0].startswith("acc: interrupted")
    assert "Traceback" not in result.err
    assert not out.exists()


def test_a_real_sigint_during_a_gate_exits_130_in_one_line(tmp_path):
    # long enough (1000 runs of 0.2 M steps, about 10 s alone) that the signals land while
    # chunks remain: at 400 runs of 2 ms steps a loaded machine finished before the signal
    campaign = TINY_CAMPAIGN.replace("samples_per_point = 2", "samples_per_point = 1000")
    campaign = campaign.replace("time_limit_s = 0.3", "time_limit_s = 20.0")
    campaign = campaign.replace("plant_step_s = 0.002", "plant_step_s = 0.0001")
    (tmp_path / "c.toml").write_text(campaign.replace("[set]", "chunk_runs = 2\n[set]"))
    (tmp_path / "g.toml").write_text(
        '[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nmax = 0\n'
    )
    out = tmp_path / "out"
    # started as from a terminal: SIGINT at its default and unblocked whatever this test
    # process inherited (the same process id: the launcher execs the command)
    launcher = ("import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
                "signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT}); "
                "os.execv(sys.executable, [sys.executable, *sys.argv[1:]])")
    cmd = [sys.executable, "-c", launcher, "-m", "acc.cli.main", "check", str(tmp_path / "g.toml")]
    proc = subprocess.Popen(
        [*cmd, "--out", str(out), "--workers", "1", "--no-progress"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 90
        while not list((out / "tiny" / "chunks").glob("runs_*.csv")):
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline
            time.sleep(0.02)
        # as a user would, Ctrl-C again while it runs on: in the full suite (never alone) the
        # first signal has been seen to go unanswered, the campaign running to its end
        for _ in range(5):
            proc.send_signal(signal.SIGINT)
            try:
                _, err = proc.communicate(timeout=3)
                break
            except subprocess.TimeoutExpired:
                continue
        else:
            _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    lines = [line for line in err.splitlines() if not line.startswith("acc: compiling")]
    status = Path("/proc/self/status")
    here = [x for x in status.read_text().splitlines() if x.startswith(("SigIgn", "SigBlk"))
            ] if status.exists() else []
    assert proc.returncode == 130, (err, here)
    assert len(lines) == 1 and lines[0].startswith("acc: interrupted"), err
    assert "re-run" in lines[0]
    assert not (out / "tiny" / "summary.csv").exists()


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--max-evaluations", "-5"], "--max-evaluations"),
        (["--max-evaluations", "0"], "--max-evaluations"),
        (["--dead-time-range-s", "0.2", "0.05"], "--dead-time-range-s"),
        (["--dead-time-range-s", "nan", "0.1"], "--dead-time-range-s"),
        (["--min-phase-margin-deg", "inf"], "--min-phase-margin-deg"),
        (["--max-sensitivity", "1"], "--max-sensitivity"),
        (["--max-complementary-sensitivity", "nan"], "--max-complementary-sensitivity"),
        (["--material-range", "0", "2"], "--material-range"),
        (["--material-range", "3", "2"], "--material-range"),
    ],
)
def test_bad_tune_arguments_are_one_line_before_any_work(tmp_path, monkeypatch, args, needle):
    monkeypatch.setattr(tuning_module, "tune", _interrupt)  # no work may start
    monkeypatch.setattr(robust_tuning_module, "robust_tune", _interrupt)
    result = acc("tune", SHIPPED, "--out", tmp_path / "t.toml", *args)
    assert_one_line_error(result, needle)
    assert not (tmp_path / "t.toml").exists()


def test_tune_into_a_directory_is_refused_before_any_work(tmp_path, monkeypatch):
    monkeypatch.setattr(tuning_module, "tune", _interrupt)
    monkeypatch.setattr(robust_tuning_module, "robust_tune", _interrupt)
    assert_one_line_error(acc("tune", SHIPPED, "--out", tmp_path), "--out", "is a directory")
    assert list(Path(tmp_path).iterdir()) == []
