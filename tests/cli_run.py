"""Running the ``acc`` command and the experiment scripts in-process, and what a one-line
error must look like."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from acc.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = str(ROOT / "experiments" / "kim_chung_2001.toml")
GEOMETRIC = str(ROOT / "experiments" / "current_sensing_geometric.toml")
#: A short run of the shipped scenario (2 ms step, 0.3 s): milliseconds once compiled.
SHORT = ["--set", "simulation.plant_step_s=0.002", "--set", "simulation.time_limit_s=0.3"]

#: ``section.key`` (maybe with an index) or ``[section]`` in a message.
KEY_RE = re.compile(r"(\b[a-z_]+\.[A-Za-z_0-9]+(\[\d+\])?\b|\[[a-z_]+\])")


@dataclass
class Outcome:
    """Exit status and captured output of one command."""

    status: int
    out: str
    err: str

    @property
    def err_lines(self) -> list[str]:
        """stderr lines, without the note that the engine is being compiled."""
        return [line for line in self.err.splitlines() if not line.startswith("acc: compiling")]


def acc(*argv: str) -> Outcome:
    """Run ``acc argv...`` in this process; a traceback escaping ``main`` fails the test."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main([str(a) for a in argv])
        except SystemExit as exc:  # argparse usage errors
            status = int(exc.code or 0)
    return Outcome(status, out.getvalue(), err.getvalue())


def experiment_module(name: str) -> ModuleType:
    """The script ``experiments/<name>.py`` loaded as a module (its ``main`` not run)."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "experiments" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclasses look their module up
    try:
        spec.loader.exec_module(mod)
    finally:
        sys.modules.pop(spec.name, None)
    return mod


def assert_one_line_error(result: Outcome, *needles: str) -> str:
    """Exit status 2 and exactly one stderr line ``acc: error: ...`` holding every needle."""
    assert result.status == 2, (result.status, result.err[-2000:])
    lines = result.err_lines
    assert len(lines) == 1, result.err[-2000:]
    line = lines[0]
    assert line.startswith("acc: error: "), line
    assert "Traceback" not in result.err
    for needle in needles:
        assert needle in line, (needle, line)
    return line
