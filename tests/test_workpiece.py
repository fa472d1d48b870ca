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


def test_batch_rows_are_the_parts_padded_to_the_longest():
    """Each row of a batch, against numpy written here: the segment starts are the running
    sum of the lengths before each segment (``np.cumsum``'s order, to the bit), padded with
    the part's length; the depths are padded with zeros, with one more zero column (the tool
    has left the part)."""
    rng = np.random.default_rng(7)
    parts = []
    for m in (1, 5, 3, 5, 2):
        parts.append(Workpiece(
            segment_length_mm=tuple(rng.uniform(0.1, 50.0, m)),
            radial_depth_mm=tuple(rng.uniform(0.5, 4.0, m)),
            axial_depth_mm=tuple(rng.uniform(1.0, 15.0, m)),
        ))
    batch = WorkpieceBatch(parts)
    assert batch.segments == 5
    assert batch.segment_start_mm.shape == (5, 5)
    assert batch.radial_depth_mm.shape == batch.axial_depth_mm.shape == (5, 6)
    for i, part in enumerate(parts):
        m = len(part.segment_length_mm)
        lengths = np.array(part.segment_length_mm)
        want = np.concatenate([[0.0], np.cumsum(lengths)[:-1], np.full(5 - m, part.length_mm)])
        np.testing.assert_array_equal(batch.segment_start_mm[i], want)
        np.testing.assert_array_equal(part.segment_start_mm, want[:m])
        np.testing.assert_array_equal(
            batch.radial_depth_mm[i], np.concatenate([part.radial_depth_mm, np.zeros(6 - m)]))
        np.testing.assert_array_equal(
            batch.axial_depth_mm[i], np.concatenate([part.axial_depth_mm, np.zeros(6 - m)]))
        assert batch.length_mm[i] == part.length_mm
