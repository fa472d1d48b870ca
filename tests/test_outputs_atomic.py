"""Outputs are all or nothing: a failed or interrupted command leaves no result-like
directory; ``manifest.json`` is strict JSON; unusable output paths are refused before work."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import acc.engine.simulate as engine_simulate
import acc.output as output_module
from tests.cli_run import SHIPPED, SHORT, acc, assert_one_line_error
from tests.test_input_loader import TINY_CAMPAIGN


def _leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


def test_a_simulation_that_raises_is_one_line_and_leaves_no_directory(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("injected fault in the engine")

    monkeypatch.setattr(engine_simulate, "simulate", broken)
    result = acc("run", SHIPPED, "--out", tmp_path / "out", *SHORT)
    assert_one_line_error(result, "injected fault")
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("fault", [OSError(28, "No space left on device"), KeyboardInterrupt()])
def test_a_failure_while_writing_outputs_leaves_nothing(tmp_path, monkeypatch, fault):
    def broken(directory, result, every=1):
        (Path(directory) / "traces.csv.tmp").write_text("half")
        raise fault

    monkeypatch.setattr(output_module, "write_traces", broken)
    result = acc("run", SHIPPED, "--out", tmp_path / "deep" / "out", *SHORT)
    assert result.status == (130 if isinstance(fault, KeyboardInterrupt) else 2)
    assert len(result.err_lines) == 1 and "Traceback" not in result.err
    if isinstance(fault, OSError):  # the disk that is full is named by the output it took
        assert str(tmp_path / "deep" / "out") in result.err and "No space left" in result.err
    assert _leftovers(tmp_path) == []  # not even the parent directory made for it


@pytest.mark.parametrize("command", ["run", "analyze", "sweep"])
def test_an_empty_out_is_refused_not_the_current_directory(tmp_path, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    campaign = tmp_path / "c.toml"
    campaign.write_text(TINY_CAMPAIGN)
    source = {"run": SHIPPED, "analyze": SHIPPED, "sweep": campaign}[command]
    result = acc(command, source, "--out", "", *(SHORT if command == "run" else ()))
    assert_one_line_error(result, "--out", "empty")
    assert _leftovers(tmp_path) == ["c.toml"]


def test_an_existing_output_directory_is_untouched_by_a_failed_run(tmp_path, monkeypatch):
    out = tmp_path / "out"
    assert acc("run", SHIPPED, "--out", out, *SHORT).status == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def broken(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(output_module, "write_manifest", broken)
    result = acc("run", SHIPPED, "--out", out, *SHORT, "--set", "controller.reference_force_N=450")
    assert result.status == 130
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert _leftovers(tmp_path) == ["out"]


def _strict(text: str) -> dict:
    def refuse(name: str) -> None:
        raise ValueError(f"not strict JSON: {name}")

    return json.loads(text, parse_constant=refuse)


def test_manifest_is_strict_json_when_gains_are_given(tmp_path):
    out = tmp_path / "out"
    result = acc(
        "run", SHIPPED, "--out", out, *SHORT,
        "--set", "controller.kp_per_N=0.002", "--set", "controller.ki_per_N_s=0.01",
    )
    assert result.status == 0, result.err
    manifest = _strict((out / "manifest.json").read_text())
    assert manifest["derived"]["design_crossover_rad_s"] == [None]
    assert manifest["derived"]["kp_per_N"] == [0.002]


@pytest.mark.parametrize("command", ["run", "analyze", "sweep", "check"])
def test_an_out_that_is_a_file_is_refused_before_any_work(tmp_path, command):
    target = tmp_path / "a_file"
    target.write_text("keep me")
    campaign = tmp_path / "c.toml"
    campaign.write_text(TINY_CAMPAIGN)
    gate = tmp_path / "g.toml"
    gate.write_text('[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nmax = 0\n')
    source = {"run": SHIPPED, "analyze": SHIPPED, "sweep": campaign, "check": gate}[command]
    result = acc(command, source, "--out", target)
    assert_one_line_error(result, "--out", str(target), "not a directory")
    assert target.read_text() == "keep me"
    assert acc(command, source, "--out", "/dev/null").status == 2


@pytest.mark.parametrize("junit", ["missing_dir/j.xml", "."])
def test_a_bad_junit_path_is_refused_before_any_sweep(tmp_path, junit):
    (tmp_path / "c.toml").write_text(TINY_CAMPAIGN)
    gate = tmp_path / "g.toml"
    gate.write_text('[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nmax = 0\n')
    out = tmp_path / "out"
    result = acc("check", gate, "--out", out, "--junit", tmp_path / junit, "--no-progress")
    assert_one_line_error(result, "--junit")
    assert not out.exists()
    assert not list(tmp_path.glob("**/.*.tmp"))


def test_progress_notes_go_to_the_current_stderr_of_each_call():
    """``main`` run twice in one process with stderr swapped in between (notebooks, tests):
    the engine's notes reach the second stderr, never a closed stream (a logging traceback)."""
    import contextlib
    import io
    import logging

    from acc.cli.main import _log_to_stderr

    first = io.StringIO()
    with contextlib.redirect_stderr(first):
        _log_to_stderr()
    first.close()
    second = io.StringIO()
    with contextlib.redirect_stderr(second):
        logging.getLogger("acc").info("compiling the simulation engine for %r", "pi")
    assert second.getvalue() == "acc: compiling the simulation engine for 'pi'\n"
