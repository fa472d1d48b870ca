"""ISO 230-2 on constructed data: hand-computed values (written out below) and an independent
per-target computation with the ``statistics`` module.  The constructed case has 4 cycles at
3 targets, so dividing by the number of targets instead of cycles, swapping forward and
backward, taking a maximum for E's minimum or R from one direction twice all fail it."""

import math
import statistics

import numpy as np
import pytest

from controllers.monitoring.positioning_accuracy import iso230_2

TARGETS = np.array([0.0, 100.0, 200.0])
# deviations [um], rows = cycles, columns = targets
FWD = np.array([[1, 4, 0], [3, 4, 2], [1, 4, 0], [3, 4, 2]], float)
BWD = np.array([[-2, 0, -1], [-2, 4, -1], [-2, 0, -1], [-2, 4, -1]], float)


def test_hand_computed_case():
    r = iso230_2(TARGETS, FWD, BWD, deviations=True)
    s1 = math.sqrt(4 / 3)  # +-1 about the mean over 4 cycles, n - 1 = 3
    s2 = math.sqrt(16 / 3)  # +-2
    np.testing.assert_allclose(r.mean_forward, [2, 4, 1])
    np.testing.assert_allclose(r.mean_backward, [-2, 2, -1])
    np.testing.assert_allclose(r.std_forward, [s1, 0, s1])
    np.testing.assert_allclose(r.std_backward, [0, s2, 0])
    np.testing.assert_allclose(r.reversal, [4, 2, 2])  # signed: forward minus backward
    assert r.B == 4 and r.mean_reversal == pytest.approx(8 / 3)
    # R_i = max(2 sf + 2 sb + |B_i|, 4 sf, 4 sb)
    np.testing.assert_allclose(r.repeatability, [2 * s1 + 4, 4 * s2, 4 * s1])
    assert r.R == pytest.approx(4 * s2) and r.R_backward == pytest.approx(4 * s2)
    assert r.R_forward == pytest.approx(4 * s1)
    assert r.E == 6.0  # max 4 (forward, target 1) - min -2 (backward, target 0)
    assert r.E_forward == 3.0 and r.E_backward == 4.0  # [2, 4, 1] and [-2, 2, -1]
    assert r.M == 3.0  # bidirectional means [0, 3, 0]
    # A: max(xb + 2 sb) = 2 + 2 s2 at target 1, min(xb - 2 sb) = 2 - 2 s2 at target 1
    assert r.A == pytest.approx(4 * s2)
    assert r.A_forward == pytest.approx((2 + 2 * s1) - (1 - 2 * s1))  # targets 0 and 2


def test_positions_equal_deviations_plus_targets():
    a = iso230_2(TARGETS, FWD / 1000 + TARGETS, BWD / 1000 + TARGETS)
    b = iso230_2(TARGETS, FWD / 1000, BWD / 1000, deviations=True)
    for name in ("A", "B", "E", "M", "R"):
        assert getattr(a, name) == pytest.approx(getattr(b, name), rel=1e-9, abs=1e-12)


def test_against_an_independent_computation():
    rng = np.random.default_rng(4)
    targets = np.linspace(0, 500, 11)
    fwd = rng.normal(0.002, 0.001, (5, 11)) + 1e-5 * targets
    bwd = rng.normal(-0.003, 0.0015, (5, 11)) + 1e-5 * targets
    r = iso230_2(targets, fwd, bwd, deviations=True)
    xf = [statistics.mean(fwd[:, i]) for i in range(11)]
    xb = [statistics.mean(bwd[:, i]) for i in range(11)]
    sf = [statistics.stdev(fwd[:, i]) for i in range(11)]
    sb = [statistics.stdev(bwd[:, i]) for i in range(11)]
    bi = [f - b for f, b in zip(xf, xb, strict=True)]
    ri = [max(2 * f + 2 * b + abs(d), 4 * f, 4 * b) for f, b, d in zip(sf, sb, bi, strict=True)]
    xm = [(f + b) / 2 for f, b in zip(xf, xb, strict=True)]
    hi = max(max(f + 2 * s for f, s in zip(xf, sf, strict=True)),
             max(b + 2 * s for b, s in zip(xb, sb, strict=True)))
    lo = min(min(f - 2 * s for f, s in zip(xf, sf, strict=True)),
             min(b - 2 * s for b, s in zip(xb, sb, strict=True)))
    assert r.A == pytest.approx(hi - lo, rel=1e-12)
    assert r.B == pytest.approx(max(abs(d) for d in bi), rel=1e-12)
    assert r.E == pytest.approx(max(xf + xb) - min(xf + xb), rel=1e-12)
    assert r.M == pytest.approx(max(xm) - min(xm), rel=1e-12)
    assert r.R == pytest.approx(max(ri), rel=1e-12)


def test_rejects_one_cycle_and_bad_shapes():
    with pytest.raises(ValueError):
        iso230_2(TARGETS, FWD[:1], BWD[:1], deviations=True)
    with pytest.raises(ValueError):
        iso230_2(TARGETS, FWD, BWD[:, :2], deviations=True)
