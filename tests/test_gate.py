"""Gates: thresholds just below / above the measured value, JUnit XML, exit status."""

from __future__ import annotations

import math
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import tomllib

from acc.campaigns.campaign import load_campaign
from acc.campaigns.gate import GateError, load_gate
from acc.campaigns.sweep import read_summary, run_sweep
from acc.cli.main import main
from tests.campaign_files import SMALL, WITH_UNSTABLE, write

ROOT = Path(__file__).resolve().parents[1]


def _gate(campaign: str, bound: str, value: float, statistic: str = "p95") -> str:
    return f"""
[gate]
name = "g"

[[check]]
name = "PI p95 RMS force error"
campaign = "{campaign}"
metric = "rms_error_N"
statistic = "{statistic}"
where = {{ controller = "pi" }}
{bound} = {value!r}
"""


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """The campaign and its PI 95th-percentile RMS error, computed from the summary."""
    d = tmp_path_factory.mktemp("gate")
    write(d, "small.toml", SMALL)
    campaign = load_campaign(d / "small.toml")
    summary = read_summary(run_sweep(campaign, d / "ref", workers=1, progress=False).summary_path)
    pi = summary["rms_error_N"][summary["controller"] == "pi"]
    assert len(pi) == 6
    return d, float(np.percentile(pi, 95))


@pytest.mark.parametrize(
    ("bound", "direction", "passes"),
    [("max", -1, False), ("max", +1, True), ("min", +1, False), ("min", -1, True)],
)
def test_threshold_just_below_fails_just_above_passes(measured, bound, direction, passes, capsys):
    d, value = measured
    threshold = value * (1 + direction * 1e-9)
    gate = write(d, f"gate_{bound}_{direction}.toml", _gate("small.toml", bound, threshold))
    out = d / f"out_{bound}_{direction}"
    status = main(["check", str(gate), "--out", str(out), "--workers", "1", "--no-progress"])
    assert status == (0 if passes else 1)
    table = capsys.readouterr().out
    assert ("PASS" if passes else "FAIL") in table
    assert f"{value:.4g}" in table
    suite = ET.parse(out / "junit.xml").getroot().find("testsuite")
    assert suite.get("tests") == "1"
    assert suite.get("failures") == ("0" if passes else "1")
    case = suite.find("testcase")
    assert (case.find("failure") is None) == passes
    assert repr(value) in case.find("system-out").text


def test_unstable_run_fails_the_no_failure_check(tmp_path, capsys):
    write(tmp_path, "u.toml", WITH_UNSTABLE)
    gate = write(
        tmp_path,
        "g.toml",
        """
[[check]]
name = "no unstable run"
campaign = "u.toml"
statistic = "failed_count"
max = 0

[[check]]
name = "at most a third unstable"
campaign = "u.toml"
statistic = "failed_fraction"
max = 0.34
""",
    )
    t0 = time.perf_counter()
    status = main(["check", str(gate), "--out", str(tmp_path / "o"), "--no-progress"])
    wall_s = time.perf_counter() - t0
    assert status == 1
    # the campaign is swept once: JUnit charges it once, and the suite's time is not more
    # than the command's wall time
    suite = ET.parse(tmp_path / "o" / "junit.xml").getroot().find("testsuite")
    times = [float(c.get("time")) for c in suite.iter("testcase")]
    assert float(suite.get("time")) <= wall_s
    assert times[1] < 0.05 * times[0]
    lines = capsys.readouterr().out.splitlines()
    first = next(line for line in lines if line.startswith("no unstable run"))
    assert first.split()[-1] == "FAIL" and " 2 " in first
    second = next(line for line in lines if line.startswith("at most a third"))
    assert second.split()[-1] == "PASS" and "0.3333" in second


def test_bad_gate_is_one_line_before_any_run(tmp_path, capsys):
    write(tmp_path, "small.toml", SMALL)
    text = _gate("small.toml", "max", 1.0).replace('statistic = "p95"', 'statistic = "p101"')
    gate = write(tmp_path, "bad.toml", text)
    with pytest.raises(GateError, match=r"check\[0\]\.statistic: unknown statistic 'p101'"):
        load_gate(gate)
    assert main(["check", str(gate), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("acc: error: ") and "\n" not in err
    assert not (tmp_path / "o").exists()


def test_project_ci_gate_passes(tmp_path, capsys):
    """The project's own gate (what CI runs): `acc check experiments/ci_gate.toml`."""
    gate = ROOT / "experiments" / "ci_gate.toml"
    status = main(["check", str(gate), "--out", str(tmp_path), "--no-progress"])
    out = capsys.readouterr().out
    assert status == 0, out
    root = ET.parse(tmp_path / "junit.xml").getroot()
    assert root.get("failures") == "0"
    assert int(root.get("tests")) == 12
    measured = {
        c.get("name"): float(c.find("system-out").text.split(" = ")[1].split(";")[0])
        for c in root.iter("testcase")
    }
    assert all(math.isfinite(m) for m in measured.values())
    # a 10 % regression of the p95 IAE of any kind, or one oscillating run, fails the gate
    with gate.open("rb") as fh:
        checks = tomllib.load(fh)["check"]
    iae = {c["where"]["controller"]: c for c in checks if c.get("metric") == "iae_N_s"}
    assert set(iae) == {"pi", "adaptive_pi", "dob_pi", "dob_adaptive_pi", "fsp_pi",
                        "fsp_adaptive_pi"}
    for kind, check in iae.items():
        value = next(v for name, v in measured.items() if name.startswith(f"{kind}: "))
        assert value <= check["max"] < 1.10 * value, kind
    oscillating = [c for c in checks if c.get("metric") == "oscillating"]
    assert oscillating and oscillating[0]["statistic"] == "count"
    assert oscillating[0]["max"] == 0 and "where" not in oscillating[0]


def test_check_without_out_writes_nothing_in_the_working_directory(
        tmp_path, monkeypatch, capsys):
    write(tmp_path, "small.toml", SMALL)
    gate = write(tmp_path, "g.toml", '[[check]]\ncampaign = "small.toml"\n'
                 'statistic = "failed_count"\nmax = 0\n')
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main(["check", str(gate), "--workers", "1", "--no-progress"]) == 0
    assert list(work.iterdir()) == []
    assert "nothing written (--out DIR keeps the sweeps and junit.xml)" in capsys.readouterr().out
    # --junit alone writes just that file
    assert main(["check", str(gate), "--junit", "j.xml", "--workers", "1", "--no-progress"]) == 0
    assert [p.name for p in work.iterdir()] == ["j.xml"]


@pytest.mark.parametrize(("direction", "passes"), [(-1, False), (+1, True)])
def test_a_summary_read_a_column_at_a_time_is_judged_alike(
    measured, direction, passes, monkeypatch
):
    """Above LAZY_SUMMARY_BYTES (forced to 0 here) the gate reads a column at a time: the
    same verdict just below and just above the value computed from the whole summary."""
    from acc.campaigns import summary_columns

    opened: list[object] = []

    class Recorded(summary_columns.SummaryColumns):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            opened.append(self)

    monkeypatch.setattr(summary_columns, "LAZY_SUMMARY_BYTES", 0)
    monkeypatch.setattr(summary_columns, "SummaryColumns", Recorded)
    d, value = measured
    gate = write(d, f"gate_lazy_{direction}.toml",
                 _gate("small.toml", "max", value * (1 + direction * 1e-9)))
    status = main(["check", str(gate), "--out", str(d / f"lazy_{direction}"), "--workers", "1",
                   "--no-progress"])
    assert status == (0 if passes else 1)
    assert len(opened) == 1
