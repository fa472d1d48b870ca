"""Statistics of a campaign summary and the short text report of a sweep.

Statistics are taken over the runs that completed (``failed`` is False): a failed run has
NaN metrics and is counted apart, in ``failed_count`` / ``failed_fraction``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

#: Metrics tabulated by the sweep report.
REPORT_METRICS = ("rms_error_N", "max_overshoot_pct", "machining_time_s", "productivity_gain_pct")

_PERCENTILE_RE = re.compile(r"^p(\d+(?:\.\d+)?)$")
#: Statistics that need no metric (they count failed runs).
FAILURE_STATISTICS = ("failed_count", "failed_fraction")


def check_statistic(name: str) -> None:
    """Raise ValueError unless ``name`` is a known statistic.

    Known: ``mean``, ``median``, ``min``, ``max``, ``std``, ``pNN`` (percentile ``NN`` in
    [0, 100], e.g. ``p95``), ``failed_count``, ``failed_fraction``.
    """
    if name in ("mean", "median", "min", "max", "std", *FAILURE_STATISTICS):
        return
    m = _PERCENTILE_RE.match(name)
    if not m or not 0 <= float(m.group(1)) <= 100:
        raise ValueError(
            f"unknown statistic {name!r} (known: mean, median, min, max, std, pNN with "
            f"0 <= NN <= 100, {', '.join(FAILURE_STATISTICS)})"
        )


def statistic(
    summary: Mapping[str, NDArray], name: str, metric: str | None, rows: NDArray[np.bool_]
) -> float:
    """One statistic of a metric over the selected completed runs.

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
    float
        NaN when no completed run is selected.
    """
    check_statistic(name)
    failed = summary["failed"][rows]
    if name == "failed_count":
        return float(np.count_nonzero(failed))
    if name == "failed_fraction":
        return float(np.mean(failed)) if len(failed) else math.nan
    if metric is None:
        raise ValueError(f"statistic {name!r} needs a metric")
    if metric not in summary:
        raise KeyError(f"no metric {metric!r} in the summary")
    x = np.asarray(summary[metric][rows][~failed], dtype=float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return math.nan
    if name == "mean":
        return float(np.mean(x))
    if name == "median":
        return float(np.median(x))
    if name == "min":
        return float(np.min(x))
    if name == "max":
        return float(np.max(x))
    if name == "std":
        return float(np.std(x))
    return float(np.percentile(x, float(name[1:])))


def controller_table(
    summary: Mapping[str, NDArray], metrics: Sequence[str] = REPORT_METRICS
) -> list[dict[str, float | str | int]]:
    """One row per controller kind: runs, failed runs, median and 95th percentile of metrics."""
    out = []
    kinds = summary["controller"]
    for kind in sorted(set(kinds.tolist())):
        rows = kinds == kind
        row: dict[str, float | str | int] = {
            "controller": kind,
            "runs": int(np.count_nonzero(rows)),
            "failed": int(statistic(summary, "failed_count", None, rows)),
        }
        for m in metrics:
            if m in summary:
                row[f"{m} p50"] = statistic(summary, "median", m, rows)
                row[f"{m} p95"] = statistic(summary, "p95", m, rows)
        out.append(row)
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


def report_text(name: str, summary: Mapping[str, NDArray], figures: Sequence[str] = ()) -> str:
    """The sweep's short text report: totals and the per-controller table."""
    runs = len(summary["run"])
    failed = int(np.count_nonzero(summary["failed"]))
    lines = [
        f"Campaign {name}: {runs} runs, {failed} failed (unstable), {runs - failed} completed.",
        "Statistics over completed runs (p50 = median, p95 = 95th percentile).",
        "",
        format_table(controller_table(summary)),
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
    "REPORT_METRICS",
    "check_statistic",
    "controller_table",
    "format_table",
    "report_text",
    "statistic",
    "write_report",
]
