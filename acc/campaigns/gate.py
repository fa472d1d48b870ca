"""``acc check``: run campaigns, compare statistics of their metrics with thresholds.

A gate file (format in ``docs/campaigns.md``)::

    [gate]
    name = "ci"

    [[check]]
    name = "PI: 95th-percentile RMS force error over the depth sweep"
    campaign = "ci_campaign.toml"        # relative to the gate file
    metric = "rms_error_N"
    statistic = "p95"                    # mean, median, min, max, std, pNN,
                                         # failed_count, failed_fraction,
                                         # count, fraction (of a flag: oscillating...)
    where = { controller = "pi" }        # optional: only runs whose summary column matches
    max = 60.0                           # and/or min; a NaN measurement fails

Every campaign named by a check is swept once, into ``OUT/<campaign name>``; re-running a gate
into the same ``OUT`` continues an interrupted sweep and reuses a finished one (a directory
holding a different campaign is refused).  A check passes when its measured value is finite,
``<= max`` and ``>= min``; it cannot pass vacuously: a selection that matches no run fails,
and a completed run without a value of the metric (it never finished the part, never reached
the segment) makes the statistic NaN, so the check fails (:func:`acc.campaigns.report.measure`).
Every check reports how many runs its selection matched and how many it used.  The result is
a table, a JUnit XML file, and the exit status (1 if any check fails).
"""

from __future__ import annotations

import math
import time
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from acc.campaigns.campaign import CampaignError, load_campaign
from acc.campaigns.report import (
    FAILURE_STATISTICS,
    check_statistic,
    format_table,
    measure,
    value_codes,
)
from acc.campaigns.summary_columns import summary_for_report
from acc.campaigns.sweep import run_sweep
from acc.errors import did_you_mean, unknown_name
from acc.inputs import InputError, read_toml
from acc.limits import abbreviate, shorten


class GateError(CampaignError):
    """A gate file that cannot be run (one line naming the file and the key)."""


@dataclass(frozen=True)
class Check:
    """One threshold on one statistic of one campaign.

    Attributes
    ----------
    name : str
    campaign_path : Path
    statistic : str
        See :func:`acc.campaigns.report.check_statistic`.
    metric : str or None
        Summary column (unit in its name); None for the failure statistics.
    where : tuple of (str, value)
        ``(column, value)`` pairs a run must match to count (:func:`selection`: numbers by
        value against numeric columns, otherwise as text).
    max_value, min_value : float or None
        Thresholds, in the metric's unit.
    """

    name: str
    campaign_path: Path
    statistic: str
    metric: str | None = None
    where: tuple[tuple[str, Any], ...] = ()
    max_value: float | None = None
    min_value: float | None = None

    def passes(self, measured: float) -> bool:
        """Whether a measured value meets the thresholds (NaN never does)."""
        if not math.isfinite(measured):
            return False
        if self.max_value is not None and not measured <= self.max_value:
            return False
        return self.min_value is None or measured >= self.min_value

    @property
    def threshold_text(self) -> str:
        """The thresholds as text, e.g. ``<= 60``."""
        parts = []
        if self.min_value is not None:
            parts.append(f">= {self.min_value:g}")
        if self.max_value is not None:
            parts.append(f"<= {self.max_value:g}")
        return " and ".join(parts)


@dataclass(frozen=True)
class Gate:
    """A gate file: a name and its checks."""

    name: str
    source: str
    checks: tuple[Check, ...]


@dataclass(frozen=True)
class CheckOutcome:
    """A check with its measured value and verdict.

    Attributes
    ----------
    check : Check
    measured : float
    passed : bool
    runs : int
        Runs the statistic used.
    seconds : float
        Time charged to the check [s]: its campaign's sweep for the first check that uses the
        campaign (the sweep is run once), then only the measurement; the checks' times add
        up to the gate's.
    selected : int
        Runs the check's selection (``where``) matched.
    note : str
        Why the value is NaN, or what was left out.
    """

    check: Check
    measured: float
    passed: bool
    runs: int
    seconds: float
    selected: int = 0
    note: str = ""


#: Summary columns that hold text, never a metric.
TEXT_COLUMNS = ("controller", "radial_depths_mm", "failure_reason", "failed")

_CHECK_KEYS = ("name", "campaign", "metric", "statistic", "where", "max", "min")


def load_gate(path: str | Path) -> Gate:
    """Read and check a gate file, and every campaign it names.

    Raises
    ------
    GateError or CampaignError
        One line naming the file and the key.
    """
    p = Path(path)
    data = read_toml(p, "gate")
    for table in data:
        if table not in ("gate", "check"):
            raise GateError(
                f"{p}: [{shorten(table, 80)}]: {unknown_name('table', table, ('gate', 'check'))}"
            )
    head = data.get("gate", {})
    if not isinstance(head, dict):
        raise GateError(f"{p}: [gate] must be a table, got {abbreviate(head)}")
    for key in head:
        if key != "name":
            raise GateError(f"{p}: gate.{shorten(key, 80)}: {unknown_name('key', key, ['name'])}")
    if not isinstance(head.get("name", ""), str):
        raise GateError(f"{p}: gate.name: expected a string, got {abbreviate(head['name'])}")
    specs = data.get("check", [])
    if not isinstance(specs, list) or not specs:
        raise GateError(f"{p}: no [[check]] (a gate needs at least one)")
    checks = []
    names: dict[str, Path] = {}
    for i, spec in enumerate(specs):
        where = f"{p}: check[{i}]"
        if not isinstance(spec, dict):
            raise GateError(f"{where}: expected a table ([[check]]), got {abbreviate(spec)}")
        for key in spec:
            if key not in _CHECK_KEYS:
                raise GateError(
                    f"{where}.{shorten(key, 80)}: {unknown_name('key', key, _CHECK_KEYS)}"
                )
        for key in ("campaign", "statistic"):
            if not isinstance(spec.get(key), str):
                raise GateError(f"{where}.{key}: required (a string)")
        if not isinstance(spec.get("name", ""), str):
            raise GateError(f"{where}.name: expected a string, got {abbreviate(spec['name'])}")
        try:
            check_statistic(spec["statistic"])
        except ValueError as exc:
            raise GateError(f"{where}.statistic: {exc}") from None
        metric = spec.get("metric")
        if metric is not None and not isinstance(metric, str):
            raise GateError(f"{where}.metric: expected a string, got {abbreviate(metric)}")
        if spec["statistic"] not in FAILURE_STATISTICS and metric is None:
            raise GateError(f"{where}.metric: required for statistic {spec['statistic']!r}")
        bounds = {}
        for key in ("max", "min"):
            v = spec.get(key)
            if v is not None and (
                isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v)
            ):
                raise GateError(f"{where}.{key}: expected a finite number, got {abbreviate(v)}")
            bounds[key] = None if v is None else float(v)
        if bounds["max"] is None and bounds["min"] is None:
            raise GateError(f"{where}: needs max or min")
        if bounds["max"] is not None and bounds["min"] is not None:
            if bounds["min"] > bounds["max"]:
                raise GateError(
                    f"{where}: min = {bounds['min']:g} > max = {bounds['max']:g} (no value passes)"
                )
        filt = spec.get("where", {})
        if not isinstance(filt, dict):
            raise GateError(f"{where}.where: expected a table {{ column = value }}")
        for column, value in filt.items():
            if isinstance(value, dict | list):
                raise GateError(
                    f"{where}.where.{shorten(column, 80)}: expected a string, number or "
                    f"boolean, got {abbreviate(value)}"
                )
        campaign_path = Path(spec["campaign"])
        if not campaign_path.is_absolute():
            campaign_path = p.parent / campaign_path
        try:
            campaign = load_campaign(campaign_path)  # a bad campaign fails here, before any run
        except InputError as exc:
            raise GateError(f"{where}.campaign: {exc}") from None
        if metric is not None and spec["statistic"] not in FAILURE_STATISTICS:
            if metric in TEXT_COLUMNS or any(
                isinstance(v, str) for k, vals in campaign.grid if k == metric for v in vals
            ):
                raise GateError(f"{where}.metric: {metric!r} is a text column, not a metric")
        key = campaign_path.resolve()
        other = names.setdefault(campaign.name, key)
        if other != key:
            raise GateError(
                f"{where}.campaign: {campaign_path} is named {campaign.name!r}, like {other}; "
                "each campaign of a gate needs its own [campaign] name (it names its "
                "directory under --out)"
            )
        checks.append(
            Check(
                name=str(spec.get("name", f"check {i}")),
                campaign_path=campaign_path,
                statistic=spec["statistic"],
                metric=metric,
                where=tuple((str(k), v) for k, v in filt.items()),
                max_value=bounds["max"],
                min_value=bounds["min"],
            )
        )
    return Gate(name=str(head.get("name", p.stem)), source=str(p), checks=tuple(checks))


def _text(value: Any) -> str:
    from acc.campaigns.sweep import format_value

    return format_value(value)


def selection(
    summary: Mapping[str, np.ndarray], where: tuple[tuple[str, Any], ...]
) -> np.ndarray:
    """Runs whose summary columns equal the ``where`` values.

    A number matches a numeric column by value (``500`` matches ``500.0``); anything else
    is compared as the summary's text (``True``/``False`` for booleans).

    Raises
    ------
    KeyError
        A column the summary does not have.
    """
    rows = np.ones(len(summary["failed"]), dtype=bool)
    for column, value in where:
        if column not in summary:
            raise KeyError(column)
        col = summary[column]
        if (
            isinstance(value, int | float)
            and not isinstance(value, bool)
            and col.dtype.kind in "fiu"
        ):
            rows &= col.astype(float) == float(value)
        else:  # each distinct cell formatted once, not a string per run
            codes, values = value_codes(col)
            rows &= np.array([_text(v) == _text(value) for v in values], dtype=bool)[codes]
    return rows


def check_columns(gate: Gate) -> None:
    """Refuse, before any sweep, a check whose metric or ``where`` column its campaign's
    summary will not have (a typo), with the nearest column names.

    The columns come from short probe runs (:func:`acc.campaigns.sweep.summary_columns`);
    ``<metric>_segN`` is accepted for any per-segment metric the probe shows.

    Raises
    ------
    GateError
        One line naming the gate file, the check and the column.
    """

    from acc.campaigns.sweep import SEGMENT_RE, summary_columns

    columns: dict[Path, set[str] | None] = {}
    for i, check in enumerate(gate.checks):
        if check.campaign_path not in columns:
            columns[check.campaign_path] = summary_columns(load_campaign(check.campaign_path))
        known = columns[check.campaign_path]
        if known is None:
            continue  # every probe run raised: the sweep will say why
        segmented = {m.group(1) for c in known if (m := SEGMENT_RE.match(c))}
        named = [("metric", check.metric)] if check.metric is not None else []
        named += [(f"where.{c}", c) for c, _ in check.where]
        for key, column in named:
            seg = SEGMENT_RE.match(column)
            if column in known or (seg and seg.group(1) in segmented):
                continue
            hint = did_you_mean(column, sorted(known))
            raise GateError(
                f"{gate.source}: check[{i}].{key}: the summary of {check.campaign_path.name} "
                f"has no column {shorten(repr(column), 60)}{hint}")


def _checked_columns(gate: Gate, campaign_path: Path) -> set[str]:
    """The summary columns the checks of one campaign read (their metrics and ``where``
    columns, and ``failed``): a gate over 1e6 runs does not hold the rest."""
    columns = {"failed"}
    for check in gate.checks:
        if check.campaign_path == campaign_path:
            columns.update(column for column, _ in check.where)
            if check.metric is not None:
                columns.add(check.metric)
    return columns


def run_gate(gate: Gate, out_dir: str | Path, **sweep_options: Any) -> list[CheckOutcome]:
    """Sweep every campaign of a gate once (into ``out_dir/<campaign name>``) and judge.

    A campaign's directory that already holds its sweep is continued (interrupted) or
    reused (finished); see :func:`acc.campaigns.sweep.run_sweep` with ``resume=True``.

    Parameters
    ----------
    gate : Gate
    out_dir : str or Path
    **sweep_options
        Passed to :func:`acc.campaigns.sweep.run_sweep` (backend, workers, progress...).

    Returns
    -------
    list of CheckOutcome, in the gate's order
    """
    out = Path(out_dir)
    sweep_options = {**sweep_options, "resume": True}
    check_columns(gate)
    summaries: dict[Path, tuple[Mapping[str, np.ndarray], float]] = {}
    for check in gate.checks:
        if check.campaign_path in summaries:
            continue
        campaign = load_campaign(check.campaign_path)
        t0 = time.perf_counter()
        outcome = run_sweep(campaign, out / campaign.name, **sweep_options)
        summaries[check.campaign_path] = (  # (a large summary: a column at a time)
            summary_for_report(outcome.summary_path,
                               _checked_columns(gate, check.campaign_path)),
            time.perf_counter() - t0,
        )
    outcomes = []
    charged: set[Path] = set()
    for i, check in enumerate(gate.checks):
        t0 = time.perf_counter()
        summary, swept_s = summaries[check.campaign_path]
        sweep_s = 0.0 if check.campaign_path in charged else swept_s
        charged.add(check.campaign_path)
        try:
            rows = selection(summary, check.where)
        except KeyError as exc:
            raise GateError(
                f"{gate.source}: check[{i}].where: no column {exc.args[0]!r} in the summary of "
                f"{check.campaign_path.name}"
            ) from None
        try:
            m = measure(summary, check.statistic, check.metric, rows)
        except ValueError as exc:
            raise GateError(f"{gate.source}: check[{i}].metric: {exc}") from None
        seconds = sweep_s + time.perf_counter() - t0
        outcomes.append(
            CheckOutcome(
                check, m.value, check.passes(m.value), m.used, seconds, m.selected, m.note
            )
        )
    return outcomes


def outcome_table(outcomes: list[CheckOutcome]) -> str:
    """The pass/fail table with measured values."""
    rows = [
        {
            "check": o.check.name,
            "statistic": f"{o.check.statistic}({o.check.metric or ''})",
            "selected": o.selected,
            "runs": o.runs,
            "measured": o.measured,
            "threshold": o.check.threshold_text,
            "result": "PASS" if o.passed else "FAIL",
        }
        for o in outcomes
    ]
    notes = [f"  {o.check.name}: {o.note}" for o in outcomes if o.note]
    return format_table(rows) + ("\nNotes:\n" + "\n".join(notes) if notes else "")


def write_junit(path: str | Path, gate: Gate, outcomes: list[CheckOutcome]) -> None:
    """Write the outcomes as JUnit XML (one testcase per check), atomically."""
    failures = sum(not o.passed for o in outcomes)
    suites = ET.Element("testsuites", tests=str(len(outcomes)), failures=str(failures))
    suite = ET.SubElement(
        suites,
        "testsuite",
        name=gate.name,
        tests=str(len(outcomes)),
        failures=str(failures),
        errors="0",
        skipped="0",
        time=f"{sum(o.seconds for o in outcomes):.3f}",
    )
    for o in outcomes:
        case = ET.SubElement(
            suite,
            "testcase",
            classname=f"{gate.name}.{o.check.campaign_path.stem}",
            name=o.check.name,
            time=f"{o.seconds:.3f}",
        )
        text = (
            f"{o.check.statistic}({o.check.metric or ''}) over {o.runs} runs = "
            f"{o.measured!r}; required {o.check.threshold_text}; selected {o.selected} runs"
            + (f"; {o.note}" if o.note else "")
        )
        if not o.passed:
            ET.SubElement(case, "failure", message=text, type="threshold")
        ET.SubElement(case, "system-out").text = text
    tree = ET.ElementTree(suites)
    ET.indent(tree)
    p = Path(path)
    tmp = p.with_name(f".{p.name}.tmp")
    tree.write(tmp, encoding="utf-8", xml_declaration=True)
    tmp.replace(p)


__all__ = [
    "Check",
    "CheckOutcome",
    "Gate",
    "GateError",
    "load_gate",
    "outcome_table",
    "run_gate",
    "selection",
    "write_junit",
]
