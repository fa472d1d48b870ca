"""Statistics of a campaign summary and the short text report of a sweep.

Statistics of a metric are taken over the selected runs that did not fail (``failed`` is
False): a failed run has NaN metrics and is counted apart, in ``failed_count`` /
``failed_fraction``.  A run that did not fail but has no value (NaN: it never finished the
part, never reached the segment, never settled) is *counted*, not dropped: the statistic is
then NaN, so a gate on it fails.  "Not reached" is always NaN, never ``-inf``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from acc.limits import abbreviate

if TYPE_CHECKING:
    from acc.campaigns.campaign import Campaign

#: Metrics tabulated by the sweep report.
REPORT_METRICS = ("rms_error_N", "max_overshoot_pct", "machining_time_s", "productivity_gain_pct")
#: Per lab (``[simulation] model``): the column the report groups runs by, and its metrics.
LAB_REPORTS: dict[str, tuple[str, tuple[str, ...]]] = {
    "force": ("controller", REPORT_METRICS),
    "axis": ("position_controller", ("max_abs_following_error_mm", "rms_following_error_mm",
                                     "iae_mm_s", "max_abs_current_A")),
    "xy_contour": ("contour_controller", ("max_abs_contour_error_mm", "iae_contour_mm_s")),
}

_PERCENTILE_RE = re.compile(r"^p(\d+(?:\.\d+)?)$")
#: Statistics that need no metric (they count failed runs).
FAILURE_STATISTICS = ("failed_count", "failed_fraction")
#: Statistics of a flag column (``oscillating``, ``overload``...): how many selected runs have
#: it, and their fraction (failed runs included).
FLAG_STATISTICS = ("count", "fraction")
#: Flags counted in the report besides ``failed``.
REPORT_FLAGS = ("oscillating", "overload")


#: Distributions whose draws are continuous: a list of them is a different text per run.
_CONTINUOUS = ("uniform", "loguniform", "normal")


def report_columns(campaign: Campaign) -> list[str]:
    """The summary columns the sweep's report and figures use: the outcome flags, the lab's
    grouping column and metrics, the finishing time, the swept keys and, with traces (the
    force bands), the run number, the reference and the depth profile.

    A random key drawn as a list of continuous values (a random depth profile) is left
    out: its text differs in every run, so no figure groups by it, and at 1e6 runs it
    would take hundreds of megabytes.  So is the depth profile without traces (only the
    force bands use it).
    """
    by, metrics = LAB_REPORTS[campaign.model]
    listed = {k for k, d in campaign.random if d.size is not None and d.kind in _CONTINUOUS}
    columns = ["failed", *REPORT_FLAGS, by, *metrics, "machining_time_s",
               *(k for k in campaign.swept_keys if k not in listed)]
    if campaign.record_every_steps is not None:
        columns += ["run", "reference_force_N", "radial_depths_mm"]
    return list(dict.fromkeys(columns))


def check_statistic(name: str) -> None:
    """Raise ValueError unless ``name`` is a known statistic.

    Known: ``mean``, ``median``, ``min``, ``max``, ``std``, ``pNN`` (percentile ``NN`` in
    [0, 100], e.g. ``p95``) of a numeric metric; ``failed_count``, ``failed_fraction`` (no
    metric); ``count``, ``fraction`` of a flag column (True/False, e.g. ``oscillating``,
    ``overload``, ``breakage_detected``): how many selected runs have it set, failed runs
    included.
    """
    if name in ("mean", "median", "min", "max", "std", *FAILURE_STATISTICS, *FLAG_STATISTICS):
        return
    m = _PERCENTILE_RE.match(name)
    if not m or not 0 <= float(m.group(1)) <= 100:
        raise ValueError(
            f"unknown statistic {abbreviate(name)} (known: mean, median, min, max, std, pNN with "
            f"0 <= NN <= 100, {', '.join(FAILURE_STATISTICS)}; {', '.join(FLAG_STATISTICS)} "
            "of a flag column)"
        )


@dataclass(frozen=True)
class Measurement:
    """A statistic over a selection of runs, and how many runs it stands on.

    Attributes
    ----------
    value : float
        The statistic; NaN when it cannot be taken (see ``note``).
    selected : int
        Runs the selection matched.
    used : int
        Runs the statistic counts (for a metric: the selected runs that did not fail, with
        or without a value).
    note : str
        Why the value is NaN, or what was left out (empty when nothing was).
    """

    value: float
    selected: int
    used: int
    note: str = ""


def measure(
    summary: Mapping[str, NDArray], name: str, metric: str | None, rows: NDArray[np.bool_]
) -> Measurement:
    """One statistic of a metric over the selected runs, with the counts behind it.

    Parameters
    ----------
    summary : mapping of str to ndarray, shape (runs,)
        Columns of a summary (:func:`acc.campaigns.sweep.read_summary`).
    name : str
        See :func:`check_statistic`.  Percentiles use linear interpolation
        (``numpy.percentile``'s default).
    metric : str or None
        Column; not needed for the failure statistics.
    rows : ndarray of bool, shape (runs,)
        Runs to consider.

    Returns
    -------
    Measurement
        NaN when the selection is empty, when no selected run completed, or when a
        completed run has no value of the metric (NaN) -- such runs are counted, not dropped.

    Raises
    ------
    ValueError
        Unknown statistic, missing metric, or a metric column that is not numeric.
    """
    check_statistic(name)
    rows = np.asarray(rows, dtype=bool)
    selected = int(np.count_nonzero(rows))
    failed = np.asarray(summary["failed"], dtype=bool)[rows]
    if selected == 0:
        return Measurement(math.nan, 0, 0, "the selection matches no runs")
    if name == "failed_count":
        return Measurement(float(np.count_nonzero(failed)), selected, selected)
    if name == "failed_fraction":
        return Measurement(float(np.mean(failed)), selected, selected)
    if metric is None:
        raise ValueError(f"statistic {name!r} needs a metric")
    if metric not in summary:
        raise ValueError(f"no metric {metric!r} in the summary")
    column = np.asarray(summary[metric])
    if name in FLAG_STATISTICS:
        if column.dtype.kind != "b":
            raise ValueError(f"statistic {name!r} needs a flag column (True/False), not {metric!r}")
        hits = np.count_nonzero(column[rows])
        return Measurement(
            float(hits if name == "count" else hits / selected), selected, selected
        )
    if column.dtype.kind not in "fiub":
        raise ValueError(f"metric {metric!r} is not numeric (a text column)")
    completed = rows.copy()
    completed[rows] = ~failed
    x = column[completed].astype(float, copy=False)  # (one copy of the selected values)
    n_failed = int(np.count_nonzero(failed))
    excluded = f"; {n_failed} failed run(s) excluded" if n_failed else ""
    if len(x) == 0:
        return Measurement(math.nan, selected, 0, f"every selected run failed{excluded}")
    missing = int(np.count_nonzero(~np.isfinite(x)))
    if missing:
        return Measurement(
            math.nan,
            selected,
            len(x),
            f"{missing} of {len(x)} completed run(s) have no value of {metric} (NaN: never "
            f"finished the part, never reached the segment or never settled){excluded}",
        )
    # (x is this call's own copy: the median and percentiles partition it in place)
    if name == "mean":
        value = float(np.mean(x))
    elif name == "median":
        value = float(np.median(x, overwrite_input=True))
    elif name == "min":
        value = float(np.min(x))
    elif name == "max":
        value = float(np.max(x))
    elif name == "std":
        value = float(np.std(x))
    else:
        value = float(np.percentile(x, float(name[1:]), overwrite_input=True))
    return Measurement(value, selected, len(x), excluded[2:])


def statistic(
    summary: Mapping[str, NDArray], name: str, metric: str | None, rows: NDArray[np.bool_]
) -> float:
    """The value of :func:`measure` (NaN when it cannot be taken)."""
    return measure(summary, name, metric, rows).value


def unfinished_runs(summary: Mapping[str, NDArray], rows: NDArray[np.bool_] | None = None) -> int:
    """Runs that did not fail but never finished the part (``machining_time_s`` NaN)."""
    if "machining_time_s" not in summary:
        return 0
    sel = np.ones(len(summary["failed"]), dtype=bool) if rows is None else rows
    t = np.asarray(summary["machining_time_s"], dtype=float)
    return int(np.count_nonzero(sel & ~np.asarray(summary["failed"], bool) & np.isnan(t)))


def _over_values(
    summary: Mapping[str, NDArray], name: str, metric: str, rows: NDArray[np.bool_]
) -> float:
    """A statistic over the selected completed runs that have a value (report tables)."""
    x = np.asarray(summary[metric], dtype=float)
    keep = rows & ~np.asarray(summary["failed"], bool) & np.isfinite(x)
    return measure(summary, name, metric, keep).value


def is_number_column(summary: Mapping[str, NDArray], name: str) -> bool:
    """Whether a summary column holds numbers (floats); a summary read a column at a time
    (:class:`acc.campaigns.summary_columns.SummaryColumns`) answers without reading it."""
    number_column = getattr(summary, "number_column", None)
    if number_column is not None:
        return bool(number_column(name))
    return np.asarray(summary[name]).dtype.kind == "f"


def value_codes(column: NDArray) -> tuple[NDArray[np.int64], list[Any]]:
    """A code per cell, equal for equal values, and the distinct values in code order.

    Numbers compare as numbers (every NaN alike), text as text; no string is made per cell
    (a column of 1e6 runs as text would take tens of megabytes).

    Parameters
    ----------
    column : ndarray, shape (runs,)

    Returns
    -------
    codes : ndarray of int, shape (runs,)
        In ``0 .. len(values) - 1``.
    values : list
        The distinct values; ``values[codes[i]]`` is cell ``i``'s.
    """
    column = np.asarray(column)
    if column.dtype.kind == "O":  # text read from a summary: few distinct strings
        index: dict[Any, int] = {}
        codes = np.fromiter((index.setdefault(v, len(index)) for v in column.tolist()),
                            dtype=np.int64, count=len(column))
        return codes, list(index)
    values, codes = np.unique(column, return_inverse=True)
    return codes.astype(np.int64).ravel(), values.tolist()


def controller_table(
    summary: Mapping[str, NDArray], metrics: Sequence[str] = REPORT_METRICS,
    by: str = "controller",
) -> list[dict[str, float | str | int]]:
    """One row per controller kind (the ``by`` column): runs, failed runs, runs that never
    finished the part, and the median and 95th percentile of metrics over the completed runs
    that have a value."""
    out = []
    n = len(summary["failed"])
    kinds = summary[by] if by in summary else np.full(n, "(all)")
    selections = [(kind, kinds == kind) for kind in sorted(set(kinds.tolist()))]
    for kind, rows in selections:
        row: dict[str, float | str | int] = {
            by: kind,
            "runs": int(np.count_nonzero(rows)),
            "failed": int(statistic(summary, "failed_count", None, rows)),
            "unfinished": unfinished_runs(summary, rows),
        }
        for flag in REPORT_FLAGS:
            if flag in summary:
                row[flag] = int(np.count_nonzero(np.asarray(summary[flag], bool)[rows]))
        out.append(row)
    for m in metrics:  # a metric at a time over every group: one column in use at a time
        if m in summary and is_number_column(summary, m):
            for row, (_, rows) in zip(out, selections, strict=True):
                row[f"{m} p50"] = _over_values(summary, "median", m, rows)
                row[f"{m} p95"] = _over_values(summary, "p95", m, rows)
    return out


def format_table(rows: Sequence[Mapping[str, object]]) -> str:
    """Rows as a fixed-width text table (numbers with 4 significant digits)."""
    if not rows:
        return "(no rows)"
    columns = list(rows[0])

    def cell(v: object) -> str:
        if isinstance(v, float):
            return f"{v:.4g}"
        return str(v)

    cells = [[cell(r.get(c, "")) for c in columns] for r in rows]
    widths = [max(len(c), *(len(r[j]) for r in cells)) for j, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)) for r in cells]
    return "\n".join(lines)


def report_text(name: str, summary: Mapping[str, NDArray], figures: Sequence[str] = (),
                model: str = "force") -> str:
    """The sweep's short text report: totals and the per-controller table (the lab's
    grouping column and metrics, :data:`LAB_REPORTS`)."""
    runs = len(summary["failed"])
    failed = int(np.count_nonzero(summary["failed"]))
    unfinished = unfinished_runs(summary)
    flags = "".join(
        f", {int(np.count_nonzero(summary[f]))} {f}" for f in REPORT_FLAGS if f in summary
    )
    lines = [
        f"Campaign {name}: {runs} runs, {failed} failed, {runs - failed} completed, "
        f"{unfinished} of them never finished the part{flags}.",
        "Statistics over completed runs that have a value (p50 = median, p95 = 95th "
        "percentile; NaN: no run has one).",
        "",
        format_table(controller_table(summary, LAB_REPORTS[model][1], LAB_REPORTS[model][0])),
    ]
    if figures:
        lines += ["", "Figures: " + ", ".join(figures)]
    return "\n".join(lines) + "\n"


def write_report(path: Path, text: str) -> None:
    """Write the report atomically."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


__all__ = [
    "FAILURE_STATISTICS",
    "FLAG_STATISTICS",
    "LAB_REPORTS",
    "REPORT_METRICS",
    "Measurement",
    "check_statistic",
    "controller_table",
    "format_table",
    "is_number_column",
    "measure",
    "report_columns",
    "report_text",
    "statistic",
    "value_codes",
    "write_report",
]
