"""Running a campaign: chunks of runs on local processes or a Dask cluster, resumable.

Layout of a sweep directory ``DIR``::

    DIR/campaign.json                 the resolved campaign and its fingerprint
    DIR/chunks/runs_00000000-00000063.csv   one file per finished chunk (its runs' rows)
    DIR/chunks/runs_00000000-00000063.npz   decimated traces of the chunk, when recorded
    DIR/summary.csv                   every run's parameters and metrics, sorted by run

Every file is written to a temporary name and renamed, so a file that exists is complete.
A chunk's CSV is its completion mark: ``resume`` simulates only the runs that no chunk file
holds.  ``DIR/.lock`` is held (``flock``) while a sweep runs in ``DIR``: a second sweep into
the same directory is refused in one line, and the lock dies with its process, so a killed
sweep can be resumed at once.  Worker processes exit when their parent dies.

A run whose simulation raises is recorded, not fatal: its chunk is simulated again run by
run, and the offending run gets ``failed = True`` and the exception in ``failure_reason``
(runs that diverge have ``failure_reason = "diverged"``).  Everything a sweep needs is
checked before any run (options, every run's scenario, the memory of a chunk); a sweep that
fails before its first chunk removes what it created.

The summary is assembled from the chunk files once every run is done; a run's row depends
only on the campaign, the root seed and the run number, so the summary is the same byte for
byte whatever the chunk size, the number of workers, the backend, or how often the sweep
was interrupted and resumed.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import gc
import io
import itertools
import json
import math
import os
import re
import shutil
import signal
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, CancelledError, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from acc.campaigns.campaign import Campaign, CampaignError
from acc.engine.result import SimulationResult
from acc.engine.simulate import check_batch_memory, engine_key
from acc.engine.threads import limit_blas_threads
from acc.limits import MAX_RUNS, shorten
from acc.scenarios.force import Scenario

try:  # POSIX advisory locks; elsewhere a sweep directory is not locked
    import fcntl
except ImportError:  # pragma: no cover
    fcntl = None  # type: ignore[assignment]

BACKENDS = ("local", "dask")
#: Boolean columns of a summary.
FLAG_COLUMNS = (
    "failed", "oscillating", "overload", "held_overload", "breakage_detected",
    "breakage_false_alarm", "breakage_missed",
)

#: How long a Dask client waits to connect, and to reconnect to a lost scheduler, before the
#: sweep stops (keeping its finished chunks) [s].
DASK_TIMEOUT_S = 20.0

_CHUNK_RE = re.compile(r"^runs_(\d{8})-(\d{8})\.csv$")

#: Leading descriptive columns of :meth:`SimulationResult.summary_rows`, in this order.
_DESCRIPTIVE = (
    "seed",
    "controller",
    "reference_force_N",
    "radial_depths_mm",
    "gain_multiplier",
    "dead_time_s",
    "noise_std_N",
    # the labs' (acc.scenarios.axis / contour summary rows)
    "path",
    "corner",
    "axis",
    "position_controller",
    "contour_controller",
    "trajectory",
    "cutting_load",
)
#: Metrics shown first, in this order; the rest follow (per-segment ones last).
_PREFERRED_METRICS = (
    "failed",
    "failure_reason",
    "rms_error_N",
    "iae_N_s",
    "ise_N2_s",
    "peak_force_N",
    "max_overshoot_pct",
    "machining_time_s",
    "conventional_time_s",
    "productivity_gain_pct",
    "cutting_time_s",
)
#: A per-segment metric column: ``<metric>_seg<N>``.
SEGMENT_RE = re.compile(r"^(.*)_seg(\d+)$")
#: Value of a column a run does not have (e.g. a segment its part lacks).
MISSING = "nan"


class SweepError(CampaignError):
    """A sweep that cannot start or resume (the message says why, in one line)."""


@dataclass(frozen=True)
class ChunkResult:
    """What a worker returns for one chunk.

    Attributes
    ----------
    run_ids : tuple of int
        The chunk's runs, ascending.
    text : str
        The chunk's CSV file as written: the header line, then one line per run, values
        already formatted (exact ``repr`` of floats); made in the worker (one string to hand
        over and write, not a dict per run).
    traces : dict of str to ndarray or None
        ``time_s`` (n,), ``run_ids`` (runs,), ``force_N`` and ``override`` (runs, n), when the
        campaign records traces.
    """

    run_ids: tuple[int, ...]
    text: str
    traces: dict[str, np.ndarray] | None

    @property
    def rows(self) -> tuple[dict[str, str], ...]:
        """One row per run, column name to cell (:data:`MISSING` where a run has none)."""
        return tuple(csv.DictReader(io.StringIO(self.text, newline="")))

    @classmethod
    def from_rows(
        cls,
        run_ids: Sequence[int],
        rows: Sequence[dict[str, str]],
        traces: dict[str, np.ndarray] | None = None,
    ) -> ChunkResult:
        """A chunk from its formatted rows, in run order: the columns are the first row's
        when it has them all (their canonical order), else every row's in canonical order
        (:data:`MISSING` where a row has none)."""
        names: set[str] = set()
        for row in rows:
            names.update(row)
        columns = list(rows[0])
        if set(columns) != names:
            columns = column_order(names, [])
        return cls(
            tuple(run_ids),
            _csv_text(columns, [[row.get(c, MISSING) for c in columns] for row in rows]),
            traces,
        )


def _csv_text(columns: Sequence[str], lines: Iterable[Sequence[str]]) -> str:
    """A CSV file's text: the header, then the lines (cells quoted where needed)."""
    out = io.StringIO(newline="")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(columns)
    writer.writerows(lines)
    return out.getvalue()


@dataclass(frozen=True)
class SweepOutcome:
    """What :func:`run_sweep` did.

    Attributes
    ----------
    summary_path : Path
    runs : int
        Runs in the campaign.
    simulated_runs : int
        Runs simulated by this call (fewer than ``runs`` after a resume).
    failed_runs : int
        Runs marked failed (unstable) in the summary.
    """

    summary_path: Path
    runs: int
    simulated_runs: int
    failed_runs: int


def format_value(value: Any) -> str:
    """A cell of the summary: exact ``repr`` for floats, space-separated lists."""
    tp = type(value)  # the common exact types first: a summary has 1e5 rows of 50 cells
    if tp is float:
        return repr(value)
    if tp is str:
        return value
    if tp is int or tp is bool:
        return str(value)
    if isinstance(value, bool | np.bool_):
        return str(bool(value))
    if isinstance(value, float | np.floating):
        return repr(float(value))
    if isinstance(value, list | tuple | np.ndarray):
        return " ".join(format_value(v) for v in value)
    return str(value)


def column_order(columns: Iterable[str], swept: Sequence[str]) -> list[str]:
    """Canonical order of summary columns, independent of which runs a chunk holds.

    ``run``; the swept keys in campaign order; the descriptive columns; ``failed`` and the
    main metrics; other columns alphabetically; per-segment metrics last, by segment.
    """
    swept = list(swept)

    def rank(name: str) -> tuple:
        if name == "run":
            return (0, 0, "")
        if name in swept:
            return (1, swept.index(name), "")
        if name in _DESCRIPTIVE:
            return (2, _DESCRIPTIVE.index(name), "")
        if name in _PREFERRED_METRICS:
            return (3, _PREFERRED_METRICS.index(name), "")
        seg = SEGMENT_RE.match(name)
        if seg:
            return (5, int(seg.group(2)), seg.group(1))
        return (4, 0, name)

    return sorted(set(columns), key=rank)


def result_table(
    campaign: Campaign,
    result: SimulationResult,
    swept: dict[int, dict[str, Any]] | None = None,
) -> tuple[list[str], list[tuple[str, ...]]]:
    """The formatted summary of a result, a column at a time: the columns (run, swept
    values, then metrics, in :func:`column_order`) and one line of cells per run.

    ``swept`` maps run -> its swept values when the caller has them (else drawn again).
    """
    table = result.summary_table()
    runs = table["run"]
    values = [swept[r] if swept is not None else campaign.values(r) for r in runs]
    keys = list(values[0]) if values else []
    if any(list(v) != keys for v in values):
        raise ValueError("the runs of a result have different swept keys")
    full: dict[str, list[Any]] = {"run": runs}
    for k in keys:
        full[k] = [v[k] for v in values]
    full.update(table)
    order = column_order(full, campaign.swept_keys)
    cells = [
        # most cells are floats: their repr without format_value's dispatch
        [repr(v) if type(v) is float else format_value(v) for v in full[k]]
        for k in order
    ]
    return order, list(zip(*cells, strict=True))


def result_rows(
    campaign: Campaign,
    result: SimulationResult,
    swept: dict[int, dict[str, Any]] | None = None,
) -> tuple[dict[str, str], ...]:
    """Formatted summary rows of a result: run, swept values, then metrics
    (:func:`result_table`, a dict per run)."""
    columns, lines = result_table(campaign, result, swept)
    return tuple(dict(zip(columns, line, strict=True)) for line in lines)


def simulate_chunk(
    campaign: Campaign, run_ids: Sequence[int], checked: bool = False
) -> ChunkResult:
    """Simulate one chunk of a campaign (what a worker process runs).

    Runs that share compiled elements are simulated as one batch; if a batch raises, its
    runs are simulated one by one and a run that raises on its own is recorded as failed,
    with the exception as its ``failure_reason`` (its metrics are absent: NaN in the
    summary).

    Parameters
    ----------
    campaign : Campaign
    run_ids : sequence of int, shape (runs,)
        Ascending run numbers.
    checked : bool
        Every run of the campaign was validated before the sweep (:meth:`Campaign.validate`):
        the runs' scenarios are rebuilt without repeating the cross-section checks.

    Returns
    -------
    ChunkResult
    """
    ids = [int(r) for r in run_ids]
    swept = {r: campaign.values(r) for r in ids}
    scenarios = [campaign.scenario(r, swept[r], checked=checked) for r in ids]
    if campaign.model != "force":
        return _simulate_lab_chunk(campaign, scenarios, ids, swept)
    groups: dict[tuple, list[int]] = {}
    for j, sc in enumerate(scenarios):
        groups.setdefault(engine_key(sc), []).append(j)
    # each batch's lines and their columns; the failed runs' rows
    tables: list[tuple[list[str], list[tuple[str, ...]]]] = []
    failed: list[dict[str, str]] = []
    parts: list[dict[str, np.ndarray]] = []
    for members in groups.values():
        batches = [members]
        while batches:
            batch = batches.pop()
            try:
                result = _simulate_batch(
                    campaign, [scenarios[j] for j in batch], [ids[j] for j in batch]
                )
            except Exception as exc:  # noqa: BLE001 - recorded as the run's failure
                if len(batch) > 1:
                    batches.extend([j] for j in reversed(batch))
                    continue
                j = batch[0]
                failed.append(failed_row(campaign, scenarios[j], ids[j], swept[ids[j]], exc))
                parts.append(_empty_traces(ids[j]))
                continue
            tables.append(result_table(campaign, result, swept))
            parts.append(
                {
                    "time_s": np.asarray(result.time_s),
                    "run_ids": np.asarray(result.run_ids),
                    "force_N": np.asarray(
                        result.signals.get("force_N", np.empty((len(batch), 0)))
                    ),
                    "override": np.asarray(
                        result.signals.get("override", np.empty((len(batch), 0)))
                    ),
                }
            )
    traces = None
    if campaign.record_every_steps is not None:
        traces = _stack_traces(parts)
    if not failed and all(columns == tables[0][0] for columns, _ in tables):
        # the usual chunk: every run has the same columns, written as they are
        lines = [line for _, part in tables for line in part]
        lines.sort(key=lambda line: int(line[0]))
        return ChunkResult(tuple(ids), _csv_text(tables[0][0], lines), traces)
    rows = failed + [
        dict(zip(columns, line, strict=True)) for columns, part in tables for line in part
    ]
    rows.sort(key=lambda row: int(row["run"]))
    return ChunkResult.from_rows(ids, rows, traces)


def lab_row(scenario: Any) -> dict[str, Any]:
    """Simulate one axis or contouring run and return its summary row (the scenario's
    ``summary_row``, with the run's seed)."""
    from acc import scenarios as labs

    if labs.model_of_scenario(scenario) == "axis":
        row = scenario.summary_row(scenario.simulate(record_every_steps=None))
    else:
        row = scenario.summary_row(*scenario.simulate())
    return {"seed": scenario.simulation.seed, **row}


def _simulate_lab_chunk(
    campaign: Campaign, scenarios: list[Any], ids: list[int], swept: dict[int, dict[str, Any]]
) -> ChunkResult:
    """A chunk of an axis or contouring campaign: its runs one by one (a run that raises
    is recorded as failed, like the force loop's)."""
    rows = []
    for sc, run in zip(scenarios, ids, strict=True):
        try:
            row = lab_row(sc)
        except Exception as exc:  # noqa: BLE001 - recorded as the run's failure
            rows.append(failed_row(campaign, sc, run, swept[run], exc))
            continue
        full = {"run": str(run), **{k: format_value(v) for k, v in swept[run].items()}}
        full.update({k: format_value(v) for k, v in row.items()})
        rows.append({k: full[k] for k in column_order(full, campaign.swept_keys)})
    return ChunkResult.from_rows(ids, rows)


def summary_columns(campaign: Campaign, points: int = 16) -> set[str] | None:
    """The columns a campaign's summary will have, from short probe runs before the sweep.

    The first run of up to ``points`` grid points (evenly spread) is simulated: force-loop
    runs for one control period (their columns do not depend on the length), axis runs for
    10 plant steps, contouring runs whole (their metrics depend on the path).  A column only
    some runs have (a segment a longer part adds) may be missing; callers accept
    ``<metric>_segN`` for any ``<metric>_seg0`` they see.

    Returns
    -------
    set of str or None
        ``run``, the swept keys and every column of the probe runs' rows; None when every
        probe run raised (nothing is known).
    """
    step = max(1, campaign.points // points)
    runs = [p * campaign.samples_per_point for p in range(0, campaign.points, step)][:points]
    columns = {"run", *campaign.swept_keys}
    shapes = set()
    informative = False
    for run in runs:
        sc = campaign.scenario(run)
        model = campaign.model
        if model == "xy_contour":  # whole runs: one per kind of path (its metrics)
            shape = (sc.path.kind, sc.path.corner)
            if shape in shapes:
                continue
            shapes.add(shape)
        elif model == "force":
            sim = sc.simulation
            sc = sc.with_values({"simulation.time_limit_s": sim.control_period_s})
        elif model == "axis":
            sim = sc.simulation
            sc = sc.with_values({"simulation.duration_s": 10 * sim.plant_step_s})
        chunk = simulate_chunk(dataclasses.replace(campaign, base=sc, grid=(), random=(),
                                                   samples_per_point=1, pair_over=()), [0])
        if not chunk.rows[0].get("failure_reason", "").startswith("raised"):
            columns.update(chunk.rows[0])  # (a run that raised has no metric columns)
            informative = True
    return columns if informative else None


def _simulate_batch(
    campaign: Campaign, scenarios: list[Scenario], ids: list[int]
) -> SimulationResult:
    from acc.engine.simulate import simulate

    return simulate(
        scenarios,
        run_ids=ids,
        noise_ids=[campaign.noise_id(r) for r in ids],
        record_every_steps=campaign.record_every_steps,
        threads=1,  # the chunks are what runs in parallel
    )


def _empty_traces(run_id: int) -> dict[str, np.ndarray]:
    return {
        "time_s": np.empty(0),
        "run_ids": np.array([run_id]),
        "force_N": np.empty((1, 0)),
        "override": np.empty((1, 0)),
    }


def failed_row(
    campaign: Campaign,
    scenario: Scenario,
    run_id: int,
    values: dict[str, Any],
    exc: BaseException,
) -> dict[str, str]:
    """The summary row of a run whose simulation raised: its parameters, ``failed = True``
    and the exception (one line) in ``failure_reason``; no metric columns (NaN)."""
    if campaign.model != "force":
        row: dict[str, Any] = {"run": run_id, **values, "seed": scenario.simulation.seed}
    else:
        row = {
            "run": run_id,
            **values,
            "seed": scenario.simulation.seed,
            "controller": scenario.controller.kind,
            "reference_force_N": scenario.controller.reference_force_N,
            "radial_depths_mm": " ".join(f"{d:g}" for d in scenario.workpiece.radial_depth_mm),
            "gain_multiplier": scenario.force_process.gain_multiplier,
            "dead_time_s": scenario.feed_drive.dead_time_s,
            "noise_std_N": scenario.sensor.noise_std_N,
        }
    row.update(failed=True, failure_reason=f"raised {type(exc).__name__}: {shorten(str(exc))}")
    full = {k: format_value(v) for k, v in row.items()}
    return {k: full[k] for k in column_order(full, campaign.swept_keys)}


def _stack_traces(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Traces of several batches as one, sorted by run and NaN-padded to the longest."""
    longest = max(parts, key=lambda d: len(d["time_s"]))
    n = len(longest["time_s"])
    run_ids = np.concatenate([d["run_ids"] for d in parts])
    order = np.argsort(run_ids, kind="stable")
    out: dict[str, np.ndarray] = {"time_s": longest["time_s"], "run_ids": run_ids[order]}
    for name in ("force_N", "override"):
        padded = []
        for d in parts:
            a = np.full((d[name].shape[0], n), math.nan)
            a[:, : d[name].shape[1]] = d[name]
            padded.append(a)
        out[name] = np.concatenate(padded)[order]
    return out


def chunk_name(first: int, last: int) -> str:
    """File stem of the chunk holding runs ``first..last``."""
    return f"runs_{first:08d}-{last:08d}"


def finished_runs(chunk_dir: Path) -> list[tuple[int, int, Path]]:
    """``(first, last, path)`` of every complete chunk file, sorted by first run."""
    out = []
    if chunk_dir.is_dir():
        for p in chunk_dir.iterdir():
            m = _CHUNK_RE.match(p.name)
            if m:
                out.append((int(m.group(1)), int(m.group(2)), p))
    return sorted(out)


def plan_chunks(runs: int, done: Iterable[tuple[int, int]], chunk_runs: int) -> list[range]:
    """Split the runs no finished chunk holds into contiguous chunks of at most
    ``chunk_runs``, each a ``range`` (a list of Python ints would hold 36 bytes a run in the
    parent for the whole sweep: 36 MB at 1e6 runs)."""
    todo = np.ones(runs, dtype=bool)
    for first, last in done:
        todo[first : last + 1] = False
    chunks: list[range] = []
    ids = np.flatnonzero(todo)
    if len(ids) == 0:
        return chunks
    breaks = np.flatnonzero(np.diff(ids) != 1) + 1
    for first, stop in zip(
        [int(ids[0]), *(int(ids[b]) for b in breaks)],
        [*(int(ids[b - 1]) + 1 for b in breaks), int(ids[-1]) + 1],
        strict=True,
    ):
        chunks += [range(a, min(a + chunk_runs, stop)) for a in range(first, stop, chunk_runs)]
    return chunks


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def write_chunk(chunk_dir: Path, chunk: ChunkResult) -> Path:
    """Write a chunk's traces (if any) then its CSV, each atomically; return the CSV path."""
    stem = chunk_name(chunk.run_ids[0], chunk.run_ids[-1])
    if chunk.traces is not None:
        tmp = chunk_dir / f".{stem}.npz.tmp"
        with tmp.open("wb") as fh:
            np.savez(fh, **chunk.traces)
        os.replace(tmp, chunk_dir / f"{stem}.npz")
    path = chunk_dir / f"{stem}.csv"
    tmp = chunk_dir / f".{stem}.csv.tmp"
    with tmp.open("w", newline="", encoding="utf-8") as fh:
        fh.write(chunk.text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    return path


def assemble_summary(
    out_dir: Path,
    campaign: Campaign,
    before_commit: Callable[[Path], None] | None = None,
) -> tuple[Path, int]:
    """Concatenate the chunk files into ``summary.csv`` (atomically), rows sorted by run.

    Parameters
    ----------
    out_dir : Path
    campaign : Campaign
    before_commit : callable or None
        Called with the finished temporary summary before it is renamed ``summary.csv``
        (e.g. to write the report and figures: ``summary.csv`` appears last, so a directory
        that has it holds a complete result).  If it raises, no ``summary.csv`` is written.

    Returns
    -------
    path : Path
    failed_runs : int

    Raises
    ------
    SweepError
        Runs missing or held twice.
    """
    chunks = finished_runs(out_dir / "chunks")
    expected = 0
    for first, last, _ in chunks:
        if first != expected:
            kind = "missing" if first > expected else "held twice"
            raise SweepError(f"{out_dir}: runs from {min(first, expected)} are {kind}")
        expected = last + 1
    if expected != campaign.runs:
        raise SweepError(f"{out_dir}: runs {expected}..{campaign.runs - 1} are missing")
    columns: set[str] = set()
    for _, _, path in chunks:
        with path.open(newline="", encoding="utf-8") as fh:
            columns.update(next(csv.reader(fh)))
    header = column_order(columns, campaign.swept_keys)
    summary = out_dir / "summary.csv"
    tmp = out_dir / ".summary.csv.tmp"
    failed = 0
    with tmp.open("w", newline="", encoding="utf-8") as out:
        writer = csv.DictWriter(out, fieldnames=header, restval=MISSING, lineterminator="\n")
        writer.writeheader()
        for _, _, path in chunks:
            failed += _append_chunk(path, header, writer, out)
    try:
        if before_commit is not None:
            before_commit(tmp)
        os.replace(tmp, summary)
    finally:
        tmp.unlink(missing_ok=True)
    return summary, failed


def _append_chunk(path: Path, header: list[str], writer: csv.DictWriter, out: Any) -> int:
    """Append a chunk file's rows to the summary being written; return its failed runs.

    A chunk whose columns are the summary's, in its order (every chunk of a sweep whose
    runs all report the same metrics), is copied as text; another is rewritten row by row
    into the summary's columns (:data:`MISSING` where it has none).
    """
    with path.open(newline="", encoding="utf-8") as fh:
        text = fh.read()
    first_line, _, body = text.partition("\n")
    columns = next(csv.reader([first_line]))
    if columns == header and body.endswith("\n"):
        out.write(body)
        if "failed" not in columns:
            return 0
        j = columns.index("failed")
        return sum(row[j] == "True" for row in csv.reader(io.StringIO(body, newline="")))
    failed = 0
    for row in csv.DictReader(io.StringIO(text, newline="")):
        failed += row.get("failed") == "True"
        writer.writerow(row)
    return failed


def _prepare(out_dir: Path, campaign: Campaign, resume: bool) -> bool:
    """Check ``out_dir`` against the campaign and write ``campaign.json`` if needed.

    Returns True if this call wrote ``campaign.json`` (a new sweep).
    """
    chunk_dir = out_dir / "chunks"
    meta_path = out_dir / "campaign.json"
    meta = {"fingerprint": campaign.fingerprint(), "source": campaign.source}
    if meta_path.exists():
        try:
            old = json.loads(meta_path.read_text(encoding="utf-8"))
        except (OSError, ValueError, UnicodeDecodeError):
            raise SweepError(
                f"{out_dir}: campaign.json is unreadable; sweep into a new directory"
            ) from None
        if not resume:
            raise SweepError(
                f"{out_dir}: already holds a sweep; pass --resume or choose a new --out"
            )
        if not isinstance(old, dict) or old.get("fingerprint") != meta["fingerprint"]:
            raise SweepError(
                f"{out_dir}: holds a different campaign (the file, its base scenario or its "
                "seed changed); sweep into a new directory"
            )
        chunk_dir.mkdir(exist_ok=True)
        for stale in chunk_dir.glob(".*.tmp"):
            stale.unlink()
        return False
    if finished_runs(chunk_dir) or (out_dir / "summary.csv").exists():
        raise SweepError(
            f"{out_dir}: holds sweep results without campaign.json; choose a new --out"
        )
    # a new sweep, or one killed before campaign.json was written: (re)start it
    chunk_dir.mkdir(parents=True, exist_ok=True)
    for stale in chunk_dir.glob(".*.tmp"):
        stale.unlink()
    from acc.output import code_revision, package_versions

    written = {**meta, "code": code_revision(), "versions": package_versions(),
               "campaign": campaign.to_dict()}
    _atomic_write_text(meta_path, json.dumps(written, indent=1, default=str))
    return True


@contextlib.contextmanager
def sweep_lock(out_dir: Path) -> Iterator[None]:
    """Hold ``out_dir/.lock`` for a sweep; a second holder is refused in one line.

    The lock is an advisory ``flock``: released when the process ends, even by SIGKILL.

    Raises
    ------
    SweepError
        Another process holds the lock.
    """
    if fcntl is None:  # pragma: no cover
        yield
        return
    path = out_dir / ".lock"
    fh = path.open("a+", encoding="utf-8")
    try:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.seek(0)
            holder = fh.read().strip() or "another process"
            raise SweepError(
                f"{out_dir}: in use by another sweep ({holder}); wait for it or choose "
                "another --out"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()}\n")
        fh.flush()
        yield
    finally:
        fh.close()


def check_execution(
    backend: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    chunk_runs: int | None = None,
) -> None:
    """Check the execution options before any work (one-line :class:`SweepError`)."""
    if backend not in BACKENDS:
        raise SweepError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "dask":
        if not scheduler:
            raise SweepError("backend 'dask' needs a scheduler address (--scheduler)")
        check_scheduler_address(scheduler)
    elif scheduler:
        raise SweepError("--scheduler needs --backend dask")
    if workers is not None and not 1 <= workers <= 4096:
        raise SweepError(f"--workers must be in 1..4096, got {workers}")
    if chunk_runs is not None and not 1 <= chunk_runs <= MAX_RUNS:
        raise SweepError(f"--chunk-runs must be in 1..{MAX_RUNS}, got {chunk_runs}")


def check_scheduler_address(address: str) -> None:
    """Refuse a malformed Dask scheduler address (``[tcp://]host:port``) in one line."""
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
        from distributed.comm.registry import backends
    except ImportError:  # pragma: no cover
        raise SweepError("--backend dask needs Dask: pip install 'acc[dask]' (dask[distributed])"
                         ) from None
    try:
        scheme, location = parse_address(address)
        if scheme not in backends:
            raise ValueError(f"unknown protocol {scheme!r} (known: {', '.join(backends)})")
        if scheme in ("tcp", "tls", "ws", "wss"):
            host, port = parse_host_port(location)
            if not host or not 0 < int(port) < 65536:
                raise ValueError("expected host:port with a port in 1..65535")
    except (ValueError, TypeError) as exc:
        raise SweepError(
            f"--scheduler {address!r}: not a Dask scheduler address ({exc}); expected e.g. "
            "tcp://host:8786"
        ) from None


def run_sweep(
    campaign: Campaign,
    out_dir: str | Path,
    *,
    backend: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    chunk_runs: int | None = None,
    resume: bool = False,
    progress: bool = True,
    validate: bool = True,
    before_commit: Callable[[Path], None] | None = None,
    ahead: Callable[[], None] | None = None,
) -> SweepOutcome:
    """Simulate every run of a campaign in chunks and write ``DIR/summary.csv``.

    Parameters
    ----------
    campaign : Campaign
    out_dir : str or Path
        Sweep directory (created).
    backend : {"local", "dask"}
        Local worker processes, or the Dask cluster at ``scheduler``.
    workers : int or None
        Local worker processes (default: all cores); 1 simulates in this process.
    scheduler : str or None
        Address of a Dask scheduler (``backend="dask"``).
    chunk_runs : int or None
        Runs per chunk (default: the campaign's ``chunk_runs``).
    resume : bool
        Continue a sweep in ``out_dir``: only runs no chunk file holds are simulated.  A
        directory that does not exist yet, or holds no ``campaign.json`` (killed before it
        was written), starts the sweep.
    progress : bool
        Report progress (runs): a bar on a terminal, else plain periodic lines on the ``acc``
        logger (:mod:`acc.campaigns.progress`).
    validate : bool
        Build every run's scenario before the first run (a bad sampled value fails at once).
    before_commit : callable or None
        See :func:`assemble_summary`: runs on the finished summary before it is committed.
    ahead : callable or None
        Work ``before_commit`` will need that does not depend on the results (e.g. importing
        the plotting modules): called once in this process while local workers simulate the
        last chunks and a core is free, else not at all; an exception in it is ignored.

    Returns
    -------
    SweepOutcome

    Raises
    ------
    SweepError, CampaignError
        Before any run: bad options, a run that cannot be built, a chunk too large for
        memory, a directory in use or holding another campaign.
    """
    check_execution(backend, workers, scheduler, chunk_runs)
    size = campaign.chunk_runs if chunk_runs is None else chunk_runs
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise SweepError(f"{out}: exists and is not a directory")
    created = _make_dir(out)
    wrote_meta = False
    with sweep_lock(out):  # (only the lock's holder may clean up)
        try:
            n = (os.cpu_count() or 1) if workers is None else workers
            samples = _validate(
                campaign, size, validate, n if backend == "local" else 1,
                preload=backend == "local",
            )
            wrote_meta = _prepare(out, campaign, resume)
            outcome = _sweep(
                campaign, out, size, backend, workers, scheduler, progress, samples, before_commit,
                checked=validate, ahead=ahead,
            )
        except BaseException:
            _clean_unstarted(out, created, wrote_meta)
            raise
    return outcome


def _validate(
    campaign: Campaign, size: int, validate: bool, workers: int = 1, preload: bool = False
) -> dict[tuple, Scenario]:
    """Build every run's scenario (if ``validate``) and check a chunk's memory; return one
    scenario per distinct compiled configuration (to load the engine once).

    With ``workers > 1`` and enough runs, the runs are built in that many processes at once
    (this one and forked children, :func:`_validate_in_processes`), this one first loading
    the engine for run 0's configuration if ``preload`` (:func:`preload_engine`: the
    simulating workers fork from it); the error raised is the same (that of the first run in
    order that cannot be built), and still before any run is simulated."""
    chunk = min(size, campaign.runs)
    if campaign.model != "force":  # runs one by one, metrics only: build each run once
        if validate:
            campaign.validate()
        return {}
    # a first estimate from run 0, before building every run (which may take a while)
    first = campaign.scenario(0)
    check_batch_memory([first], chunk, campaign.record_every_steps, campaign.source)
    if not validate:
        return {}
    n = max(1, min(workers, campaign.runs // PARALLEL_VALIDATION_RUNS))
    meanwhile: BaseException | None = None
    if n == 1:
        parts = [validate_runs(campaign, 0, campaign.runs)]
    else:
        parts, meanwhile = _validate_in_processes(
            campaign, n, (lambda: preload_engine([first])) if preload else None
        )
    samples: dict[tuple, Scenario] = {}
    largest: dict[str, Scenario] = {}
    for error, part_samples, part_largest in parts:  # in run order
        if error is not None:
            raise CampaignError(error)
        for key, sc in part_samples.items():
            samples.setdefault(key, sc)
        for what, sc in part_largest.items():
            if what not in largest or _size(what, sc) > _size(what, largest[what]):
                largest[what] = sc
    if meanwhile is not None:  # the runs are sound: loading the engine failed
        raise meanwhile
    if largest:
        check_batch_memory(
            list(largest.values()), chunk, campaign.record_every_steps, what=campaign.source
        )
    return samples


_ValidatedPart = tuple[str | None, dict[tuple, Scenario], dict[str, Scenario]]

#: Runs a validating process builds at a time (:func:`_validate_in_processes`).
VALIDATION_BLOCK_RUNS = 250


def _validate_in_processes(
    campaign: Campaign, processes: int, meanwhile: Callable[[], None] | None
) -> tuple[list[_ValidatedPart], BaseException | None]:
    """:func:`validate_runs` of every run in ``processes`` processes: this one and
    ``processes - 1`` forked children, each taking the next block of
    :data:`VALIDATION_BLOCK_RUNS` runs in run order until none is left; this process first
    runs ``meanwhile`` (loading the engine: however long it takes, the children build the
    runs meanwhile).  Returns the blocks' parts in run order and what ``meanwhile`` raised
    (an :class:`Exception`; None if nothing).

    A block that meets a run that cannot be built stops the taking of later blocks; every
    earlier block has been taken, and is finished, so the first such run in order is among
    the parts.  Plain child processes, not a pool: a pool's tasks are handed out by a thread
    of this process, which ``meanwhile`` (holding the interpreter) would hold up.  The
    children leave Ctrl-C to this process and die with it (:func:`_worker_init`); an
    exception a child raises is raised here."""
    import multiprocessing

    context = multiprocessing.get_context()
    taken = context.Value("q", 0)  # blocks handed out so far (with its lock)
    children = []
    try:
        for _ in range(processes - 1):
            receive, send = context.Pipe(duplex=False)
            child = context.Process(
                target=_validate_child, args=(send, campaign, taken, os.getpid()), daemon=True
            )
            child.start()
            send.close()
            children.append((child, receive))
        failure: BaseException | None = None
        if meanwhile is not None:
            try:
                meanwhile()
            except Exception as exc:  # raised once the runs are known to be sound
                failure = exc
        blocks = _validate_blocks(campaign, taken)
        for child, receive in children:
            try:
                status, value = receive.recv()
            except EOFError:
                child.join()
                raise SweepError(
                    f"{campaign.source}: a process building the runs ended without a result "
                    f"(exit code {child.exitcode})"
                ) from None
            if status == "raised":
                raise value
            blocks.extend(value)
    finally:
        for child, receive in children:
            receive.close()
            if child.is_alive():
                child.terminate()
            child.join()
    blocks.sort(key=lambda block: block[0])
    return [part for _, part in blocks], failure


def _validate_blocks(campaign: Campaign, taken: Any) -> list[tuple[int, _ValidatedPart]]:
    """Build the next block of runs (``taken``: the shared count of blocks handed out) until
    none is left or a run cannot be built; returns ``(first run, part)`` of each block."""
    size = VALIDATION_BLOCK_RUNS
    last = -(-campaign.runs // size)
    done = []
    while True:
        with taken.get_lock():
            block = taken.value
            taken.value = block + 1
        if block >= last:
            return done
        first = block * size
        part = validate_runs(campaign, first, min(first + size, campaign.runs))
        done.append((first, part))
        if part[0] is not None:  # no later block is needed
            with taken.get_lock():
                taken.value = last
            return done


def _validate_child(send: Any, campaign: Campaign, taken: Any, parent_pid: int) -> None:
    """The body of a child of :func:`_validate_in_processes`: ``("ok", blocks)`` or
    ``("raised", exception)`` sent to the parent."""
    _worker_init(parent_pid)
    try:
        result: tuple[str, Any] = ("ok", _validate_blocks(campaign, taken))
    except Exception as exc:
        result = ("raised", exc)
    try:
        send.send(result)
    except Exception as exc:  # what does not pickle is sent as words
        what = result[1] if result[0] == "raised" else exc
        send.send(("raised", SweepError(shorten(f"{type(what).__name__}: {what}"))))
    send.close()


#: Runs per validating process at least (fewer: one process builds them all).
PARALLEL_VALIDATION_RUNS = 1000


def _size(what: str, scenario: Scenario) -> float:
    """What :func:`check_batch_memory` grows with: the feed drive's delay line, the
    nominal dead time's."""
    if what == "delay":
        return scenario.delay_steps
    return scenario.nominal_plant.dead_time_s


def validate_runs(
    campaign: Campaign, first: int, stop: int
) -> tuple[str | None, dict[tuple, Scenario], dict[str, Scenario]]:
    """Build the runs numbered ``first`` to ``stop - 1`` of a force-loop campaign, in order.

    Returns
    -------
    error : str or None
        The one-line message of the first run that cannot be built (then the rest are not).
    samples : dict
        The first scenario of each compiled configuration (:func:`engine_key`).
    largest : dict
        The first scenario with the longest feed-drive delay (``"delay"``) and nominal dead
        time (``"nominal"``).
    """
    samples: dict[tuple, Scenario] = {}
    largest: dict[str, Scenario] = {}
    for start in range(first, stop, VALIDATION_BLOCK_RUNS):
        block = range(start, min(start + VALIDATION_BLOCK_RUNS, stop))
        # a block's values drawn first, then its runs built: NumPy's generators and the
        # scenario code, alternated run by run, cost about 14 us a run more (70 against
        # 55 us a run of bench_loop.py's speed campaign)
        drawn = [campaign.values(r) for r in block]
        for r, values in zip(block, drawn, strict=True):
            try:
                scenario = campaign.scenario(r, values)
            except CampaignError as exc:
                return str(exc), samples, largest
            samples.setdefault(engine_key(scenario), scenario)
            for what in ("delay", "nominal"):
                if what not in largest or _size(what, scenario) > _size(what, largest[what]):
                    largest[what] = scenario
    return None, samples, largest


def _make_dir(out: Path) -> list[Path]:
    """Create ``out`` and missing parents; return the directories created (outermost first)."""
    made = []
    p = out.absolute()
    while not p.exists():
        made.append(p)
        p = p.parent
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepError(f"{out}: cannot create: {exc.strerror or exc}") from None
    return list(reversed(made))


def _clean_unstarted(out: Path, created: list[Path], wrote_meta: bool) -> None:
    """After a failure: if no chunk was finished, remove what this sweep created."""
    chunk_dir = out / "chunks"
    if finished_runs(chunk_dir):
        return  # resumable work is kept
    if created:
        shutil.rmtree(created[0], ignore_errors=True)
        return
    if wrote_meta:
        with contextlib.suppress(OSError):
            (out / "campaign.json").unlink()
        with contextlib.suppress(OSError):
            for stale in chunk_dir.glob(".*.tmp"):
                stale.unlink()
            chunk_dir.rmdir()
        with contextlib.suppress(OSError):
            (out / ".lock").unlink()


def _sweep(
    campaign: Campaign,
    out: Path,
    size: int,
    backend: str,
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    samples: dict[tuple, Scenario],
    before_commit: Callable[[Path], None] | None,
    checked: bool = False,
    ahead: Callable[[], None] | None = None,
) -> SweepOutcome:
    chunk_dir = out / "chunks"
    done = [(a, b) for a, b, _ in finished_runs(chunk_dir)]
    todo = plan_chunks(campaign.runs, done, size)
    remaining = sum(len(c) for c in todo)

    from acc.campaigns.progress import Progress

    bar = Progress(campaign.runs, campaign.runs - remaining, campaign.name, enabled=progress)
    try:
        if todo and backend == "local" and campaign.model == "force":
            preload_engine(samples.values() or [campaign.scenario(todo[0][0])])
        for chunk in _execute(campaign, todo, backend, workers, scheduler, checked, ahead):
            write_chunk(chunk_dir, chunk)
            bar.update(len(chunk.run_ids))
    finally:
        bar.close()
    summary, failed = assemble_summary(out, campaign, before_commit)
    return SweepOutcome(summary, campaign.runs, remaining, failed)


def _execute(
    campaign: Campaign,
    todo: list[range],
    backend: str,
    workers: int | None,
    scheduler: str | None,
    checked: bool = False,
    ahead: Callable[[], None] | None = None,
) -> Iterable[ChunkResult]:
    """Yield chunk results as they finish (``checked``: every run was validated by this
    process, local workers need not check the runs again; a Dask cluster's workers do;
    ``ahead``: see :func:`run_sweep`)."""
    if not todo:
        return
    if backend == "dask":
        yield from _execute_dask(campaign, todo, scheduler)
        return
    n = (os.cpu_count() or 1) if workers is None else workers
    if n == 1 or len(todo) == 1:
        for ids in todo:
            yield simulate_chunk(campaign, ids, checked)
        return
    workers_used = min(n, len(todo))
    with shared_heap(), ProcessPoolExecutor(
        max_workers=workers_used, initializer=_worker_init, initargs=(os.getpid(),)
    ) as pool:
        # a bounded window of chunks in flight: a finished chunk is handed on and dropped,
        # so the parent holds at most 2 chunks per worker whatever the run count
        pending = iter(todo)
        running: set[Any] = set()
        unsubmitted = len(todo)
        try:
            while True:
                for ids in itertools.islice(pending, 2 * workers_used - len(running)):
                    running.add(pool.submit(simulate_chunk, campaign, ids, checked))
                    unsubmitted -= 1
                if not running:
                    break
                if ahead is not None and unsubmitted == 0 and len(running) < workers_used:
                    # the last chunks run and a worker is idle: a core is free (a failure
                    # is left for the work that needs it to meet)
                    with contextlib.suppress(Exception):
                        ahead()
                    ahead = None
                finished, _ = wait(running, return_when=FIRST_COMPLETED)
                fut = finished.pop()
                running.discard(fut)
                chunk = fut.result()
                del finished, fut
                yield chunk
                del chunk
        except BaseException:
            for fut in running:
                fut.cancel()
            raise


@contextlib.contextmanager
def shared_heap() -> Iterator[None]:
    """Keep the objects of this process out of the garbage collector's scans while the
    block runs (``gc.freeze``), then hand them back.

    Workers forked meanwhile share the parent's pages until one writes to them; a full
    collection in a worker writes to the header of every object it scans and so copies
    every page of the parent's heap (imports, the loaded engine): about 20 MiB more per
    process a few seconds into a sweep.  A process that had frozen objects itself keeps
    them (and these) frozen: ``gc.unfreeze`` cannot release only some.
    """
    frozen_before = gc.get_freeze_count()
    gc.freeze()
    try:
        yield
    finally:
        if frozen_before == 0:
            gc.unfreeze()


def _worker_init(parent_pid: int | None = None) -> None:
    """Workers leave Ctrl-C to the parent (which cancels the pending chunks), use one BLAS
    thread each (small design computations are slower threaded, and the workers are
    already one per core), and exit when the parent dies (even by SIGKILL): the kernel
    signals them where it can (Linux ``PR_SET_PDEATHSIG``), and a watchdog thread checks
    the parent every half second elsewhere."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    limit_blas_threads()
    if parent_pid is None:
        return
    _exit_with_parent(parent_pid)


def _exit_with_parent(parent_pid: int) -> None:
    with contextlib.suppress(Exception):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent_pid:  # the parent died before the request took effect
        os._exit(1)

    def watch() -> None:
        while True:
            if os.getppid() != parent_pid:
                os._exit(1)
            threading.Event().wait(0.5)

    threading.Thread(target=watch, name="acc-parent-watchdog", daemon=True).start()


def preload_engine(scenarios: Iterable[Scenario]) -> None:
    """Compile (or load from the cache) the loops these scenarios need, in this process, so
    that worker processes forked from it start with them loaded."""
    from acc.engine.simulate import simulate

    for sc in scenarios:
        short = sc.with_values({"simulation.time_limit_s": sc.simulation.plant_step_s})
        simulate(short, record_every_steps=None, threads=1)


def _execute_dask(
    campaign: Campaign, todo: list[range], scheduler: str | None
) -> Iterable[ChunkResult]:
    from distributed import Client
    from distributed import as_completed as dask_completed

    try:
        client = Client(scheduler, timeout=f"{DASK_TIMEOUT_S}s")
    except (OSError, ValueError, TypeError) as exc:
        raise SweepError(
            f"cannot reach the Dask scheduler at {scheduler}: {shorten(str(exc))}"
        ) from None
    done = 0
    try:
        shared = client.scatter(campaign, broadcast=True)
        window = 2 * max(1, sum(client.nthreads().values()))
        pending = iter(todo)
        queue = dask_completed([client.submit(simulate_chunk, shared, ids, pure=False)
                                for ids in itertools.islice(pending, window)])
        try:
            for fut in queue:  # bounded in flight; a finished chunk is released at once
                for ids in itertools.islice(pending, 1):
                    queue.add(client.submit(simulate_chunk, shared, ids, pure=False))
                chunk = fut.result()
                fut.release()
                done += 1
                yield chunk
        finally:
            with contextlib.suppress(Exception):
                client.cancel(list(queue.futures))
    except (OSError, TimeoutError, CancelledError) as exc:  # (connection lost: cancelled)
        raise SweepError(
            f"lost the Dask scheduler at {scheduler} after {done} chunk(s) "
            f"({type(exc).__name__}: {shorten(str(exc))}); the finished chunks are kept: "
            "run the sweep again with --resume"
        ) from None
    finally:
        with contextlib.suppress(Exception):
            client.close(timeout=5)


def read_summary(
    path: str | Path, columns: Iterable[str] | None = None
) -> dict[str, np.ndarray]:
    """A summary CSV as columns: numbers as float arrays, the flags (:data:`FLAG_COLUMNS`)
    as bool, text as object arrays of ``str`` (one string per distinct text, shared by its
    cells: 8 bytes a cell, where a ``str_`` array would take 4 bytes per character).  A
    column is numbers if every cell of it reads as one.

    Parameters
    ----------
    path : str or Path
        The summary file.
    columns : iterable of str, optional
        Read only these columns (those of them the file has), in the file's order; default:
        every column.  A report of 1e6 runs reads the few it needs, not the depth lists.

    Returns
    -------
    dict of str to ndarray, each of shape (runs,)
    """
    # never the whole table as Python strings (1e6 runs x 50 columns would take gigabytes):
    # NumPy's compiled CSV reader, the number columns as floats, the rest column by column
    path = Path(path)
    header, numeric, rows = summary_layout(path, columns)
    if not rows:  # (no rows: empty columns; no row says which columns are text)
        return {header[j]: np.zeros(0, dtype=bool) if header[j] in FLAG_COLUMNS
                else np.empty(0) for j in numeric}
    # the columns whose first rows are numbers are read as numbers; if a later cell is not
    # one, NumPy's reader refuses and the table is read again knowing which are
    try:
        return _read_summary_numpy(path, header, numeric)
    except ValueError:
        return _read_summary_blocks(path, header, _numbers_by_column(path, list(numeric)))


def summary_layout(
    path: str | Path, columns: Iterable[str] | None = None
) -> tuple[list[str], dict[int, bool], bool]:
    """A summary file's header, and which of ``columns`` read as numbers in its first
    :data:`SUMMARY_BLOCK_ROWS` rows (flags do not; a later cell may still be text).

    Returns
    -------
    header : list of str
    numeric : dict of int to bool
        Index in ``header`` of each of ``columns`` the file has (default every column), in
        the file's order -> whether its first cells are numbers (False when there are no rows).
    rows : bool
        Whether the file has rows.
    """
    with Path(path).open(newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = next(reader)
        wanted = set(header) if columns is None else set(columns)
        used = [j for j, name in enumerate(header) if name in wanted]
        # the first rows' cells of the used columns only (each row's others freed at once)
        first = [[row[j] for j in used] for row in itertools.islice(reader, SUMMARY_BLOCK_ROWS)]
    cells = list(zip(*first, strict=True)) if first else [() for _ in used]
    numeric = {j: bool(first) and header[j] not in FLAG_COLUMNS and _numbers(cells[i])
               for i, j in enumerate(used)}
    return header, numeric, bool(first)


#: Rows of a summary whose cells decide which columns are tried as numbers, and rows read
#: at a time when the csv module reads a summary.
SUMMARY_BLOCK_ROWS = 8192


def _numbers(cells: Sequence[str]) -> bool:
    """Whether every cell reads as a number (``float``)."""
    try:
        np.array(cells, dtype=float)
    except ValueError:
        return False
    return True


def _read_summary_numpy(
    path: Path, header: list[str], numeric: dict[int, bool]
) -> dict[str, np.ndarray]:
    """NumPy's CSV reader (quoted cells, no comment character): the columns ``numeric``
    maps to True as floats, those it maps to False as text.  Raises ValueError if a cell of
    a numeric column is not a number (or a row has another number of cells)."""
    options: dict[str, Any] = {"delimiter": ",", "quotechar": '"', "comments": None,
                               "skiprows": 1, "ndmin": 2, "encoding": "utf-8"}
    out: dict[str, np.ndarray] = {}
    floats = [j for j, n in numeric.items() if n]
    if floats:
        table = np.loadtxt(path, usecols=floats, dtype=float, **options)
        out.update((header[j], table[:, i]) for i, j in enumerate(floats))
    text = [j for j, n in numeric.items() if not n]
    if text:
        # a code per cell and one string object per distinct text, not a string per cell (a
        # flag column of 1e6 runs: 4 MB of codes, then 1 MB of flags, instead of 60 MB of
        # strings); a text column holds references to the distinct strings
        index: dict[str, int] = {}
        codes = np.loadtxt(path, usecols=text, dtype=np.int32,
                           converters=lambda v: index.setdefault(v, len(index)), **options)
        labels = np.empty(len(index), dtype=object)
        labels[:] = list(index)
        for i, j in enumerate(text):
            col = codes[:, i]
            out[header[j]] = col == index.get("True", -1) if header[j] in FLAG_COLUMNS \
                else labels[col]
        del codes
    return {header[j]: out[header[j]] for j in sorted(numeric)}


def _read_summary_blocks(
    path: Path, header: list[str], numeric: dict[int, bool]
) -> dict[str, np.ndarray]:
    """The columns of ``numeric`` in blocks of rows (the csv module), those it maps to True
    as floats."""
    used = sorted(numeric)
    parts: dict[int, list[np.ndarray]] = {j: [] for j in used}
    distinct: dict[str, str] = {}
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        next(reader)
        while block := list(itertools.islice(reader, SUMMARY_BLOCK_ROWS)):
            cells = list(zip(*block, strict=True))
            del block
            for j in used:
                if numeric[j]:
                    parts[j].append(np.array(cells[j], dtype=float))
                else:
                    text = np.empty(len(cells[j]), dtype=object)
                    text[:] = [distinct.setdefault(v, v) for v in cells[j]]
                    parts[j].append(text)
    out: dict[str, np.ndarray] = {}
    for j in used:
        col = np.concatenate(parts.pop(j))  # each column's blocks freed once it is whole
        out[header[j]] = col == "True" if header[j] in FLAG_COLUMNS else col
    return out


def _numbers_by_column(path: Path, used: Sequence[int]) -> dict[int, bool]:
    """Which of the columns ``used`` (indices) have only cells that read as numbers (flags:
    no)."""
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = next(reader)
        numeric = {j: header[j] not in FLAG_COLUMNS for j in used}
        while block := list(itertools.islice(reader, SUMMARY_BLOCK_ROWS)):
            cells = list(zip(*block, strict=True))
            for j in used:
                numeric[j] = numeric[j] and _numbers(cells[j])
    return numeric


def read_traces(out_dir: str | Path) -> dict[str, np.ndarray] | None:
    """Traces of every chunk, stacked by run and NaN-padded to the longest: ``time_s`` (n,),
    ``run_ids`` (runs,), ``force_N`` and ``override`` (runs, n); None if none were recorded."""
    files = [p.with_suffix(".npz") for _, _, p in finished_runs(Path(out_dir) / "chunks")]
    files = [f for f in files if f.exists()]
    if not files:
        return None
    return _stack_traces([dict(np.load(f)) for f in files])


__all__ = [
    "BACKENDS",
    "ChunkResult",
    "SEGMENT_RE",
    "SweepError",
    "SweepOutcome",
    "assemble_summary",
    "check_execution",
    "check_scheduler_address",
    "column_order",
    "failed_row",
    "format_value",
    "plan_chunks",
    "read_summary",
    "read_traces",
    "result_rows",
    "result_table",
    "run_sweep",
    "simulate_chunk",
    "summary_columns",
    "summary_layout",
    "sweep_lock",
]
