"""Gates that cannot pass vacuously: empty selections and unfinished runs fail, every check
says how many runs it used, malformed gates are one line before any sweep, and a gate can be
re-run into the same ``--out``.  "Not reached" is NaN in the summary, report and gates."""

from __future__ import annotations

import csv
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from tests.cli_run import SHIPPED, acc, assert_one_line_error

#: Half of the runs cannot finish the part before the time limit (override capped at 0.2).
HALF_FINISH = f"""[campaign]
name = "half_finish"
base = "{Path(SHIPPED).as_posix()}"
seed = 1
samples_per_point = 2
chunk_runs = 4
[set]
simulation.plant_step_s = 0.002
simulation.time_limit_s = 6.0
workpiece.segment_length_mm = [4.0, 4.0]
workpiece.radial_depth_mm = [2.0, 3.0]
workpiece.axial_depth_mm = [10.0, 10.0]
[grid]
controller.override_max = [2.0, 0.2]
"""

CHECKS = """
[[check]]
name = "every run finishes within 5 s"
campaign = "half.toml"
metric = "machining_time_s"
statistic = "max"
max = 5.0

[[check]]
name = "no unstable PI run (typo: PI)"
campaign = "half.toml"
statistic = "failed_count"
where = { controller = "PI" }
max = 0

[[check]]
name = "no unstable run at 500 N (an integer)"
campaign = "half.toml"
statistic = "failed_count"
where = { reference_force_N = 500 }
max = 0

[[check]]
name = "finishing runs finish within 5 s"
campaign = "half.toml"
metric = "machining_time_s"
statistic = "max"
where = { "controller.override_max" = 2.0 }
max = 5.0

[[check]]
name = "failed fraction of nothing"
campaign = "half.toml"
statistic = "failed_fraction"
where = { controller = "constant" }
max = 0.5
"""


@pytest.fixture(scope="module")
def judged(tmp_path_factory):
    d = tmp_path_factory.mktemp("gate")
    (d / "half.toml").write_text(HALF_FINISH)
    (d / "g.toml").write_text(CHECKS)
    result = acc("check", d / "g.toml", "--out", d / "out", "--workers", "1", "--no-progress")
    return d, result


def _cases(d: Path) -> dict[str, ET.Element]:
    root = ET.parse(d / "out" / "junit.xml").getroot()
    return {c.get("name"): c for c in root.iter("testcase")}


def test_a_selection_that_matches_no_run_fails_whatever_the_statistic(judged):
    d, result = judged
    assert result.status == 1
    cases = _cases(d)
    for name in ("no unstable PI run (typo: PI)", "failed fraction of nothing"):
        assert cases[name].find("failure") is not None, name
        assert "selected 0 runs" in cases[name].find("system-out").text
        assert "matches no runs" in cases[name].find("system-out").text


def test_unfinished_runs_are_counted_and_fail_a_machining_time_check(judged):
    d, _ = judged
    cases = _cases(d)
    text = cases["every run finishes within 5 s"].find("system-out").text
    assert cases["every run finishes within 5 s"].find("failure") is not None
    assert "over 4 runs = nan" in text
    assert "2 of 4 completed run(s) have no value of machining_time_s" in text
    # the runs that can finish pass the same check
    assert cases["finishing runs finish within 5 s"].find("failure") is None


def test_a_number_selects_a_numeric_column_by_value(judged):
    d, _ = judged
    case = _cases(d)["no unstable run at 500 N (an integer)"]
    assert case.find("failure") is None
    assert "selected 4 runs" in case.find("system-out").text


def test_the_table_reports_selected_and_used_runs(judged):
    _, result = judged
    header = result.out.splitlines()[0].split()
    assert header[:5] == ["check", "statistic", "selected", "runs", "measured"]
    assert "Notes:" in result.out and "the selection matches no runs" in result.out


def test_a_gate_can_be_rerun_into_the_same_out_and_continues_an_interrupted_sweep(judged):
    d, first = judged
    out = d / "rerun"
    shutil.copytree(d / "out", out)
    again = acc("check", d / "g.toml", "--out", out, "--workers", "1", "--no-progress")
    assert again.status == first.status and again.out.replace("rerun", "out") == first.out
    # an interrupted sweep: no summary, a chunk lost; re-running (or --resume) finishes it
    sweep_dir = out / "half_finish"
    (sweep_dir / "summary.csv").unlink()
    for chunk in (sweep_dir / "chunks").glob("runs_*"):
        chunk.unlink()
    resumed = acc(
        "check", d / "g.toml", "--out", out, "--workers", "1", "--no-progress", "--resume"
    )
    assert resumed.status == first.status
    assert (sweep_dir / "summary.csv").read_bytes() == (
        d / "out" / "half_finish" / "summary.csv"
    ).read_bytes()


def test_not_reached_is_nan_in_the_summary_the_report_and_the_gate(tmp_path):
    text = HALF_FINISH.replace("simulation.time_limit_s = 6.0", "simulation.time_limit_s = 1.0")
    (tmp_path / "half.toml").write_text(text)
    out = tmp_path / "sweep"
    result = acc("sweep", tmp_path / "half.toml", "--out", out, "--workers", "1", "--no-progress")
    assert result.status == 0, result.err
    with (out / "summary.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:  # the second segment is never reached within 1 s
        assert row["peak_force_N_seg2"] == "nan" and row["settling_time_s_seg2"] == "nan"
        assert row["machining_time_s"] == "nan"
        assert all("inf" not in v for v in row.values())
    report = (out / "report.txt").read_text()
    assert "inf" not in report and "4 of them never finished the part" in report
    (tmp_path / "g.toml").write_text(
        '[[check]]\ncampaign = "half.toml"\nmetric = "peak_force_N_seg2"\n'
        'statistic = "max"\nmax = 1e9\n'
    )
    gate = acc("check", tmp_path / "g.toml", "--out", tmp_path / "g", "--workers", "1",
               "--no-progress")
    assert gate.status == 1 and "FAIL" in gate.out and "-inf" not in gate.out


@pytest.mark.parametrize(
    ("gate", "needles"),
    [
        ('gate = 5\n[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nmax = 0\n',
         ["[gate] must be a table"]),
        ("check = [1]\n", ["check[0]", "expected a table"]),
        ('[[check]]\ncampaign = "c.toml"\nmetric = "controller"\nstatistic = "max"\nmax = 1\n',
         ["check[0].metric", "text column"]),
        ('[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nwhere = 5\nmax = 0\n',
         ["check[0].where"]),
        ('[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nmax = nan\n',
         ["check[0].max", "finite"]),
        ('[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nmin = 2\nmax = 1\n',
         ["check[0]", "min = 2 > max = 1"]),
        ('[[check]]\ncampaign = "nope.toml"\nstatistic = "failed_count"\nmax = 0\n',
         ["check[0].campaign", "no such campaign file"]),
        ('[[check]]\ncampaign = "c.toml"\nstatistic = "failed_count"\nmax = 0\n'
         '[[check]]\ncampaign = "same.toml"\nstatistic = "failed_count"\nmax = 0\n',
         ["check[1].campaign", "'c'", "own [campaign] name"]),
    ],
)
def test_malformed_gates_are_one_line_before_any_sweep(tmp_path, gate, needles):
    campaign = HALF_FINISH.replace('name = "half_finish"', 'name = "c"')
    (tmp_path / "c.toml").write_text(campaign)
    (tmp_path / "same.toml").write_text(campaign.replace("seed = 1", "seed = 2"))
    (tmp_path / "g.toml").write_text(gate)
    out = tmp_path / "out"
    result = acc("check", tmp_path / "g.toml", "--out", out, "--workers", "1", "--no-progress")
    assert_one_line_error(result, str(tmp_path / "g.toml"), *needles)
    assert not out.exists()
