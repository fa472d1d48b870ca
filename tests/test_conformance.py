"""One step contract for every dynamic element: ``init`` -> state, ``step(state, ...)`` ->
(state, output); outputs of shape (runs,); deterministic; inputs never modified; a batch
equals its runs stepped one by one."""

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from controllers.pi import ConstantOverride, FeedOverridePI
from plants.feed_drive import FeedDrive
from plants.force_process import ForceProcess
from plants.force_sensor import ForceSensor

RUNS = 3
DT = 0.001


def _copy(tree: Any) -> Any:
    if isinstance(tree, np.ndarray):
        return tree.copy()
    if isinstance(tree, tuple):
        items = [_copy(x) for x in tree]
        return type(tree)(*items) if hasattr(tree, "_fields") else tuple(items)
    return tree


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray):
        return np.array_equal(a, b)
    if isinstance(a, tuple):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b, strict=True))
    return a == b


# each case: (factory(runs, rows) -> element, init(element) -> state, inputs(k, runs) -> args,
#             output picker)
def _drive(runs, rows):
    return FeedDrive(np.array([29.33, 20.0, 40.0])[rows], np.array([5, 0, 3])[rows], DT, runs)


def _process(runs, rows):
    g = np.array([[0.0, 4.0, 3.0], [3.3, 0.0, 3.7], [4.2, 3.3, 0.0]])[rows]
    p = np.array([[-2.35, -3.75, -5.35]] * 3)[rows]
    return ForceProcess(g, p, np.full(runs, 29.33), DT)


def _sensor(runs, rows):
    return ForceSensor(np.array([0.0, 2.0, 5.0])[rows], np.array([0.0, 20.0, 5.0])[rows], DT)


def _pi(runs, rows):
    return FeedOverridePI(
        np.array([500.0, 400.0, 450.0])[rows], 0.0025, 0.0094, 0.1, 2.0, 1.0, 0.01, runs
    )


def _constant(runs, rows):
    return ConstantOverride(np.array([0.9, 1.0, 1.1])[rows], runs)


def _feed(k, rows):
    return (np.array([100.0, 150.0, 200.0])[rows] * (1 + 0.1 * np.sin(0.01 * k)),)


def _proc_in(k, rows):
    seg = np.array([(k // 7) % 3] * 3)[rows]
    return (seg, np.full(len(rows), 120.0 + k), np.full(len(rows), 130.0))


def _force(k, rows):
    return (np.array([480.0, 520.0, 300.0])[rows] + k,)


def _force_noise(k, rows):
    rng = np.random.default_rng(k)
    return (np.array([480.0, 520.0, 300.0])[rows] + k, rng.standard_normal(3)[rows])


CASES: dict[str, tuple[Callable, Callable, Callable, Callable]] = {
    "feed_drive": (_drive, lambda e: e.init(), _feed, lambda out: out.velocity_mm_min),
    "force_process": (_process, lambda e: e.init(), _proc_in, lambda out: out),
    "force_sensor": (_sensor, lambda e: e.init(), _force_noise, lambda out: out),
    "pi": (_pi, lambda e: e.init(), _force, lambda out: out),
    "constant": (_constant, lambda e: e.init(), _force, lambda out: out),
}


def _trajectory(name: str, rows: np.ndarray, steps: int = 40) -> np.ndarray:
    factory, init, inputs, pick = CASES[name]
    element = factory(len(rows), rows)
    state = init(element)
    outs = []
    for k in range(steps):
        args = inputs(k, rows)
        before_state, before_args = _copy(state), _copy(args)
        state_next, out = element.step(state, *args)
        assert _equal(state, before_state), f"{name}.step modified its input state"
        assert _equal(args, before_args), f"{name}.step modified its inputs"
        value = np.asarray(pick(out))
        assert value.shape == (len(rows),), f"{name} output shape {value.shape}"
        outs.append(value)
        state = state_next
    return np.array(outs).T


@pytest.mark.parametrize("name", sorted(CASES))
def test_step_contract(name):
    rows = np.arange(RUNS)
    a = _trajectory(name, rows)
    b = _trajectory(name, rows)
    assert np.array_equal(a, b), "not deterministic"
    for r in range(RUNS):
        single = _trajectory(name, np.array([r]))
        np.testing.assert_allclose(a[r], single[0], rtol=1e-12, atol=0)
