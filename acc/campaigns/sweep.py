"""Running a campaign: chunks of runs on local processes or a Dask cluster, resumable.

Layout of a sweep directory ``DIR``::

    DIR/campaign.json                 the resolved campaign and its fingerprint
    DIR/chunks/runs_00000000-00000063.csv   one file per finished chunk (its runs' rows)
    DIR/chunks/runs_00000000-00000063.npz   decimated traces of the chunk, when recorded
    DIR/summary.csv                   every run's parameters and metrics, sorted by run

Every file is written to a temporary name and renamed, so a file that exists is complete.
A chunk's CSV is its completion mark: ``resume`` simulates only the runs that no chunk file
holds.  The summary is assembled from the chunk files once every run is done; a run's row
depends only on the campaign, the root seed and the run number, so the summary is the same
byte for byte whatever the chunk size, the number of workers, the backend, or how often
the sweep was interrupted and resumed.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
import signal
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from acc.campaigns.campaign import Campaign, CampaignError
from acc.engine.result import SimulationResult
from acc.engine.simulate import engine_key
from acc.engine.threads import limit_blas_threads
from acc.scenario import Scenario

BACKENDS = ("local", "dask")

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
)
#: Metrics shown first, in this order; the rest follow (per-segment ones last).
_PREFERRED_METRICS = (
    "failed",
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
_SEGMENT_RE = re.compile(r"^(.*)_seg(\d+)$")
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
    rows : tuple of dict of str to str
        One row per run, values already formatted (exact ``repr`` of floats).
    traces : dict of str to ndarray or None
        ``time_s`` (n,), ``run_ids`` (runs,), ``force_N`` and ``override`` (runs, n), when the
        campaign records traces.
    """

    run_ids: tuple[int, ...]
    rows: tuple[dict[str, str], ...]
    traces: dict[str, np.ndarray] | None


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
        seg = _SEGMENT_RE.match(name)
        if seg:
            return (5, int(seg.group(2)), seg.group(1))
        return (4, 0, name)

    return sorted(set(columns), key=rank)


def result_rows(
    campaign: Campaign,
    result: SimulationResult,
    swept: dict[int, dict[str, Any]] | None = None,
) -> tuple[dict[str, str], ...]:
    """Formatted summary rows of a chunk's result: run, swept values, then metrics.

    ``swept`` maps run -> its swept values when the caller has them (else drawn again).
    """
    rows = []
    order: list[str] | None = None
    for row in result.summary_rows():
        run = int(row["run"])
        values = swept[run] if swept is not None else campaign.values(run)
        full = {"run": str(run), **{k: format_value(v) for k, v in values.items()}}
        full.update({k: format_value(v) for k, v in row.items() if k != "run"})
        if order is None or len(order) != len(full) or any(k not in full for k in order):
            order = column_order(full, campaign.swept_keys)
        rows.append({k: full[k] for k in order})
    return tuple(rows)


def simulate_chunk(campaign: Campaign, run_ids: Sequence[int]) -> ChunkResult:
    """Simulate one chunk of a campaign (what a worker process runs).

    Parameters
    ----------
    campaign : Campaign
    run_ids : sequence of int, shape (runs,)
        Ascending run numbers.

    Returns
    -------
    ChunkResult
    """
    ids = [int(r) for r in run_ids]
    swept = {r: campaign.values(r) for r in ids}
    scenarios = [campaign.scenario(r, swept[r]) for r in ids]
    from acc.engine.simulate import simulate

    groups: dict[tuple, list[int]] = {}
    for j, sc in enumerate(scenarios):
        groups.setdefault(engine_key(sc), []).append(j)
    rows: list[dict[str, str]] = []
    parts = []
    for members in groups.values():
        result = simulate(
            [scenarios[j] for j in members],
            run_ids=[ids[j] for j in members],
            record_every_steps=campaign.record_every_steps,
            threads=1,  # the chunks are what runs in parallel
        )
        rows += result_rows(campaign, result, swept)
        parts.append(result)
    rows.sort(key=lambda row: int(row["run"]))
    traces = None
    if campaign.record_every_steps is not None:
        traces = _stack_traces(
            [
                {
                    "time_s": np.asarray(r.time_s),
                    "run_ids": np.asarray(r.run_ids),
                    "force_N": np.asarray(r.signals["force_N"]),
                    "override": np.asarray(r.signals["override"]),
                }
                for r in parts
            ]
        )
    return ChunkResult(tuple(ids), tuple(rows), traces)


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


def plan_chunks(runs: int, done: Iterable[tuple[int, int]], chunk_runs: int) -> list[list[int]]:
    """Split the runs no finished chunk holds into contiguous chunks of at most ``chunk_runs``."""
    todo = np.ones(runs, dtype=bool)
    for first, last in done:
        todo[first : last + 1] = False
    chunks: list[list[int]] = []
    ids = np.flatnonzero(todo)
    if len(ids) == 0:
        return chunks
    breaks = np.flatnonzero(np.diff(ids) != 1) + 1
    for block in np.split(ids, breaks):
        for start in range(0, len(block), chunk_runs):
            chunks.append([int(r) for r in block[start : start + chunk_runs]])
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
    columns = list(chunk.rows[0])
    path = chunk_dir / f"{stem}.csv"
    tmp = chunk_dir / f".{stem}.csv.tmp"
    with tmp.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(chunk.rows)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    return path


def assemble_summary(out_dir: Path, campaign: Campaign) -> tuple[Path, int]:
    """Concatenate the chunk files into ``summary.csv`` (atomically), rows sorted by run.

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
            with path.open(newline="", encoding="utf-8") as fh:
                for row in csv.DictReader(fh):
                    failed += row.get("failed") == "True"
                    writer.writerow(row)
    os.replace(tmp, summary)
    return summary, failed


def _prepare(out_dir: Path, campaign: Campaign, resume: bool) -> None:
    chunk_dir = out_dir / "chunks"
    meta_path = out_dir / "campaign.json"
    meta = {"fingerprint": campaign.fingerprint(), "source": campaign.source}
    if resume:
        if not meta_path.exists():
            raise SweepError(f"{out_dir}: nothing to resume (no campaign.json)")
        old = json.loads(meta_path.read_text(encoding="utf-8"))
        if old.get("fingerprint") != meta["fingerprint"]:
            raise SweepError(
                f"{out_dir}: holds a different campaign (the file, its base scenario or its "
                "seed changed); sweep into a new directory"
            )
        for stale in chunk_dir.glob(".*.tmp"):
            stale.unlink()
        return
    if finished_runs(chunk_dir) or (out_dir / "summary.csv").exists():
        raise SweepError(f"{out_dir}: already holds a sweep; pass --resume or choose a new --out")
    chunk_dir.mkdir(parents=True, exist_ok=True)
    for stale in chunk_dir.glob(".*.tmp"):
        stale.unlink()
    _atomic_write_text(
        meta_path, json.dumps({**meta, "campaign": campaign.to_dict()}, indent=1, default=str)
    )


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
        Continue a sweep in ``out_dir``: only runs no chunk file holds are simulated.
    progress : bool
        Report progress (runs): a bar on a terminal, else plain periodic lines on the ``acc``
        logger (:mod:`acc.campaigns.progress`).
    validate : bool
        Build every run's scenario before the first run (a bad sampled value fails at once).

    Returns
    -------
    SweepOutcome
    """
    if backend not in BACKENDS:
        raise SweepError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "dask" and not scheduler:
        raise SweepError("backend 'dask' needs a scheduler address (--scheduler)")
    size = campaign.chunk_runs if chunk_runs is None else chunk_runs
    if size < 1:
        raise SweepError(f"chunk size must be >= 1, got {size}")
    out = Path(out_dir)
    samples: dict[tuple, Scenario] = {}
    if validate:

        def note(scenario: Scenario) -> None:
            samples.setdefault(engine_key(scenario), scenario)

        campaign.validate(note)
    out.mkdir(parents=True, exist_ok=True)
    _prepare(out, campaign, resume)
    chunk_dir = out / "chunks"
    done = [(a, b) for a, b, _ in finished_runs(chunk_dir)]
    todo = plan_chunks(campaign.runs, done, size)
    remaining = sum(len(c) for c in todo)

    from acc.campaigns.progress import Progress

    bar = Progress(campaign.runs, campaign.runs - remaining, campaign.name, enabled=progress)
    try:
        if todo and backend == "local":
            preload_engine(samples.values() or [campaign.scenario(todo[0][0])])
        for chunk in _execute(campaign, todo, backend, workers, scheduler):
            write_chunk(chunk_dir, chunk)
            bar.update(len(chunk.run_ids))
    finally:
        bar.close()
    summary, failed = assemble_summary(out, campaign)
    return SweepOutcome(summary, campaign.runs, remaining, failed)


def _execute(
    campaign: Campaign,
    todo: list[list[int]],
    backend: str,
    workers: int | None,
    scheduler: str | None,
) -> Iterable[ChunkResult]:
    """Yield chunk results as they finish."""
    if not todo:
        return
    if backend == "dask":
        yield from _execute_dask(campaign, todo, scheduler)
        return
    n = (os.cpu_count() or 1) if workers is None else workers
    if n < 1:
        raise SweepError(f"workers must be >= 1, got {n}")
    if n == 1 or len(todo) == 1:
        for ids in todo:
            yield simulate_chunk(campaign, ids)
        return
    with ProcessPoolExecutor(max_workers=min(n, len(todo)), initializer=_worker_init) as pool:
        futures = [pool.submit(simulate_chunk, campaign, ids) for ids in todo]
        try:
            for fut in as_completed(futures):
                yield fut.result()
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise


def _worker_init() -> None:
    """Workers leave Ctrl-C to the parent (which cancels the pending chunks) and use one BLAS
    thread each (small design computations are slower threaded, and the workers are
    already one per core)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    limit_blas_threads()


def preload_engine(scenarios: Iterable[Scenario]) -> None:
    """Compile (or load from the cache) the loops these scenarios need, in this process, so
    that worker processes forked from it start with them loaded."""
    from acc.engine.simulate import simulate

    for sc in scenarios:
        short = sc.with_values({"simulation.time_limit_s": sc.simulation.plant_step_s})
        simulate(short, record_every_steps=None, threads=1)


def _execute_dask(
    campaign: Campaign, todo: list[list[int]], scheduler: str | None
) -> Iterable[ChunkResult]:
    from distributed import Client
    from distributed import as_completed as dask_completed

    try:
        client = Client(scheduler, timeout="20s")
    except OSError as exc:
        raise SweepError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
    try:
        shared = client.scatter(campaign, broadcast=True)
        futures = [client.submit(simulate_chunk, shared, ids, pure=False) for ids in todo]
        try:
            for fut in dask_completed(futures):
                yield fut.result()
        finally:
            client.cancel(futures)
    finally:
        client.close()


def read_summary(path: str | Path) -> dict[str, np.ndarray]:
    """A summary CSV as columns: numbers as float arrays, ``failed`` as bool, text as str.

    Returns
    -------
    dict of str to ndarray, each of shape (runs,)
    """
    with Path(path).open(newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = next(reader)
        cells = list(reader)
    out: dict[str, np.ndarray] = {}
    for j, name in enumerate(header):
        col = [row[j] for row in cells]
        if name == "failed":
            out[name] = np.array([c == "True" for c in col], dtype=bool)
            continue
        try:
            out[name] = np.array([float(c) for c in col], dtype=float)
        except ValueError:
            out[name] = np.array(col, dtype=str)
    return out


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
    "SweepError",
    "SweepOutcome",
    "assemble_summary",
    "column_order",
    "format_value",
    "plan_chunks",
    "read_summary",
    "read_traces",
    "result_rows",
    "run_sweep",
    "simulate_chunk",
]
