"""Sweeps: the same summary whatever the chunking, workers, backend or interruptions."""

from __future__ import annotations

import csv
import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from acc.campaigns.campaign import load_campaign
from acc.campaigns.sweep import SweepError, read_summary, result_rows, run_sweep
from acc.engine.simulate import simulate
from tests.campaign_files import SMALL, WITH_UNSTABLE, kill_sweep_after, write


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    d = tmp_path_factory.mktemp("small")
    campaign = load_campaign(write(d, "small.toml", SMALL))
    outcome = run_sweep(
        campaign, d / "reference", workers=1, chunk_runs=5, progress=False
    )
    return campaign, outcome.summary_path


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _cell(value: object) -> str:
    """A swept value as the summary writes it (names as they are, numbers as ``repr``)."""
    if isinstance(value, str):
        return value
    if isinstance(value, list | tuple):
        return " ".join(_cell(v) for v in value)
    return repr(float(value))


def test_summary_equals_one_batch_of_all_runs(small):
    campaign, summary = small
    ids = list(range(campaign.runs))
    result = simulate(campaign.scenarios(ids), run_ids=ids, record_every_steps=None)
    expected = result_rows(campaign, result)
    got = _rows(summary)
    assert [int(r["run"]) for r in got] == ids
    # every cell of a run is the same text (exact float repr) as in a single batch
    for row, exp in zip(got, expected, strict=True):
        assert {k: row[k] for k in exp} == exp
    # and that text is the metric's repr, the run's swept values its draws
    for i, row in enumerate(got):
        for k, v in result.metrics.items():
            assert row[k] == (str(bool(v[i])) if v.dtype == bool else repr(float(v[i]))), k
        for k, v in campaign.values(i).items():
            assert row[k] == _cell(v), k
        assert row["seed"] == str(campaign.scenario(i).simulation.seed)
    s = read_summary(summary)
    assert not s["failed"].any()
    assert np.all(np.isfinite(s["rms_error_N"]))


@pytest.mark.parametrize(
    ("workers", "chunk_runs"),
    [(1, 1), (2, 3), (2, 12), (2, 5)],
)
def test_same_summary_whatever_chunks_and_workers(small, tmp_path, workers, chunk_runs):
    # the compiled kernel gives the PI and constant-feed runs bit for bit (tests/test_kernel.py)
    campaign, reference = small
    calls = []

    def ahead() -> None:  # (called while the last chunks run; its failure changes nothing)
        calls.append(len(list((tmp_path / "out" / "chunks").glob("runs_*.csv"))))
        if chunk_runs == 5:
            raise RuntimeError("ahead failed")

    outcome = run_sweep(
        campaign,
        tmp_path / "out",
        workers=workers,
        chunk_runs=chunk_runs,
        progress=False,
        ahead=ahead,
    )
    assert outcome.summary_path.read_bytes() == reference.read_bytes()
    chunks = sorted((tmp_path / "out" / "chunks").glob("runs_*.csv"))
    assert len(chunks) == math.ceil(campaign.runs / chunk_runs)
    if workers > 1 and len(chunks) > 1:  # once, with a chunk or more still to finish
        assert len(calls) == 1 and calls[0] < len(chunks)
    else:  # no pool: no core is ever free
        assert calls == []


def test_dask_backend_gives_the_same_summary(small, tmp_path):
    distributed = pytest.importorskip("distributed")
    campaign, reference = small
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        outcome = run_sweep(
            campaign,
            tmp_path / "dask",
            backend="dask",
            scheduler=cluster.scheduler_address,
            chunk_runs=2,
            progress=False,
        )
    assert outcome.summary_path.read_bytes() == reference.read_bytes()


def test_resume_skips_finished_chunks_and_ignores_partial_files(small, tmp_path):
    campaign, reference = small
    out = tmp_path / "out"
    run_sweep(campaign, out, workers=1, chunk_runs=3, progress=False)
    # an interruption: the summary never written, two chunks lost, a half-written temp file
    (out / "summary.csv").unlink()
    chunks = sorted((out / "chunks").glob("runs_*.csv"))
    for lost in (chunks[1], chunks[3]):
        lost.unlink()
    (out / "chunks" / ".runs_00000003-00000005.csv.tmp").write_text("run,rms\n3,1e9\n")
    outcome = run_sweep(
        campaign, out, workers=2, chunk_runs=2, resume=True, progress=False
    )
    assert outcome.simulated_runs == 6
    assert outcome.summary_path.read_bytes() == reference.read_bytes()
    assert not list((out / "chunks").glob(".*.tmp"))
    # resuming a finished sweep simulates nothing and rewrites the same summary
    again = run_sweep(campaign, out, workers=1, resume=True, progress=False)
    assert again.simulated_runs == 0
    assert again.summary_path.read_bytes() == reference.read_bytes()


def test_resume_after_kill_gives_the_uninterrupted_summary(tmp_path):
    text = SMALL.replace("samples_per_point = 3", "samples_per_point = 10")
    path = write(tmp_path, "c.toml", text)
    campaign = load_campaign(path)
    reference = run_sweep(campaign, tmp_path / "ref", workers=1, progress=False).summary_path
    out = tmp_path / "killed"
    done = kill_sweep_after(path, out, 3)
    assert 3 <= done < campaign.runs
    outcome = run_sweep(campaign, out, workers=2, chunk_runs=4, resume=True, progress=False)
    assert outcome.simulated_runs == campaign.runs - done
    assert outcome.summary_path.read_bytes() == reference.read_bytes()


def test_unstable_run_is_recorded_as_failed_and_the_others_complete(tmp_path):
    campaign = load_campaign(write(tmp_path, "u.toml", WITH_UNSTABLE))
    outcome = run_sweep(campaign, tmp_path / "out", workers=2, progress=False)
    assert outcome.failed_runs == 2
    s = read_summary(outcome.summary_path)
    gain = s["force_process.gain_multiplier"]
    np.testing.assert_array_equal(s["failed"], gain == 1000.0)
    assert np.all(np.isnan(s["rms_error_N"][s["failed"]]))
    assert np.all(np.isnan(s["peak_force_N"][s["failed"]]))
    ok = ~s["failed"]
    assert np.all(np.isfinite(s["rms_error_N"][ok]))
    assert np.all(np.isfinite(s["machining_time_s"][ok]))
    # a stable run's metrics do not depend on sharing its chunk with an unstable one
    for r in np.flatnonzero(ok):
        alone = simulate(campaign.scenario(int(r)), run_ids=[int(r)], record_every_steps=None)
        assert s["rms_error_N"][r] == alone.metrics["rms_error_N"][0]
        assert s["machining_time_s"][r] == alone.metrics["machining_time_s"][0]


def test_refuses_to_overwrite_or_resume_another_campaign(small, tmp_path):
    campaign, reference = small
    out = tmp_path / "out"
    shutil.copytree(reference.parent, out)
    with pytest.raises(SweepError, match="already holds a sweep"):
        run_sweep(campaign, out, workers=1, progress=False)
    other = load_campaign(write(tmp_path, "o.toml", SMALL.replace("seed = 11", "seed = 12")))
    with pytest.raises(SweepError, match="different campaign"):
        run_sweep(other, out, workers=1, resume=True, progress=False)


def test_traces_are_kept_decimated_only_when_asked(tmp_path):
    from acc.campaigns.sweep import read_traces

    text = SMALL.replace("chunk_runs = 4", "chunk_runs = 4\nrecord_every_steps = 5")
    campaign = load_campaign(write(tmp_path, "t.toml", text))
    run_sweep(campaign, tmp_path / "t", workers=1, progress=False)
    traces = read_traces(tmp_path / "t")
    assert traces["force_N"].shape[0] == campaign.runs
    np.testing.assert_allclose(np.diff(traces["time_s"]), 5 * 0.002, rtol=1e-12)
    assert read_traces(tmp_path / "none") is None


def test_sweep_with_traces_draws_force_bands_per_kind_and_profile(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from acc.campaigns.plots import plot_force_bands
    from acc.campaigns.sweep import read_traces
    from tests.cli_run import acc

    text = SMALL.replace("chunk_runs = 4", "chunk_runs = 4\nrecord_every_steps = 5")
    path = write(tmp_path, "t.toml", text)
    out = tmp_path / "t"
    result = acc("sweep", str(path), "--out", str(out), "--quiet")
    assert result.status == 0, result.err
    assert (out / "force_bands.png").stat().st_size > 0
    traces, summary = read_traces(out), read_summary(out / "summary.csv")
    fig, ax = plt.subplots()
    plot_force_bands(traces, summary, ax=ax)
    medians = {ln.get_label(): ln for ln in ax.get_lines()}
    # 2 kinds x 2 depth profiles: four groups, each the median of its own runs only
    row = {int(r): i for i, r in enumerate(summary["run"])}
    for kind in ("pi", "constant"):
        for depths in ("2 3", "4 2"):
            runs = [
                k for k, r in enumerate(traces["run_ids"])
                if summary["controller"][row[int(r)]] == kind
                and summary["radial_depths_mm"][row[int(r)]] == depths
            ]
            assert len(runs) == 3
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # columns after every run ended
                expected = np.nanmedian(traces["force_N"][runs], axis=0)
            drawn = medians[f"{kind}, {depths} mm median"].get_ydata()
            np.testing.assert_allclose(drawn, expected, rtol=0, atol=1e-9, equal_nan=True)
    assert medians["reference"].get_ydata()[0] == 500.0
    plt.close(fig)


def test_runs_a_batch_cannot_mix_are_simulated_apart(tmp_path):
    # the simulator runs one anti-windup kind per batch; a chunk holding both is split
    text = SMALL.replace(
        'controller.kind = ["pi", "constant"]', 'controller.anti_windup = ["clamping", "none"]'
    )
    campaign = load_campaign(write(tmp_path, "aw.toml", text))
    out = run_sweep(campaign, tmp_path / "aw", workers=1, progress=False)
    s = read_summary(out.summary_path)
    assert sorted(set(s["controller.anti_windup"].tolist())) == ["clamping", "none"]
    for r in (0, 6, 11):
        alone = simulate(campaign.scenario(r), run_ids=[r], record_every_steps=None)
        assert s["rms_error_N"][r] == alone.metrics["rms_error_N"][0]


def test_runs_with_different_estimators_share_a_chunk(tmp_path):
    # RLS and Kalman runs, each equal to its standalone simulation
    text = SMALL.replace(
        'controller.kind = ["pi", "constant"]',
        'controller.kind = ["adaptive_pi"]\ncontroller.estimator = ["rls", "kalman"]',
    ).replace("samples_per_point = 3", "samples_per_point = 2")
    campaign = load_campaign(write(tmp_path, "k.toml", text))
    out = run_sweep(campaign, tmp_path / "a", workers=1, progress=False)
    s = read_summary(out.summary_path)
    assert sorted(set(s["controller.estimator"].tolist())) == ["kalman", "rls"]
    for r in range(campaign.runs):
        alone = simulate(campaign.scenario(r), run_ids=[r], record_every_steps=None)
        assert s["rms_error_N"][r] == alone.metrics["rms_error_N"][0]


def test_a_chunk_of_interleaved_batches_is_written_in_run_order(tmp_path):
    # one sample a point, the controller kind varying fastest: a chunk's runs alternate
    # between two compiled configurations (two batches, the same columns), whose lines are
    # merged back into run order
    text = (
        SMALL.replace('controller.kind = ["pi", "constant"]\n', "")
        .replace("samples_per_point = 3", "samples_per_point = 1")
        .replace("[random]", 'controller.kind = ["pi", "dob_pi"]\n\n[random]')
    )
    campaign = load_campaign(write(tmp_path, "alt.toml", text))
    out = run_sweep(campaign, tmp_path / "alt", workers=1, chunk_runs=4, progress=False)
    rows = _rows(out.summary_path)
    assert [r["run"] for r in rows] == [str(r) for r in range(campaign.runs)]
    assert [r["controller.kind"] for r in rows[:4]] == ["pi", "dob_pi"] * 2
    for r in (1, 2):
        alone = simulate(campaign.scenario(r), run_ids=[r], record_every_steps=None)
        assert rows[r]["rms_error_N"] == repr(float(alone.metrics["rms_error_N"][0]))
