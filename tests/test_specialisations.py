"""How many compiled specialisations a sweep needs: delay lines, moving windows and signal
pieces have coarse capacities (:func:`acc.engine.element.delay_size`), so a sweep over dead
times or spindle speeds compiles the loop once, not once per power of two."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from acc import scenarios
from acc.engine import simulate as simulate_module
from acc.engine.element import delay_size, ring_size
from acc.engine.loop_compile import specialisation_key
from acc.engine.piecewise import piecewise_records

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "experiments" / "kim_chung_2001.toml"


class _NotCompiledError(Exception):
    """Raised in place of compiling: the key is all the test needs."""


def loop_key(monkeypatch: pytest.MonkeyPatch, *assignments: str) -> str:
    """The specialisation key of the force loop for the shipped scenario with overrides,
    taken where :func:`acc.engine.loop_compile.prepare_loop` would compile (nothing runs)."""
    keys: list[str] = []

    def capture(dispatcher: object, args: tuple, what: object) -> None:
        keys.append(specialisation_key(args))
        raise _NotCompiledError

    monkeypatch.setattr(simulate_module, "prepare_loop", capture)
    scenario = scenarios.load(SCENARIO, ["simulation.time_limit_s=1.0", *assignments])
    with pytest.raises(_NotCompiledError):
        simulate_module.simulate(scenario)
    return keys[0]


def dead_time(seconds: float, kind: str = "dob_adaptive_pi") -> list[str]:
    """Overrides: the plant's and the nominal model's dead time, a controller kind."""
    return [f"feed_drive.dead_time_s={seconds}", f"nominal_plant.dead_time_s={seconds}",
            f"controller.kind={kind!r}".replace("'", '"')]


def test_delay_size_series() -> None:
    """256, then powers of four; each the smallest that holds what is needed."""
    assert [delay_size(n) for n in (0, 1, 256, 257, 1024, 1025, 4097)] == [
        256, 256, 256, 1024, 1024, 4096, 16384]
    assert ring_size(9) == 16  # the small sizes keep their powers of two


def test_dead_times_up_to_255_steps_share_one_loop(monkeypatch: pytest.MonkeyPatch) -> None:
    """Dead times of 10 to 250 plant steps (1 ms) with the observer and the estimator, whose
    delay lines are in plant steps and control periods: one specialisation.  310 steps need
    a longer line, so the key (the types) is seen to change with the capacity."""
    keys = {t: loop_key(monkeypatch, *dead_time(t)) for t in (0.01, 0.03, 0.1, 0.25)}
    assert len(set(keys.values())) == 1, keys
    assert loop_key(monkeypatch, *dead_time(0.31)) != keys[0.1]


def test_spindle_speeds_share_one_loop(monkeypatch: pytest.MonkeyPatch) -> None:
    """The geometric force model: the metrics' per-revolution window (plant steps per
    spindle revolution) from 3000 rpm (20 steps) to 250 rpm (240 steps), one
    specialisation."""
    keys = {rpm: loop_key(monkeypatch, "geometry.enabled=true",
                          f"geometry.spindle_speed_rpm={rpm}")
            for rpm in (3000.0, 1000.0, 250.0)}
    assert len(set(keys.values())) == 1, keys


def test_signal_pieces_share_one_type() -> None:
    """A position reference of 2 pieces and one of 200: the same record type (the axis
    loop's specialisation)."""
    def dtype(pieces: int) -> np.dtype:
        steps = np.arange(pieces, dtype=np.int64) * 10
        params, _ = piecewise_records([steps], [np.ones(pieces)], plant_step_s=1e-3)
        return params.dtype

    assert dtype(2) == dtype(200)
    assert dtype(2) != dtype(300)
