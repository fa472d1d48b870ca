"""Batch plumbing shared by the axis, XY and contouring engines.

A parameter given once applies to every run, a sequence gives one value per run
(:func:`per_run`, :func:`runs_of`); the compiled ``run_runs`` loops share the runs out
over threads (:func:`run_on_threads`; the compiled loops release the GIL).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np


def per_run(value: Any, kind: type | tuple[type, ...], runs: int, what: str) -> list[Any]:
    """One value per run: ``value`` repeated ``runs`` times, or the sequence itself.

    Parameters
    ----------
    value : kind or sequence of kind
        One parameter set for every run, or one per run.
    kind : type or tuple of type
        The accepted parameter classes.
    runs : int
        Number of runs.
    what : str
        The parameter's name in the error messages.

    Returns
    -------
    list, length runs

    Raises
    ------
    ValueError
        A sequence of another length, or an item of another kind.
    """
    if isinstance(value, kind):
        return [value] * runs
    items = list(value)
    if len(items) != runs:
        raise ValueError(f"{what}: expected {runs} values, got {len(items)}")
    for item in items:
        if not isinstance(item, kind):
            raise ValueError(f"{what}: unsupported kind {type(item).__name__}")
    return items


def runs_of(*values: Any) -> int:
    """Number of runs the per-run sequences (lists, tuples) among ``values`` ask for (1 when
    none); a ValueError when they disagree."""
    sizes = {len(v) for v in values if isinstance(v, (list, tuple))}
    if len(sizes) > 1:
        raise ValueError(f"per-run sequences must have one length, got {sorted(sizes)}")
    return sizes.pop() if sizes else 1


def run_on_threads(
    run_runs: Callable[..., Any], runs: int, threads: int | None, args: tuple[Any, ...]
) -> None:
    """Call ``run_runs(share, *args)`` for the runs split round-robin over threads.

    Parameters
    ----------
    run_runs : callable
        A compiled loop taking the run indices (int64 array) first.
    runs : int
        Number of runs.
    threads : int or None
        Threads to use (None: one per CPU); at most one per run.
    args : tuple
        The loop's remaining arguments (output arrays written in place per run).
    """
    n_threads = (os.cpu_count() or 1) if threads is None else int(threads)
    if n_threads < 1:
        raise ValueError(f"threads must be >= 1, got {n_threads}")
    shares = [np.arange(t, runs, n_threads, dtype=np.int64)
              for t in range(min(n_threads, runs))]
    if len(shares) == 1:
        run_runs(shares[0], *args)
    else:
        with ThreadPoolExecutor(max_workers=len(shares)) as pool:
            list(pool.map(lambda share: run_runs(share, *args), shares))


__all__ = ["per_run", "run_on_threads", "runs_of"]
