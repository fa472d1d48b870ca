"""Timing and the Markdown report shared by the axis and XY benchmarks."""

from __future__ import annotations

import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numba
import numpy as np


def median_time(fn: Callable[[], object], repeats: int = 3) -> float:
    """Median wall time of ``repeats`` calls of ``fn`` after one warm-up call [s]."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def tree_memory_bytes(pid: int) -> tuple[int, int, int]:
    """Memory of a process and its descendants [bytes]: the process's resident memory (RSS),
    the RSS summed over the tree, and the proportional set size summed over it (PSS: pages
    the forked workers share with the parent counted once); zeros once it has ended."""
    import psutil

    try:
        proc = psutil.Process(pid)
        procs = [proc, *proc.children(recursive=True)]
        parent = proc.memory_info().rss
    except psutil.NoSuchProcess:
        return 0, 0, 0
    rss = pss = 0
    for p in procs:
        try:
            info = p.memory_full_info()
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        rss += info.rss
        pss += getattr(info, "pss", info.rss)
    return parent, rss, pss


def wait_sampling_memory(proc: Any, every_s: float = 0.2) -> tuple[int, int]:
    """Wait for a :class:`subprocess.Popen` to end, sampling its process tree's memory every
    ``every_s`` seconds; return the peaks of the RSS summed over the tree and of the PSS
    [bytes] (:func:`tree_memory_bytes`).  Its output pipes, if any, are drained meanwhile."""
    import threading

    peak = [0, 0]
    stop = threading.Event()

    def sample() -> None:
        while not stop.wait(every_s):
            _, rss, pss = tree_memory_bytes(proc.pid)
            peak[0] = max(peak[0], rss)
            peak[1] = max(peak[1], pss)

    sampler = threading.Thread(target=sample)
    sampler.start()
    try:
        proc.communicate()
    finally:
        stop.set()
        sampler.join()
    return peak[0], peak[1]


def write_report(results: dict[str, float], command: str, write: Path | None) -> str:
    """The figures as a Markdown table with the machine and the command; printed, and
    written to ``write`` when given.

    Parameters
    ----------
    results : dict of str to float
        Quantity (with its unit) -> value.
    command : str
        The command that measured them, without ``--write``.
    write : Path or None
        Markdown file to write as well.

    Returns
    -------
    str
        The report.
    """
    lines = ["| quantity | value |", "|---|---|"]
    lines += [f"| {k} | {v:.4g} |" for k, v in results.items()]
    lines += [
        "",
        f"Machine: {numba.config.NUMBA_NUM_THREADS} threads, {platform.machine()}, Python "
        f"{platform.python_version()}, NumPy {np.__version__}, numba {numba.__version__}.",
        f"Command: `{command}" + (f" --write {write}`" if write else "`"),
    ]
    text = "\n".join(lines)
    print(text)
    if write:
        write.write_text(text + "\n", encoding="utf-8")
    return text


__all__ = ["median_time", "write_report"]
