"""The sweep report reads only the summary columns it uses (:func:`report_columns`): the
report and figures must be those of the whole summary."""

from __future__ import annotations

from pathlib import Path

from acc.campaigns.campaign import load_campaign
from acc.campaigns.report import report_columns, report_text
from acc.campaigns.sweep import read_summary
from acc.cli.campaigns import _figures
from acc.cli.main import main
from tests.campaign_files import SMALL_SET, write

#: 2 kinds x 4 samples; a random depth profile (a list per run: a text column that differs in
#: every run) and a random noise level (a number per run).
RANDOM_PROFILES = (
    """
[campaign]
name = "random_profiles"
seed = 3
samples_per_point = 4
chunk_runs = 4
"""
    + SMALL_SET
    + """
[grid]
controller.kind = ["pi", "constant"]

[random]
workpiece.radial_depth_mm = { dist = "uniform", low = 2.0, high = 4.0, size = 2 }
sensor.noise_std_N = { dist = "uniform", low = 0.0, high = 10.0 }
"""
)


def test_the_report_of_the_chosen_columns_is_that_of_the_whole_summary(tmp_path: Path) -> None:
    path = write(tmp_path, "random_profiles.toml", RANDOM_PROFILES)
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--no-progress", "-q"]) == 0
    campaign = load_campaign(path)
    columns = report_columns(campaign)
    assert "workpiece.radial_depth_mm" not in columns  # a list of random draws: left out
    assert {"controller.kind", "sensor.noise_std_N", "controller"} <= set(columns)
    full = read_summary(out / "summary.csv")
    assert len(set(full["workpiece.radial_depth_mm"].tolist())) == 8  # (one text per run)
    figures = _figures(tmp_path, full, campaign.swept_keys, [], campaign.model)
    assert figures == ["metrics.png", "failure_rate.png"]
    assert (out / "report.txt").read_text(encoding="utf-8") == report_text(
        campaign.name, full, figures, campaign.model)
    assert sorted(p.name for p in out.glob("*.png")) == sorted(figures)
