"""Command-line conventions: ``--version``, ``--quiet``/``--verbose`` before or after the
subcommand, ``--help`` without the numerical libraries, progress as plain lines off a
terminal."""

import logging
import subprocess
import sys
from pathlib import Path

import pytest

from acc.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = str(ROOT / "experiments" / "kim_chung_2001.toml")

#: 4 runs in 4 chunks of one: progress at 25, 50, 75, 100 %.
TINY = """
[campaign]
name = "tiny"
seed = 5
samples_per_point = 2
chunk_runs = 1

[set]
simulation.plant_step_s = 0.002
simulation.time_limit_s = 1.0
workpiece.segment_length_mm = [2.0]
workpiece.radial_depth_mm = [3.0]
workpiece.axial_depth_mm = [10.0]

[grid]
controller.kind = ["pi", "constant"]
"""


def test_version_names_acc_and_its_numerical_libraries(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("acc ") and "Python" in out and "control " in out


@pytest.mark.parametrize("argv", [["--help"], ["analyze", "--help"], ["sweep", "--help"]])
def test_help_imports_no_numerical_library(argv):
    # the modules `acc --help` must not import (each costs 0.1-1 s); timings: benchmarks/
    code = (
        "import sys\n"
        "from acc.cli.main import main\n"
        "try:\n"
        f"    main({argv!r})\n"
        "except SystemExit:\n"
        "    pass\n"
        "heavy = {'numpy', 'scipy', 'control', 'matplotlib', 'numba', 'tqdm'}\n"
        "print(sorted(heavy & set(sys.modules)))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, check=True)
    assert done.stdout.strip().splitlines()[-1] == "[]"


def test_quiet_silences_result_lines_before_or_after_the_subcommand(capsys):
    assert main(["kinds"]) == 0
    assert "dob_pi" in capsys.readouterr().out
    for argv in (["-q", "kinds"], ["kinds", "--quiet"]):
        assert main(argv) == 0
        captured = capsys.readouterr()
        assert captured.out == "" and captured.err == ""


def test_verbose_shows_debug_notes(tmp_path, caplog):
    with caplog.at_level(logging.DEBUG, logger="acc"):
        status = main(["analyze", SHIPPED, "--out", str(tmp_path), "--kinds", "pi", "-v"])
    assert status == 0
    assert any(r.levelno == logging.DEBUG and "analysing pi" in r.getMessage()
               for r in caplog.records)
    assert (tmp_path / "analysis_pi.png").exists()


def test_sweep_off_a_terminal_reports_plain_lines_and_nothing_when_quiet(tmp_path, capsys,
                                                                          caplog):
    campaign = tmp_path / "tiny.toml"
    campaign.write_text(TINY)
    args = ["sweep", str(campaign), "--workers", "1", "--no-figures"]
    with caplog.at_level(logging.INFO, logger="acc"):
        assert main([*args, "--out", str(tmp_path / "a")]) == 0
    lines = [r.getMessage() for r in caplog.records if "runs (" in r.getMessage()]
    assert [line.split(",")[0] for line in lines] == [
        "tiny: 1/4 runs (25 %)", "tiny: 2/4 runs (50 %)", "tiny: 3/4 runs (75 %)",
        "tiny: 4/4 runs (100 %)",
    ]
    captured = capsys.readouterr()
    assert "\r" not in captured.err  # no bar redrawn in a log
    assert "simulated 4 of 4 runs" in captured.out
    caplog.clear()
    assert main([*args, "--out", str(tmp_path / "b"), "-q"]) == 0
    assert not [r for r in caplog.records if r.levelno < logging.WARNING]
    assert capsys.readouterr().out == ""
