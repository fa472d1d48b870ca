"""The sweep report reads only the summary columns it uses (:func:`report_columns`): the
report and figures must be those of the whole summary."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from acc.campaigns.campaign import load_campaign
from acc.campaigns.report import controller_table, report_columns, report_text
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


def test_a_summary_read_a_column_at_a_time_reports_as_one_read_whole(tmp_path, monkeypatch):
    """Above LAZY_SUMMARY_BYTES the report reads one number column at a time; its text and
    figures are those of the summary read whole."""
    from acc.campaigns import summary_columns

    monkeypatch.setattr(summary_columns, "LAZY_SUMMARY_BYTES", 0)
    path = write(tmp_path, "random_profiles.toml", RANDOM_PROFILES)
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--no-progress", "-q"]) == 0
    campaign = load_campaign(path)
    lazy = summary_columns.summary_for_report(out / "summary.csv", report_columns(campaign))
    assert isinstance(lazy, summary_columns.SummaryColumns)
    full = read_summary(out / "summary.csv")
    whole = tmp_path / "whole"
    whole.mkdir()
    figures = _figures(whole, full, campaign.swept_keys, [], campaign.model)
    assert (out / "report.txt").read_text(encoding="utf-8") == report_text(
        campaign.name, full, figures, campaign.model)
    for name in figures:
        assert (out / name).read_bytes() == (whole / name).read_bytes(), name
    # the table against numpy over each kind's completed runs that have a value
    table = {row["controller"]: row for row in controller_table(lazy)}
    assert sorted(table) == ["constant", "pi"]
    for kind, row in table.items():
        for metric in ("rms_error_N", "machining_time_s"):
            x = full[metric][(full["controller"] == kind) & ~full["failed"]]
            x = x[np.isfinite(x)]
            assert row[f"{metric} p50"] == np.median(x)
            assert row[f"{metric} p95"] == np.percentile(x, 95)
    # the same columns, one number column held at a time
    lazy = summary_columns.SummaryColumns(out / "summary.csv", report_columns(campaign))
    assert report_text(campaign.name, lazy, figures) == report_text(campaign.name, full, figures)
    assert lazy.reads == 1 + 5  # the text and flags together, then each metric once
    for name in lazy:
        np.testing.assert_array_equal(lazy[name], full[name])
        assert lazy[name].dtype == full[name].dtype
        assert len(lazy._recent) <= 1
