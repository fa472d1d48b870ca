"""The compiled normal streams against NumPy's Philox and ``Generator.standard_normal``.

:mod:`acc.engine.rng` claims its words equal ``numpy.random.Philox`` keyed by ``(seed,
noise_id)`` and counted from ``(0, stream, 0, 0)``, and its normals equal
``Generator(Philox(...)).standard_normal`` (NumPy's 256-layer ziggurat) drawn from the same
words, including the rare draws outside a layer's rectangle (the wedges and the tail beyond
r = 3.654), which take the out-of-line path: to the last bits of the layer widths (computed
here in double precision; NumPy's are printed constants), with every draw accepted or
rejected alike (one draw out of step would differ by O(1) from there on).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from acc.engine.rng import _ZIG_R, NORMAL_STREAM, next_word, normals, seed_stream


def _numpy_philox(seed: int, noise_id: int, stream: int) -> np.random.Philox:
    return np.random.Philox(key=np.array([seed, noise_id], dtype=np.uint64),
                            counter=np.array([0, stream, 0, 0], dtype=np.uint64))


@numba.njit
def _words(streams: np.ndarray, n: int) -> np.ndarray:
    out = np.empty(n, dtype=np.uint64)
    for i in range(n):
        out[i] = next_word(streams[0])
    return out


@pytest.mark.parametrize(("seed", "noise_id", "stream"),
                         [(0, 0, 0), (2001, 17, 1), (2**63 - 1, 2**62 + 5, 3)])
def test_words_equal_numpy_philox(seed: int, noise_id: int, stream: int) -> None:
    st = np.zeros(1, dtype=NORMAL_STREAM)
    seed_stream(st[0], seed, noise_id, stream)
    ours = _words(st, 4001)  # not a whole number of four-word blocks
    theirs = _numpy_philox(seed, noise_id, stream).random_raw(4001)
    np.testing.assert_array_equal(ours, theirs)


@pytest.mark.parametrize(("seed", "noise_id", "stream"), [(5, 0, 0), (2001, 9, 3)])
def test_normals_equal_numpy_standard_normal(seed: int, noise_id: int, stream: int) -> None:
    n = 200_000
    ours = normals(seed, noise_id, stream, n)
    theirs = np.random.Generator(_numpy_philox(seed, noise_id, stream)).standard_normal(n)
    np.testing.assert_allclose(ours, theirs, rtol=1e-13, atol=0.0)
    # the comparison covers the tail beyond r (about 2.6e-4 of the draws: some 50 here)
    assert np.count_nonzero(np.abs(ours) > _ZIG_R) >= 20


def test_the_force_sensor_adds_the_streams_normals_in_order_from_the_first_step():
    """Without a low-pass, measured - true force at plant step k is the noise standard
    deviation times normal k of the run's force-sensor stream (NumPy's, as above), for every
    step of runs with different noise ids: none skipped, none repeated, none out of step."""
    from acc.engine.rng import STREAM_FORCE_SENSOR
    from acc.engine.simulate import simulate
    from acc.scenarios.force import load_scenario
    from tests.cli_run import SHIPPED

    sc = load_scenario(SHIPPED).with_values(
        {"sensor.lowpass_cutoff_hz": 0.0, "sensor.noise_std_N": 5.0,
         "simulation.time_limit_s": 0.5})
    res = simulate([sc, sc], noise_ids=[3, 11], record_every_steps=1, threads=1)
    noise = res.signal("measured_force_N") - res.signal("force_N")
    n = noise.shape[1]
    for row, noise_id in zip(noise, (3, 11), strict=True):
        gen = np.random.Generator(_numpy_philox(sc.simulation.seed, noise_id,
                                                STREAM_FORCE_SENSOR))
        np.testing.assert_allclose(row, 5.0 * gen.standard_normal(n), rtol=0, atol=1e-9)
