"""A large summary file's columns, read when used: what lets the report of a sweep of 1e6
runs hold a column or two of numbers instead of all of them.

:func:`summary_for_report` picks: a summary file under :data:`LAZY_SUMMARY_BYTES` is read
whole (:func:`acc.campaigns.sweep.read_summary`, one pass over the file); a larger one is a
:class:`SummaryColumns`, which reads its text and flag columns together on first use and
keeps them (a byte or a shared string reference a run), and its number columns one at a
time (8 bytes a run each), reading one again when it is asked for again.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

import numpy as np

from acc.campaigns import sweep

#: Summary files larger than this [bytes] are read a column at a time by the sweep's report
#: (about 1.5e5 runs of a force-loop campaign with three-segment depth lists).
LAZY_SUMMARY_BYTES = 64 * 2**20


class SummaryColumns(Mapping[str, np.ndarray]):
    """The columns of a summary CSV, each read from the file when first used.

    Same values and types as :func:`acc.campaigns.sweep.read_summary`.  Text and flag
    columns are read in one pass, together, and kept; of the number columns only the last
    ``numbers_kept`` used are kept.

    Parameters
    ----------
    path : str or Path
    columns : iterable of str, optional
        The columns to offer (those of them the file has); default every column.
    numbers_kept : int
        Number columns held at once.
    """

    def __init__(
        self, path: str | Path, columns: Iterable[str] | None = None, numbers_kept: int = 1
    ) -> None:
        self.path = Path(path)
        header, numeric, _ = sweep.summary_layout(self.path, columns)
        self._names = [header[j] for j in numeric]
        #: Whether each column reads as numbers in its first rows (as read_summary decides).
        self._numbers = {header[j]: n for j, n in numeric.items()}
        self._kept = max(1, numbers_kept)
        self._text: dict[str, np.ndarray] | None = None
        self._recent: dict[str, np.ndarray] = {}
        #: Passes over the file so far (a test and a benchmark count them).
        self.reads = 0

    def number_column(self, name: str) -> bool:
        """Whether column ``name`` holds numbers, without reading it (its first rows
        decide, as in :func:`acc.campaigns.sweep.read_summary`)."""
        if name not in self._numbers:
            raise KeyError(name)
        return self._numbers[name]

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._numbers:
            raise KeyError(name)
        if not self._numbers[name]:
            if self._text is None or name not in self._text:
                self.reads += 1
                self._text = {**(self._text or {}), **sweep.read_summary(
                    self.path, [n for n in self._names if not self._numbers[n]]
                )}
            return self._text[name]
        if name in self._recent:
            self._recent[name] = self._recent.pop(name)  # the most recent last
            return self._recent[name]
        while len(self._recent) >= self._kept:
            del self._recent[next(iter(self._recent))]  # (freed before the next is read)
        self.reads += 1
        column = sweep.read_summary(self.path, [name])[name]
        if column.dtype.kind != "f":  # a later cell is not a number: text, kept with it
            self._numbers[name] = False
            self._text = {**(self._text or {}), name: column}
            return column
        self._recent[name] = column
        return column

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name: object) -> bool:
        return name in self._numbers


def summary_for_report(
    path: str | Path, columns: Iterable[str], lazy_bytes: int | None = None
) -> Mapping[str, np.ndarray]:
    """The summary columns a report reads: a dict of every column for a file of at most
    ``lazy_bytes`` bytes (default :data:`LAZY_SUMMARY_BYTES`), a :class:`SummaryColumns`
    for a larger one."""
    limit = LAZY_SUMMARY_BYTES if lazy_bytes is None else lazy_bytes
    size = Path(path).stat().st_size
    if size <= limit:
        return sweep.read_summary(path, columns)
    logging.getLogger("acc").info(
        "report: the summary (%.0f MB) is read a column at a time, about %.0f s a column",
        size / 1e6, size / 4e8)
    return SummaryColumns(path, columns)


__all__ = ["LAZY_SUMMARY_BYTES", "SummaryColumns", "summary_for_report"]
