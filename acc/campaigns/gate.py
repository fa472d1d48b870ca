"""``acc check``: run campaigns, compare statistics of their metrics with thresholds.

A gate file (format in ``docs/campaigns.md``)::

    [gate]
    name = "ci"

    [[check]]
    name = "PI: 95th-percentile RMS force error over the depth sweep"
    campaign = "ci_campaign.toml"        # relative to the gate file
    metric = "rms_error_N"
    statistic = "p95"                    # mean, median, min, max, std, pNN,
                                         # failed_count, failed_fraction
    where = { controller = "pi" }        # optional: only runs whose summary column matches
    max = 60.0                           # and/or min; a NaN measurement fails

Every campaign named by a check is swept once.  A check passes when its measured value is
finite, ``<= max`` and ``>= min``.  The result is a table, a JUnit XML file, and the exit
status (1 if any check fails).
"""

from __future__ import annotations

import math
import sys
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from acc.campaigns.campaign import CampaignError, load_campaign
from acc.campaigns.report import FAILURE_STATISTICS, check_statistic, format_table, statistic
from acc.campaigns.sweep import read_summary, run_sweep

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


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
    where : tuple of (str, str)
        ``(column, value)`` pairs a run must match to count (compared as text).
    max_value, min_value : float or None
        Thresholds, in the metric's unit.
    """

    name: str
    campaign_path: Path
    statistic: str
    metric: str | None = None
    where: tuple[tuple[str, str], ...] = ()
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
    """A check with its measured value and verdict."""

    check: Check
    measured: float
    passed: bool
    runs: int
    seconds: float


_CHECK_KEYS = ("name", "campaign", "metric", "statistic", "where", "max", "min")


def load_gate(path: str | Path) -> Gate:
    """Read and check a gate file, and every campaign it names.

    Raises
    ------
    GateError or CampaignError
        One line naming the file and the key.
    """
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise GateError(f"{p}: no such gate file") from None
    except tomllib.TOMLDecodeError as exc:
        raise GateError(f"{p}: not valid TOML: {exc}") from None
    for table in data:
        if table not in ("gate", "check"):
            raise GateError(f"{p}: [{table}]: unknown table (known: gate, check)")
    head = data.get("gate", {})
    for key in head:
        if key != "name":
            raise GateError(f"{p}: gate.{key}: unknown key (known: name)")
    specs = data.get("check", [])
    if not isinstance(specs, list) or not specs:
        raise GateError(f"{p}: no [[check]] (a gate needs at least one)")
    checks = []
    for i, spec in enumerate(specs):
        where = f"{p}: check[{i}]"
        for key in spec:
            if key not in _CHECK_KEYS:
                raise GateError(f"{where}.{key}: unknown key (known: {', '.join(_CHECK_KEYS)})")
        for key in ("campaign", "statistic"):
            if not isinstance(spec.get(key), str):
                raise GateError(f"{where}.{key}: required (a string)")
        try:
            check_statistic(spec["statistic"])
        except ValueError as exc:
            raise GateError(f"{where}.statistic: {exc}") from None
        metric = spec.get("metric")
        if spec["statistic"] not in FAILURE_STATISTICS and not isinstance(metric, str):
            raise GateError(f"{where}.metric: required for statistic {spec['statistic']!r}")
        bounds = {}
        for key in ("max", "min"):
            v = spec.get(key)
            if v is not None and (isinstance(v, bool) or not isinstance(v, int | float)):
                raise GateError(f"{where}.{key}: expected a number, got {v!r}")
            bounds[key] = None if v is None else float(v)
        if bounds["max"] is None and bounds["min"] is None:
            raise GateError(f"{where}: needs max or min")
        filt = spec.get("where", {})
        if not isinstance(filt, dict):
            raise GateError(f"{where}.where: expected a table {{ column = value }}")
        campaign_path = Path(spec["campaign"])
        if not campaign_path.is_absolute():
            campaign_path = p.parent / campaign_path
        load_campaign(campaign_path)  # a bad campaign fails here, before any run
        checks.append(
            Check(
                name=str(spec.get("name", f"check {i}")),
                campaign_path=campaign_path,
                statistic=spec["statistic"],
                metric=metric,
                where=tuple((str(k), _text(v)) for k, v in filt.items()),
                max_value=bounds["max"],
                min_value=bounds["min"],
            )
        )
    return Gate(name=str(head.get("name", p.stem)), source=str(p), checks=tuple(checks))


def _text(value: Any) -> str:
    from acc.campaigns.sweep import format_value

    return format_value(value)


def run_gate(gate: Gate, out_dir: str | Path, **sweep_options: Any) -> list[CheckOutcome]:
    """Sweep every campaign of a gate once (into ``out_dir/<campaign name>``) and judge.

    Parameters
    ----------
    gate : Gate
    out_dir : str or Path
    **sweep_options
        Passed to :func:`acc.campaigns.sweep.run_sweep` (backend, workers, engine, progress...).

    Returns
    -------
    list of CheckOutcome, in the gate's order
    """
    out = Path(out_dir)
    summaries: dict[Path, tuple[dict[str, np.ndarray], float]] = {}
    for check in gate.checks:
        if check.campaign_path in summaries:
            continue
        campaign = load_campaign(check.campaign_path)
        t0 = time.perf_counter()
        outcome = run_sweep(campaign, out / campaign.name, **sweep_options)
        summaries[check.campaign_path] = (
            read_summary(outcome.summary_path),
            time.perf_counter() - t0,
        )
    outcomes = []
    for check in gate.checks:
        summary, seconds = summaries[check.campaign_path]
        rows = np.ones(len(summary["run"]), dtype=bool)
        for column, value in check.where:
            if column not in summary:
                raise GateError(f"{gate.source}: {check.name}: where: no column {column!r}")
            rows &= np.array([_text(v) for v in summary[column]]) == value
        if check.metric is not None and check.metric not in summary:
            raise GateError(f"{gate.source}: {check.name}: no metric {check.metric!r}")
        measured = statistic(summary, check.statistic, check.metric, rows)
        outcomes.append(
            CheckOutcome(check, measured, check.passes(measured), int(rows.sum()), seconds)
        )
    return outcomes


def outcome_table(outcomes: list[CheckOutcome]) -> str:
    """The pass/fail table with measured values."""
    rows = [
        {
            "check": o.check.name,
            "statistic": f"{o.check.statistic}({o.check.metric or ''})",
            "runs": o.runs,
            "measured": o.measured,
            "threshold": o.check.threshold_text,
            "result": "PASS" if o.passed else "FAIL",
        }
        for o in outcomes
    ]
    return format_table(rows)


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
            f"{o.measured!r}; required {o.check.threshold_text}"
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
    "write_junit",
]
