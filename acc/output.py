"""Writing results to a directory: summary CSV, manifest JSON, traces, figure."""

from __future__ import annotations

import csv
import json
import platform
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from acc.engine.result import SimulationResult

_PACKAGES = ("acc", "numpy", "scipy", "control", "matplotlib", "filterpy", "casadi")


def package_versions() -> dict[str, str]:
    """Versions of Python and the packages results depend on."""
    out = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """Write dict rows to CSV, columns in first-seen order; atomically (temp file + rename)."""
    columns: list[str] = []
    for row in rows:
        columns += [c for c in row if c not in columns]
    tmp = path.with_suffix(path.suffix + ".tmp")
    with tmp.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    tmp.replace(path)


def write_manifest(
    path: Path, result: SimulationResult, extra: dict[str, Any] | None = None
) -> None:
    """Scenarios as resolved, seeds, run ids and package versions, as JSON."""
    manifest = {
        "scenarios": [sc.to_dict() for sc in result.scenarios],
        "sources": [sc.source for sc in result.scenarios],
        "seeds": [sc.simulation.seed for sc in result.scenarios],
        "run_ids": [int(r) for r in result.run_ids],
        "derived": {k: [float(x) for x in v] for k, v in result.parameters.items()},
        "versions": package_versions(),
    }
    if extra:
        manifest.update(extra)
    path.write_text(json.dumps(manifest, indent=2, allow_nan=True), encoding="utf-8")


def write_traces(directory: Path, result: SimulationResult, every: int = 1) -> None:
    """``traces.npz`` (all signals, shape (runs, n)) and ``traces.csv`` (long format).

    Parameters
    ----------
    directory : Path
    result : SimulationResult
    every : int
        Keep every this many recorded samples in the CSV (the NPZ keeps all).
    """
    np.savez_compressed(
        directory / "traces.npz", time_s=result.time_s, run_ids=result.run_ids, **result.signals
    )
    names = list(result.signals)
    idx = np.arange(0, len(result.time_s), every)
    tmp = directory / "traces.csv.tmp"
    with tmp.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["run", "time_s", *names])
        for i in range(result.runs):
            block = np.column_stack(
                [result.time_s[idx]] + [result.signals[n][i, idx] for n in names]
            )
            run_id = int(result.run_ids[i])
            writer.writerows([run_id, *(f"{x:.10g}" for x in row)] for row in block)
    tmp.replace(directory / "traces.csv")


__all__ = ["package_versions", "write_csv", "write_manifest", "write_traces"]
