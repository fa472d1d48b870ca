"""The stepped part's segment look-up (the ``workpiece.stepped`` element's ``output``)."""

from __future__ import annotations

import numpy as np

from plants.workpiece import Workpiece, WorkpieceBatch, output


def test_segment_is_the_last_start_at_or_before_the_position():
    """Against the definition written here: the number of segment starts at or before the
    position, less one (0 before the first and for NaN), and ``segments`` from the end of
    the part on; on the starts themselves, the padded parts of a batch, and random points."""
    parts = [
        Workpiece(segment_length_mm=(10.0, 0.5, 5.0, 20.0), radial_depth_mm=(2.0, 3.0, 4.0, 2.0),
                  axial_depth_mm=(10.0, 10.0, 10.0, 10.0)),
        Workpiece(),  # three segments: padded to four in the batch
        Workpiece(segment_length_mm=(7.0,), radial_depth_mm=(3.0,), axial_depth_mm=(10.0,)),
    ]
    batch = WorkpieceBatch(parts)
    params, state = batch.records()
    rng = np.random.default_rng(1)
    for i, part in enumerate(parts):
        starts = part.segment_start_mm
        points = np.concatenate([starts, np.nextafter(starts, -np.inf), [part.length_mm],
                                 [np.nextafter(part.length_mm, -np.inf), -1.0, np.nan],
                                 rng.uniform(-2.0, part.length_mm + 2.0, 200)])
        for x in points:
            if x >= part.length_mm:
                want = batch.segments
            else:
                want = max(int(np.sum(starts <= x)) - 1, 0)
            assert output(params[i], state[i], float(x)) == want, (i, x)
