"""Workpiece: depth of cut as a piecewise-constant function of tool position along the path.

The part is a sequence of segments along the feed direction, each with a length [mm], a
radial depth [mm] and an axial depth [mm].  A radial depth of 0 is an air cut.  The tool
starts at position 0; the part is finished when the position reaches the total length.
Past the end the tool is in air.  Because the depth follows the position, the depth the tool
meets at a given time depends on how fast it has fed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import accumulate

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import init_states, jit, record, register_element, ring_size


def segment_size(segments: int) -> int:
    """Capacity of per-segment record fields for ``segments`` segments plus the trailing
    "left the part" one (a power of two: similar parts share a compiled specialisation)."""
    return ring_size(segments + 1)


@dataclass(frozen=True)
class Workpiece:
    """A stepped part.

    Attributes
    ----------
    segment_length_mm : tuple of float, shape (segments,)
        Length of each segment along the path [mm], > 0.
    radial_depth_mm : tuple of float, shape (segments,)
        Radial depth of cut in each segment [mm], >= 0 (0 = air).
    axial_depth_mm : tuple of float, shape (segments,)
        Axial depth of cut in each segment [mm], >= 0.
    """

    segment_length_mm: tuple[float, ...] = (20.0, 20.0, 20.0)
    radial_depth_mm: tuple[float, ...] = (2.0, 3.0, 4.0)
    axial_depth_mm: tuple[float, ...] = (10.0, 10.0, 10.0)

    def __post_init__(self) -> None:
        n = len(self.segment_length_mm)
        if n == 0:
            raise ValueError("segment_length_mm: the part needs at least one segment")
        if len(self.radial_depth_mm) != n or len(self.axial_depth_mm) != n:
            raise ValueError(
                "segment_length_mm, radial_depth_mm and axial_depth_mm must have the same "
                f"length (got {n}, {len(self.radial_depth_mm)}, {len(self.axial_depth_mm)})"
            )
        if any(not length > 0 for length in self.segment_length_mm):
            raise ValueError("segment_length_mm: every segment must be > 0 mm long")
        if any(not d >= 0 for d in self.radial_depth_mm):
            raise ValueError("radial_depth_mm: depths must be >= 0 mm")
        if any(not d >= 0 for d in self.axial_depth_mm):
            raise ValueError("axial_depth_mm: depths must be >= 0 mm")
        if all(d == 0 for d in self.radial_depth_mm):
            raise ValueError("radial_depth_mm: the part has no cutting segment")

    @property
    def length_mm(self) -> float:
        """Total path length [mm]."""
        return float(sum(self.segment_length_mm))

    @property
    def segment_start_mm(self) -> NDArray[np.float64]:
        """Start position of each segment [mm], shape (segments,)."""
        return np.array(self._starts_mm())

    def _starts_mm(self) -> list[float]:
        """:attr:`segment_start_mm` as a list (the running sum in order, as ``np.cumsum``)."""
        return [0.0, *accumulate(self.segment_length_mm[:-1])]


class WorkpieceBatch:
    """Segment look-up for a batch of parts with a leading run axis.

    Parts with fewer segments are padded with zero-length segments at the end.  Segment
    index ``segments`` (one past the last) means the tool has left the part.

    Parameters
    ----------
    parts : sequence of Workpiece, length runs
    """

    def __init__(self, parts: Sequence[Workpiece]) -> None:
        runs = len(parts)
        nseg = max(len(p.segment_length_mm) for p in parts)
        self.segments = nseg
        self.length_mm = np.array([p.length_mm for p in parts])
        # the rows' values in flat lists, each array made once (about 1 us a run; no list
        # kept per run, which would bring the garbage collector round every few chunks)
        starts: list[float] = []
        radial: list[float] = []
        axial: list[float] = []
        for p in parts:
            pad = nseg - len(p.segment_length_mm)
            starts += p._starts_mm()
            starts += [p.length_mm] * pad
            radial += p.radial_depth_mm
            radial += [0.0] * (pad + 1)
            axial += p.axial_depth_mm
            axial += [0.0] * (pad + 1)
        self.segment_start_mm = np.array(starts, dtype=float).reshape(runs, nseg)
        #: radial depth per segment, with the trailing "left the part" column [mm]
        self.radial_depth_mm = np.array(radial, dtype=float).reshape(runs, nseg + 1)
        #: axial depth per segment, with the trailing "left the part" column [mm]
        self.axial_depth_mm = np.array(axial, dtype=float).reshape(runs, nseg + 1)

    def records(self) -> tuple[NDArray, NDArray]:
        """Params and (empty) state of the compiled segment look-up, shape (runs,)."""
        runs, nseg = self.segment_start_mm.shape
        params, state = STEPPED.records(runs, segments=segment_size(nseg))
        params["segment_start_mm"][:, :nseg] = self.segment_start_mm
        params["segment_start_mm"][:, nseg:] = np.inf
        params["axial_depth_mm"][:, : nseg + 1] = self.axial_depth_mm
        params["segments"] = nseg
        params["length_mm"] = self.length_mm
        return params, init_states(params, state)


def _dtypes(segments: int = 8) -> tuple[np.dtype, np.dtype]:
    params = record(
        "workpiece.stepped",
        [
            ("segment_start_mm", "f8", (segments,)),
            ("axial_depth_mm", "f8", (segments,)),  # the trailing "left the part" one is 0
            ("segments", "i8"),
            ("length_mm", "f8"),
        ],
    )
    return params, record("workpiece.stepped", [])


@jit
def init(p, s) -> None:  # noqa: ANN001
    """No state."""


@jit
def output(p, s, position_mm: float) -> int:  # noqa: ANN001
    """Segment index at a tool position [mm]; ``segments`` once the part is finished."""
    if position_mm >= p.length_mm:
        return p.segments
    # the last segment starting at or before the position (the starts ascend; 0 before the
    # first and for NaN); a scan with branches, not a count of comparisons: the branches are
    # predicted (the tool stays in a segment for thousands of steps), so what the loop reads
    # by segment does not wait for this step's position
    j = 0
    while j + 1 < p.segments and position_mm >= p.segment_start_mm[j + 1]:
        j += 1
    return j


@jit
def step(p, s, position_mm: float) -> int:  # noqa: ANN001
    """Same as :func:`output` (the part has no state)."""
    return output(p, s, position_mm)


STEPPED = register_element(
    "workpiece.stepped",
    _dtypes,
    init,
    step,
    "stepped part: depth piecewise constant along the path",
    output,
)


__all__ = ["STEPPED", "Workpiece", "WorkpieceBatch", "segment_size"]
