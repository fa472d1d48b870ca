"""The sweep's summary file: chunks concatenated into ``summary.csv`` and read back as columns.

``assemble_summary`` copies a chunk whose columns are the summary's as text and rewrites any
other row by row; the result is checked against the csv module's ``DictReader`` /
``DictWriter`` over every row (an independent reading of the same chunks).  ``read_summary``
converts blocks of rows at a time; a column that reads as numbers for a block and as text
later must come back as text, cell for cell.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from acc.campaigns import sweep
from acc.campaigns.sweep import MISSING, assemble_summary, chunk_name, column_order, read_summary


def _write(path: Path, columns: list[str], rows: list[dict[str, str]]) -> None:
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, restval=MISSING, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)


def _chunks(tmp_path: Path) -> tuple[Path, list[list[dict[str, str]]]]:
    """Three chunks: two with every metric in the summary's order (copied as text; one cell
    quoted, with a comma, a quote and a line break), one of failed runs without the metrics
    and with its columns in another order (rewritten)."""
    d = tmp_path / "chunks"
    d.mkdir()
    full = column_order(["run", "x", "failed", "rms_error_N", "failure_reason"], ["x"])
    a = [{"run": "0", "x": "1.5", "failed": "False", "rms_error_N": "12.25",
          "failure_reason": ""},
         {"run": "1", "x": "2.5", "failed": "True", "rms_error_N": "nan",
          "failure_reason": 'diverged, "at once"\nat 0.1 s # of 2'}]
    b = [{"run": "2", "x": "3.5", "failed": "False", "rms_error_N": "7.0",
          "failure_reason": ""}]
    c = [{"failure_reason": "raised", "failed": "True", "x": "4.5", "run": "3"}]
    _write(d / f"{chunk_name(0, 1)}.csv", full, a)
    _write(d / f"{chunk_name(2, 2)}.csv", full, b)
    _write(d / f"{chunk_name(3, 3)}.csv", ["failure_reason", "failed", "x", "run"], c)
    return tmp_path, [a, b, c]


def test_assembled_summary_equals_the_rows_rewritten_one_by_one(tmp_path: Path) -> None:
    out, parts = _chunks(tmp_path)
    campaign = SimpleNamespace(runs=4, swept_keys=("x",))
    path, failed = assemble_summary(out, campaign)  # type: ignore[arg-type]
    rows = [r for part in parts for r in part]
    header = column_order({k for r in rows for k in r}, ["x"])
    expected = io.StringIO(newline="")
    w = csv.DictWriter(expected, fieldnames=header, restval=MISSING, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    assert path.read_text(encoding="utf-8") == expected.getvalue()
    assert failed == 2
    s = read_summary(path)
    np.testing.assert_array_equal(s["failed"], [False, True, False, True])
    np.testing.assert_array_equal(s["x"], [1.5, 2.5, 3.5, 4.5])
    assert s["failure_reason"][1] == 'diverged, "at once"\nat 0.1 s # of 2'


@pytest.mark.parametrize("block_rows", [1, 2, 8192])
def test_a_column_that_turns_text_in_a_later_block_is_read_as_text(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, block_rows: int
) -> None:
    monkeypatch.setattr(sweep, "SUMMARY_BLOCK_ROWS", block_rows)
    path = tmp_path / "summary.csv"
    cells = ["1.0", "2", "nan", "n/a", "5e-3"]
    _write(path, ["run", "value", "failed", "y"],
           [{"run": str(i), "value": c, "failed": str(i == 2), "y": f"{i / 4}"}
            for i, c in enumerate(cells)])
    s = read_summary(path)
    assert s["value"].dtype == object and {type(v) for v in s["value"]} == {str}
    assert list(s["value"]) == cells
    assert s["failed"].dtype == bool and list(s["failed"]) == [False, False, True, False, False]
    np.testing.assert_array_equal(s["y"], [0.0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_array_equal(s["run"], np.arange(5.0))


def test_a_summary_without_rows_reads_as_empty_columns(tmp_path: Path) -> None:
    path = tmp_path / "summary.csv"
    _write(path, ["run", "failed", "rms_error_N"], [])
    s = read_summary(path)
    assert {k: (v.shape, v.dtype.kind) for k, v in s.items()} == {
        "run": ((0,), "f"), "failed": ((0,), "b"), "rms_error_N": ((0,), "f")}


@pytest.mark.parametrize("block_rows", [2, 8192])
@pytest.mark.parametrize("columns", [["y", "failed", "absent"], ["value", "y", "note"]])
def test_chosen_columns_are_read_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, block_rows: int, columns: list[str]
) -> None:
    """Only the chosen columns (those the file has, in its order), each cell as written; with
    ``value`` (numbers, then text after two rows) the exact block reader takes over."""
    monkeypatch.setattr(sweep, "SUMMARY_BLOCK_ROWS", block_rows)
    path = tmp_path / "summary.csv"
    cells = ["1.0", "2", "nan", "n/a", "5e-3"]
    notes = ["", 'a, "b"', "c\nd", "", "e"]
    rows = [{"run": str(i), "value": c, "failed": str(i % 2 == 1), "y": f"{i / 4}",
             "note": n} for i, (c, n) in enumerate(zip(cells, notes, strict=True))]
    _write(path, ["run", "value", "failed", "y", "note"], rows)
    s = read_summary(path, columns)
    assert list(s) == [c for c in ("run", "value", "failed", "y", "note") if c in columns]
    expected = {"value": cells, "failed": [i % 2 == 1 for i in range(5)],
                "y": [i / 4 for i in range(5)], "note": notes}
    for name, col in s.items():
        assert col.tolist() == expected[name], name


def test_text_cells_are_held_once_per_distinct_text(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Reading a flag and a short text column of 20000 runs peaks (tracemalloc) below 24
    bytes per run and column: a reference per cell (8 bytes) and the result, not a string
    object per cell (about 54 bytes for "False").  (The rows that decide which columns are
    numbers, a fixed number, are made few here.)"""
    import tracemalloc

    monkeypatch.setattr(sweep, "SUMMARY_BLOCK_ROWS", 64)
    path = tmp_path / "summary.csv"
    _write(path, ["run", "failed", "controller"],
           [{"run": str(i), "failed": str(i % 3 == 0), "controller": "pi"}
            for i in range(20000)])
    read_summary(path, ["failed", "controller"])  # (imports, first-call caches)
    tracemalloc.start()
    try:
        s = read_summary(path, ["failed", "controller"])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert s["controller"].tolist() == ["pi"] * 20000
    assert peak < 24 * 2 * 20000, peak
