"""A sweep's workers rebuild runs the parent validated without repeating the cross-section
checks: the same scenarios and the same summary rows, and a run that was never validated
still fails with its one-line message; the parent's validation in parallel processes ends
as the serial one does (the first bad run's message)."""

from __future__ import annotations

import pytest

from acc.campaigns.campaign import CampaignError, apply_values, load_campaign
from acc.campaigns.sweep import PARALLEL_VALIDATION_RUNS, _validate, simulate_chunk
from tests.campaign_files import SMALL, SMALL_SET, write


def test_checked_build_equals_the_validated_one(tmp_path):
    campaign = load_campaign(write(tmp_path, "small.toml", SMALL))
    for run in range(campaign.runs):
        values = campaign.values(run)
        full = campaign.scenario(run, values)
        quick = campaign.scenario(run, values, checked=True)
        assert quick == full
        assert quick.source == full.source
        assert quick == campaign.base.with_values(values, source=campaign.source)
    rows = simulate_chunk(campaign, range(campaign.runs)).rows
    assert simulate_chunk(campaign, range(campaign.runs), checked=True).rows == rows


def test_unchecked_build_still_refuses_a_bad_value(tmp_path):
    campaign = load_campaign(write(tmp_path, "small.toml", SMALL))
    # a depth beyond the process table: a valid workpiece, only the cross-section check
    # (every depth in the table) refuses it
    bad = {"workpiece.radial_depth_mm": [2.0, 99.0]}
    with pytest.raises(Exception, match="radial_depth_mm") as err:
        campaign.base.with_values(bad)
    with pytest.raises(type(err.value), match="radial_depth_mm"):
        apply_values(campaign.base, bad)
    apply_values(campaign.base, bad, checked=True)  # the caller vouches for it


_THREE_POINTS = """
[campaign]
name = "three_points"
seed = 3
samples_per_point = 1000
""" + SMALL_SET + """
[grid]
workpiece.radial_depth_mm = [[2.0, 3.0], {second}, {third}]

[random]
sensor.noise_std_N = {{ dist = "uniform", low = 0.0, high = 10.0 }}
"""


@pytest.mark.parametrize(("second", "third", "first_bad"), [
    ("[2.0, 98.0]", "[2.0, 99.0]", 1000),  # bad runs in both processes' slices
    ("[2.0, 3.0]", "[2.0, 99.0]", 2000),  # only in the second slice
    ("[2.0, 3.0]", "[4.0, 2.0]", None),
])
def test_parallel_validation_gives_the_serial_outcome(tmp_path, second, third, first_bad):
    campaign = load_campaign(write(tmp_path, "three.toml", _THREE_POINTS.format(
        second=second, third=third)))
    assert campaign.runs == 3 * PARALLEL_VALIDATION_RUNS  # two processes, 1500 runs each
    try:
        campaign.validate()
        serial = None
    except CampaignError as exc:
        serial = str(exc)
    if first_bad is None:
        assert serial is None
        samples = _validate(campaign, 100, True, workers=2)
        assert list(samples) == list(_validate(campaign, 100, True, workers=1))
        assert list(samples.values()) == [campaign.scenario(0)]
        return
    assert f"run {first_bad} (" in serial
    with pytest.raises(CampaignError) as err:
        _validate(campaign, 100, True, workers=2)
    assert str(err.value) == serial


_RARE_BAD = """
[campaign]
name = "rare_bad"
seed = 7
samples_per_point = 3000
""" + SMALL_SET + """
[random]
workpiece.radial_depth_mm = { dist = "uniform", low = 2.0, high = 4.0005, size = 2 }
"""


def test_a_bad_run_inside_a_block_is_named_as_in_order(tmp_path):
    """Depths drawn past the process table's 4 mm now and then: the first such run (1542,
    inside a block of runs, found by building every run in order) is the one named when
    the runs are built by blocks in two processes."""
    campaign = load_campaign(write(tmp_path, "rare.toml", _RARE_BAD))
    with pytest.raises(CampaignError) as serial:
        campaign.validate()
    assert "run 1542 (" in str(serial.value)
    with pytest.raises(CampaignError) as err:
        _validate(campaign, 100, True, workers=2)
    assert str(err.value) == str(serial.value)


def _points(tmp_path, second="[2.0, 3.0]", third="[4.0, 2.0]"):
    return load_campaign(write(tmp_path, "three.toml", _THREE_POINTS.format(
        second=second, third=third)))


def test_the_engine_loads_while_the_runs_are_built(tmp_path, monkeypatch):
    """``preload``: this process loads run 0's configuration (once) while its children
    build the runs, and the outcome is the serial one; a failure to load is raised only
    once the runs are known to be sound (a bad run's message comes first)."""
    import acc.campaigns.sweep as sweep

    loaded = []
    monkeypatch.setattr(sweep, "preload_engine", lambda scenarios: loaded.append(
        list(scenarios)))
    campaign = _points(tmp_path)
    samples = _validate(campaign, 100, True, workers=2, preload=True)
    assert list(samples) == list(_validate(campaign, 100, True, workers=1))
    assert loaded == [[campaign.scenario(0)]]
    _validate(campaign, 100, True, workers=2)  # without preload: not loaded
    assert len(loaded) == 1

    def fails(scenarios):
        raise RuntimeError("no engine here")

    monkeypatch.setattr(sweep, "preload_engine", fails)
    with pytest.raises(RuntimeError, match="no engine here"):
        _validate(campaign, 100, True, workers=2, preload=True)
    bad = _points(tmp_path, third="[2.0, 99.0]")
    with pytest.raises(CampaignError, match=r"run 2000 \("):
        _validate(bad, 100, True, workers=2, preload=True)


def test_a_child_building_runs_that_raises_is_raised_here(tmp_path, monkeypatch):
    """An unexpected exception in a forked child building runs reaches the caller (not a
    hang, not a silent success); so does a child that dies without a result.  (This
    process "loads the engine" for a second first, so the child surely takes a block.)"""
    import os
    import time

    import acc.campaigns.sweep as sweep

    parent = os.getpid()
    real = sweep.validate_runs
    monkeypatch.setattr(sweep, "preload_engine", lambda scenarios: time.sleep(1.0))

    def broken(campaign, first, stop):
        if os.getpid() != parent:
            raise ValueError(f"broken at {first}")
        return real(campaign, first, stop)

    monkeypatch.setattr(sweep, "validate_runs", broken)
    campaign = _points(tmp_path)
    with pytest.raises(ValueError, match="broken at"):
        _validate(campaign, 100, True, workers=2, preload=True)

    def dies(campaign, first, stop):
        if os.getpid() != parent:
            os._exit(3)
        return real(campaign, first, stop)

    monkeypatch.setattr(sweep, "validate_runs", dies)
    with pytest.raises(sweep.SweepError, match="exit code 3"):
        _validate(campaign, 100, True, workers=2, preload=True)
