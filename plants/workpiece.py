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

import numpy as np
from numpy.typing import NDArray


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
        return np.concatenate(([0.0], np.cumsum(self.segment_length_mm)[:-1]))


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
        starts = np.empty((runs, nseg))
        radial = np.zeros((runs, nseg + 1))
        axial = np.zeros((runs, nseg + 1))
        for i, p in enumerate(parts):
            m = len(p.segment_length_mm)
            starts[i, :m] = p.segment_start_mm
            starts[i, m:] = p.length_mm
            radial[i, :m] = p.radial_depth_mm
            axial[i, :m] = p.axial_depth_mm
        self.segment_start_mm = starts
        #: radial depth per segment, with the trailing "left the part" column [mm]
        self.radial_depth_mm = radial
        #: axial depth per segment, with the trailing "left the part" column [mm]
        self.axial_depth_mm = axial

    def segment(self, position_mm: NDArray[np.float64]) -> NDArray[np.intp]:
        """Segment index of each run at a tool position, shape (runs,).

        Parameters
        ----------
        position_mm : ndarray, shape (runs,)
            Tool position along the path [mm], >= 0.
        """
        inside = np.count_nonzero(position_mm[:, None] >= self.segment_start_mm, axis=1) - 1
        inside = np.maximum(inside, 0)
        return np.where(position_mm >= self.length_mm, self.segments, inside)


__all__ = ["Workpiece", "WorkpieceBatch"]
