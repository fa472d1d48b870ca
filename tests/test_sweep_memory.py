"""What keeps a sweep's memory flat in its run count: chunks planned as ranges, the parent's
heap out of the workers' garbage collections, text columns held once per distinct text,
and figure groupings found without a string per cell.  The peaks themselves are measured
by ``benchmarks/bench_sweep_limit.py``."""

from __future__ import annotations

import gc
import sys
from pathlib import Path

import numpy as np

from acc.campaigns.plots import box_stats, grouping_column
from acc.campaigns.report import value_codes
from acc.campaigns.sweep import SUMMARY_BLOCK_ROWS, plan_chunks, read_summary, shared_heap


def test_chunks_are_ranges_of_the_runs_left():
    assert plan_chunks(10, [(2, 3)], 3) == [range(0, 2), range(4, 7), range(7, 10)]
    assert plan_chunks(4, [(0, 3)], 2) == []
    rng = np.random.default_rng(1)
    done = sorted({(a, a + int(rng.integers(0, 5))) for a in rng.integers(0, 990, 40)})
    done = [d for k, d in enumerate(done) if k == 0 or d[0] > done[k - 1][1]]  # disjoint
    chunks = plan_chunks(1000, done, 7)
    held = {r for a, b in done for r in range(a, b + 1)}
    runs = [r for c in chunks for r in c]
    assert runs == sorted(set(range(1000)) - held)
    assert all(1 <= len(c) <= 7 and c.step == 1 for c in chunks)
    # a whole sweep's plan of 1e6 runs: a few bytes a chunk, not 36 bytes a run
    big = plan_chunks(1_000_000, [], 250)
    assert len(big) == 4000 and sys.getsizeof(big[0]) < 100


def test_the_parents_heap_is_frozen_only_while_workers_run():
    assert gc.get_freeze_count() == 0
    with shared_heap():
        assert gc.get_freeze_count() > 0
    assert gc.get_freeze_count() == 0
    # a caller's own frozen objects stay frozen
    gc.freeze()
    try:
        mine = gc.get_freeze_count()
        with shared_heap():
            pass
        assert gc.get_freeze_count() >= mine > 0
    finally:
        gc.unfreeze()


def _write(path: Path, header: str, rows: list[str]) -> Path:
    path.write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    return path


def test_text_columns_hold_one_string_per_distinct_text(tmp_path):
    kinds = ["pi", "dob_adaptive_pi", "pi", "pi", "dob_adaptive_pi"]
    path = _write(tmp_path / "s.csv", "run,controller,failed,rms_error_N",
                  [f"{i},{k},{i == 2},{0.5 * i}" for i, k in enumerate(kinds)])
    s = read_summary(path)
    col = s["controller"]
    assert col.dtype == object and col.tolist() == kinds
    assert col[0] is col[2] is col[3] and col[1] is col[4]
    assert s["failed"].tolist() == [False, False, True, False, False]
    np.testing.assert_array_equal(s["rms_error_N"], [0.0, 0.5, 1.0, 1.5, 2.0])


def test_text_columns_are_shared_when_read_in_blocks(tmp_path):
    # a column whose first block reads as numbers and a later cell does not: the second
    # reader (blocks of rows) takes over
    n = SUMMARY_BLOCK_ROWS + 3
    cells = [str(i) for i in range(n - 1)] + ["n/a"]
    path = _write(tmp_path / "s.csv", "run,controller,x",
                  [f"{i},{'pi' if i % 2 else 'dob_pi'},{c}" for i, c in enumerate(cells)])
    s = read_summary(path)
    assert s["x"].dtype == object and s["x"].tolist() == cells
    col = s["controller"]
    assert col[1] is col[n - 2] and col[0] is col[n - 1] and col[0] == "dob_pi"
    np.testing.assert_array_equal(s["run"], np.arange(n, dtype=float))


def test_value_codes_count_values_as_their_text_does():
    nan = float("nan")
    for column in (np.array([1.0, nan, 1.0, nan, 2.5]),
                   np.array(["b", "a", "b", "c"], dtype=object),
                   np.array([True, False, True])):
        codes, values = value_codes(column)
        distinct = len(values)
        text = [str(v) for v in column.tolist()]
        assert distinct == len(set(text))
        assert [str(values[c]) for c in codes] == text  # each cell's value by its code
        for i in range(len(text)):  # equal codes exactly where the texts are equal
            assert [codes[i] == c for c in codes] == [text[i] == t for t in text]
        assert codes.min() == 0 and codes.max() == distinct - 1


def test_grouping_column_skips_copies_of_the_groups_and_too_many_values():
    kinds = np.array(["pi", "pi", "dob_pi", "dob_pi"] * 6, dtype=object)
    summary = {
        "controller": kinds,
        "controller.kind": np.array([f"k_{k}" for k in kinds], dtype=object),  # a copy
        "noise": np.arange(24.0),  # 24 values > 8
        "depth_mm": np.array([2.0, 3.0, 2.0, 3.0] * 3 + [4.0, 3.0, 2.0, 3.0] * 3),
        "gain": np.array([1.0, 2.0] * 12),
    }
    swept = ["controller.kind", "noise", "depth_mm", "gain"]
    assert grouping_column(summary, "controller", swept) == "depth_mm"
    assert grouping_column(summary, "controller", swept, most=2) == "gain"
    assert grouping_column(summary, "controller", ["controller.kind", "noise"]) is None


def test_box_statistics_are_matplotlibs():
    import matplotlib.cbook as cbook

    rng = np.random.default_rng(0)
    for x in (rng.normal(size=1001), rng.exponential(size=10), np.array([1.0]),
              np.array([2.0, 2.0, 2.0, 5.0]), rng.integers(0, 3, 50).astype(float),
              np.array([])):
        ours, theirs = box_stats(x), cbook.boxplot_stats(x, whis=(5, 95))[0]
        assert set(theirs) <= set(ours)
        for key, value in theirs.items():
            np.testing.assert_array_equal(ours[key], value, err_msg=key)


def test_the_workers_are_forked_from_a_frozen_heap(tmp_path):
    """While local workers simulate, the parent's heap is frozen (their collections would copy
    its pages); once the chunks are in, it is not."""
    from acc.campaigns.campaign import load_campaign
    from acc.campaigns.sweep import _execute
    from tests.campaign_files import SMALL, write

    campaign = load_campaign(write(tmp_path, "small.toml", SMALL))
    before = gc.get_freeze_count()
    frozen = []
    runs = []
    for chunk in _execute(campaign, plan_chunks(campaign.runs, [], 4), "local", 2, None):
        frozen.append(gc.get_freeze_count() > before)
        runs += chunk.run_ids
    assert sorted(runs) == list(range(campaign.runs)) and all(frozen)
    assert gc.get_freeze_count() == before


def test_gate_selection_formats_each_distinct_cell_once_with_the_same_matches():
    from acc.campaigns.gate import selection

    nan = float("nan")
    summary = {
        "failed": np.zeros(6, dtype=bool),
        "controller": np.array(["pi", "dob_pi", "pi", "x", "pi", "dob_pi"], dtype=object),
        "depth_mm": np.array([2.0, nan, 3.0, nan, 2.0, 3.0]),
        "overload": np.array([True, False, True, True, False, False]),
    }
    mask = {
        (("controller", "pi"),): [1, 0, 1, 0, 1, 0],
        (("depth_mm", 2),): [1, 0, 0, 0, 1, 0],  # a number matches by value
        (("depth_mm", "nan"),): [0, 1, 0, 1, 0, 0],  # text matches the summary's text
        (("overload", True),): [1, 0, 1, 1, 0, 0],
        (("controller", "dob_pi"), ("depth_mm", 3.0)): [0, 0, 0, 0, 0, 1],
    }
    for where, expected in mask.items():
        assert selection(summary, where).tolist() == [bool(e) for e in expected], where
