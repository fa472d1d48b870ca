"""Campaigns over the axis and contouring labs: sweeps and gates as for the force loop.

Numbers from: each run's own scenario simulated directly (``AxisScenario.simulate`` /
``ContourScenario.simulate`` on the base file with the run's values, built here from the
TOML, not through the campaign), NumPy percentiles of the summary columns, and the seeding
rule (``SeedSequence(root, spawn_key=(noise id, 1))``) computed here.
"""

from __future__ import annotations

import gc
import time

import numpy as np
import pytest

from acc.campaigns.campaign import CampaignError, load_campaign
from acc.campaigns.sweep import ChunkResult, _execute, read_summary, run_sweep
from acc.scenarios.axis import load_axis_scenario
from acc.scenarios.contour import load_contour_scenario
from tests.campaign_files import SMALL, kill_sweep_after, write
from tests.cli_run import ROOT, acc, assert_one_line_error

AXIS = ROOT / "experiments" / "peng_servo_axis.toml"
DIAMOND = ROOT / "experiments" / "peng_diamond_mismatched.toml"

#: 3 gains (the last unstable: Peng's axis diverges above K_p of about 10) x 2 random loads.
AXIS_CAMPAIGN = f"""
[campaign]
name = "axis_small"
base = "{AXIS}"
seed = 4
samples_per_point = 2
chunk_runs = 2

[set]
simulation.duration_s = 0.6

[grid]
lead_lag.gain = [1.0, 2.5, 15.0]

[random]
cutting_load.force_N = {{ dist = "uniform", low = 0.0, high = 800.0 }}
"""

CONTOUR_CAMPAIGN = f"""
[campaign]
name = "diamond_small"
base = "{DIAMOND}"
seed = 8
chunk_runs = 1

[grid]
servo_axis.y.viscous_friction_Nm_s_rad = [0.09, 0.3]
path.feed_per_axis_mm_s = [10.0, 20.0]
"""


@pytest.fixture(scope="module")
def axis_sweep(tmp_path_factory):
    d = tmp_path_factory.mktemp("axis")
    campaign = load_campaign(write(d, "axis.toml", AXIS_CAMPAIGN))
    outcome = run_sweep(campaign, d / "ref", workers=1, progress=False)
    return campaign, outcome.summary_path, d


def test_axis_sweep_rows_are_the_runs_simulated_on_their_own(axis_sweep):
    campaign, summary, _ = axis_sweep
    s = read_summary(summary)
    assert campaign.model == "axis" and len(s["run"]) == 6
    base = load_axis_scenario(AXIS)
    for r in range(campaign.runs):
        gain = [1.0, 2.5, 15.0][r // 2]
        assert s["lead_lag.gain"][r] == gain
        seed = np.random.SeedSequence(4, spawn_key=(r, 1)).generate_state(1, np.uint32)[0]
        assert s["seed"][r] == seed
        alone = base.with_values({
            "simulation.duration_s": 0.6, "lead_lag.gain": gain,
            "cutting_load.force_N": s["cutting_load.force_N"][r], "simulation.seed": int(seed),
        }).simulate(record_every_steps=None)
        for metric in ("max_abs_following_error_mm", "iae_mm_s"):  # (NaN = NaN: diverged)
            np.testing.assert_equal(s[metric][r], alone.metrics[metric][0])
        assert (gain < 15.0) == np.isfinite(s["iae_mm_s"][r])


def test_axis_sweep_flags_the_unstable_gain_failed(axis_sweep):
    s = read_summary(axis_sweep[1])
    unstable = s["lead_lag.gain"] == 15.0
    np.testing.assert_array_equal(s["failed"], unstable)
    assert np.all(np.isfinite(s["max_abs_following_error_mm"][~unstable]))


@pytest.mark.parametrize(("workers", "chunk_runs"), [(2, 1), (1, 4)])
def test_axis_sweep_summary_is_the_same_whatever_chunks_and_workers(axis_sweep, workers,
                                                                     chunk_runs):
    campaign, reference, d = axis_sweep
    out = d / f"w{workers}c{chunk_runs}"
    outcome = run_sweep(campaign, out, workers=workers, chunk_runs=chunk_runs, progress=False)
    assert outcome.summary_path.read_bytes() == reference.read_bytes()


def test_lab_sweep_killed_and_resumed_is_byte_identical(axis_sweep):
    campaign, reference, d = axis_sweep
    out = d / "killed"
    done = kill_sweep_after(d / "axis.toml", out, 2)
    assert 2 <= done < campaign.runs
    outcome = run_sweep(campaign, out, workers=2, chunk_runs=3, resume=True, progress=False)
    assert outcome.simulated_runs == campaign.runs - done
    assert outcome.summary_path.read_bytes() == reference.read_bytes()


def test_contour_sweep_of_per_axis_keys_matches_each_run_alone(tmp_path):
    campaign = load_campaign(write(tmp_path, "c.toml", CONTOUR_CAMPAIGN))
    assert campaign.model == "xy_contour"
    s = read_summary(run_sweep(campaign, tmp_path / "o", workers=2, progress=False).summary_path)
    base = load_contour_scenario(DIAMOND)
    for r, (friction, feed) in enumerate([(0.09, 10.0), (0.09, 20.0), (0.3, 10.0), (0.3, 20.0)]):
        sc = base.with_values({"servo_axis.y.viscous_friction_Nm_s_rad": friction,
                               "path.feed_per_axis_mm_s": feed})
        assert sc.axis_y.viscous_friction_Nm_s_rad == friction
        assert sc.axis_x.viscous_friction_Nm_s_rad == base.axis_x.viscous_friction_Nm_s_rad
        row = sc.summary_row(*sc.simulate())
        assert s["M1_vertex_distance_mm"][r] == row["M1_vertex_distance_mm"]
        assert s["iae_contour_mm_s"][r] == row["iae_contour_mm_s"]
    assert not s["failed"].any()
    # the corner error grows with the feed at either mismatch (Peng's Table 4.1 trend)
    m1 = s["M1_vertex_distance_mm"].reshape(2, 2)
    assert np.all(m1[:, 1] > m1[:, 0])


def test_paired_lab_runs_share_their_seed(tmp_path):
    text = AXIS_CAMPAIGN.replace("chunk_runs = 2",
                                 'chunk_runs = 2\npair_over = ["lead_lag.gain"]')
    campaign = load_campaign(write(tmp_path, "p.toml", text))
    seeds = [campaign.scenario(r).simulation.seed for r in range(campaign.runs)]
    assert seeds[0] == seeds[2] == seeds[4] and seeds[1] == seeds[3] == seeds[5]
    assert seeds[0] != seeds[1]
    loads = [campaign.values(r)["cutting_load.force_N"] for r in range(campaign.runs)]
    assert loads[0] == loads[2] == loads[4]


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ('lead_lag.gain = [1.0, 2.5, 15.0]', "lead_lag.gian"),
        ('lead_lag.gain = [1.0, 2.5, 15.0]', "simulation.seed"),
        ('[set]', "record_every_steps"),
    ],
)
def test_lab_campaign_errors_are_one_line_before_any_run(tmp_path, change, key):
    if key == "record_every_steps":
        text = AXIS_CAMPAIGN.replace("chunk_runs = 2", "chunk_runs = 2\nrecord_every_steps = 5")
    else:
        text = AXIS_CAMPAIGN.replace(change, f"{key} = [1, 2]")
    path = write(tmp_path, "bad.toml", text)
    with pytest.raises(CampaignError, match=key.split(".")[-1]):
        load_campaign(path)
    result = acc("sweep", str(path), "--out", str(tmp_path / "o"))
    assert_one_line_error(result, key if "." in key else f"campaign.{key}")
    assert not (tmp_path / "o").exists()


def test_gate_over_the_labs_passes_on_measured_statistics(tmp_path):
    gate = write(tmp_path, "g.toml", f"""
[gate]
name = "labs"
[[check]]
name = "axis p95"
campaign = "{write(tmp_path, 'axis.toml', AXIS_CAMPAIGN)}"
metric = "max_abs_following_error_mm"
statistic = "p95"
where = {{ "lead_lag.gain" = 2.5 }}
max = 0.4
[[check]]
name = "unstable flagged"
campaign = "{tmp_path / 'axis.toml'}"
statistic = "failed_fraction"
where = {{ "lead_lag.gain" = 15.0 }}
min = 1.0
""")
    result = acc("check", str(gate), "--out", str(tmp_path / "g"), "--no-progress")
    assert result.status == 0, result.err + result.out
    s = read_summary(tmp_path / "g" / "axis_small" / "summary.csv")
    p95 = np.percentile(s["max_abs_following_error_mm"][s["lead_lag.gain"] == 2.5], 95)
    assert f"{p95:.4g}" in result.out


def test_gate_metric_typo_is_refused_before_any_sweep(tmp_path):
    gate = write(tmp_path, "g.toml", f"""
[[check]]
campaign = "{write(tmp_path, 'axis.toml', AXIS_CAMPAIGN)}"
metric = "max_abs_folowing_error_mm"
statistic = "max"
max = 1.0
""")
    result = acc("check", str(gate), "--out", str(tmp_path / "g"))
    assert_one_line_error(result, "check[0].metric")
    assert "did you mean 'max_abs_following_error_mm'" in result.err
    assert not (tmp_path / "g" / "axis_small").exists()


def test_gate_where_typo_on_the_force_loop_is_refused_before_any_sweep(tmp_path):
    gate = write(tmp_path, "g.toml", f"""
[[check]]
campaign = "{write(tmp_path, 'small.toml', SMALL)}"
metric = "rms_error_N"
statistic = "max"
where = {{ controler = "pi" }}
max = 100.0
""")
    result = acc("check", str(gate), "--out", str(tmp_path / "g"))
    assert_one_line_error(result, "check[0].where.controler")
    assert "'controller'" in result.err
    assert not (tmp_path / "g" / "small").exists()


def test_the_sweep_parent_holds_a_bounded_window_of_chunks(tmp_path):
    # 12 one-run chunks on 2 workers: never more than the window (2 per worker) alive in the
    # parent, plus the one the executor's result thread holds from setting a future's result
    # until it next runs (a loaded machine catches it there): bounded, not the run count
    campaign = load_campaign(write(tmp_path, "s.toml", SMALL))
    todo = [[r] for r in range(campaign.runs)]
    gc.collect()  # chunks other tests of this process still hold are not this sweep's
    before = sum(isinstance(o, ChunkResult) for o in gc.get_objects())
    alive = []
    for chunk in _execute(campaign, todo, "local", 2, None):
        del chunk
        time.sleep(0.2)  # a slow consumer: without the window the workers' chunks pile up
        gc.collect()
        alive.append(sum(isinstance(o, ChunkResult) for o in gc.get_objects()) - before)
    assert len(alive) == campaign.runs
    assert max(alive) <= 2 * 2 + 1 < campaign.runs


@pytest.mark.parametrize(
    ("command", "path", "says"),
    [("tune", AXIS, "takes cutting-force-loop scenarios"),
     ("analyze", DIAMOND, "does not analyse contouring scenarios")],
)
def test_commands_name_what_they_support_for_other_labs(tmp_path, command, path, says):
    result = acc(command, str(path), "--out", str(tmp_path / "o"))
    assert_one_line_error(result)
    assert says in result.err
