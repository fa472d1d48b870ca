"""Integration tests on a headless LinuxCNC (marked ``linuxcnc``; skipped with the reason when
LinuxCNC is not installed or unusable).  Few runs: each one starts LinuxCNC (3-4 s) and runs
a program.

* an adaptive-feed step: the value takes effect in exactly the scheduled servo cycle and the
  planner's velocity ramps from it at ``MAX_ACCELERATION / 2`` per second (G64), the joint's
  position one cycle later (closed forms from the settings);
* ``acc linuxcnc run`` of the shipped example: the force settles at the reference in every
  depth segment, differs from the workbench's prediction by <= 2 % of the reference RMS, the
  LinuxCNC session takes well under a minute;
* nothing is left behind (processes, LinuxCNC's shared memory, its lock file) after a normal
  exit, a failure (a HAL error) and a timeout kill.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from acc.cli.main import main
from acc.linuxcnc import (
    FeedSchedule,
    LinuxCNCError,
    MachineSettings,
    leftovers,
    linuxcnc_problem,
    record_program,
    straight_program,
)

_PROBLEM = linuxcnc_problem()
pytestmark = [
    pytest.mark.linuxcnc,
    pytest.mark.skipif(_PROBLEM is not None, reason=_PROBLEM or ""),
]

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "experiments" / "linuxcnc_kim_chung.toml"


def _shm_files() -> set[str]:
    return {p.name for p in Path("/dev/shm").iterdir()}


def test_adaptive_feed_step_is_exact_in_time_and_ramps_at_half_the_acceleration(
    tmp_path: Path,
) -> None:
    settings = MachineSettings(max_acceleration_mm_s2=400.0, path_mode="G64")
    shm_before = _shm_files()
    rec = record_program(
        straight_program(20.0, 600.0), tmp_path,
        settings=settings, hook=FeedSchedule((0.5,), (0.25,), initial=0.5),
        time_limit_s=60.0,
    )
    assert leftovers() == []
    assert _shm_files() <= shm_before
    n = rec.sample
    assert np.all(np.diff(n) == 1)  # every servo cycle
    origin = int(rec.hook_arrays["origin_sample"][0])
    step_at = origin + 500  # 0.5 s at 1 ms
    feed = rec.signals["motion.adaptive-feed"]
    i = int(np.searchsorted(n, step_at))
    assert feed[i - 1] == 0.5 and feed[i] == 0.25
    vel = rec.signals["motion.current-vel"]
    v0 = 600.0 / 60.0 * 2.0 * 0.5  # F x feed override x adaptive feed [mm/s]
    v1 = v0 / 2.0
    ramp = 400.0 / 2.0 * 0.001  # A/2 per cycle under G64 [mm/s]
    assert vel[i - 1] == pytest.approx(v0, abs=1e-9)
    expected = np.maximum(v0 - ramp * np.arange(1, 30), v1)
    np.testing.assert_allclose(vel[i:i + 29], expected, atol=1e-9)
    # the joint's position: the planner's trapezoidal position smoothed one cycle later
    pos = rec.signals["joint.0.motor-pos-cmd"]
    assert pos[i + 40] - pos[i + 39] == pytest.approx(v1 * 0.001, rel=1e-6)


def test_closed_loop_settles_and_matches_the_prediction(tmp_path: Path) -> None:
    out = tmp_path / "run"
    shm_before = _shm_files()
    assert main(["-q", "linuxcnc", "run", str(EXAMPLE), "--out", str(out)]) == 0
    assert leftovers() == []
    assert _shm_files() <= shm_before
    with open(out / "summary.csv") as f:
        row = next(csv.DictReader(f))
    with open(out / "prediction.csv") as f:
        pred = next(csv.DictReader(f))
    ref = 500.0
    # within the 2 % settling band in every depth segment of the part
    for j in (1, 2, 3):
        assert float(row[f"settling_time_s_seg{j}"]) < 3.0
    traces = np.load(out / "traces.npz")
    force = traces["force_N"][0]
    seg = traces["radial_depth_mm"][0]
    for depth in (2.0, 3.0, 4.0):
        tail = force[np.flatnonzero(seg == depth)[-300:]]
        assert abs(tail.mean() - ref) < 0.02 * ref
    assert float(pred["rms_force_difference_pct"]) <= 2.0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["linuxcnc"]["difference"]["rms_force_difference_pct"] <= 2.0
    assert manifest["linuxcnc"]["session_wall_s"] < 60.0
    assert manifest["linuxcnc"]["worker"]["late_schedules"] == 0
    for name in ("response.png", "comparison.png", "traces.csv", "linuxcnc/config/machine.ini",
                 "linuxcnc/recording.npz"):
        assert (out / name).exists()


def test_nothing_is_left_after_a_failure_or_a_timeout_kill(tmp_path: Path) -> None:
    shm_before = _shm_files()
    with pytest.raises(LinuxCNCError, match="did not start"):
        record_program(straight_program(5.0, 600.0), tmp_path / "bad",
                       extra_hal=["net acc-broken no-such-component.pin"], time_limit_s=60.0)
    assert leftovers() == []
    with pytest.raises(LinuxCNCError, match="time limit"):
        # 600 mm at 30 mm/min is 20 minutes: the 5 s limit kills it while it runs
        record_program(straight_program(600.0, 30.0), tmp_path / "slow", time_limit_s=5.0)
    assert leftovers() == []
    assert _shm_files() <= shm_before


def test_exported_component_runs_the_controller_in_hal(tmp_path: Path) -> None:
    """The exported ``acc-force`` loads into a machine and runs the scenario's PI: a force of
    1600 N (above the reference, 500 N, and the limit, 1500 N) drives the override to its
    minimum and raises the overload and feed-inhibit pins."""
    export = tmp_path / "export"
    assert main(["-q", "linuxcnc", "export", str(EXAMPLE), "--out", str(export)]) == 0
    pins = ["acc-force.override", "acc-force.adaptive-feed", "acc-force.overload",
            "acc-force.feed-inhibit"]
    rec = record_program(
        straight_program(40.0, 600.0), tmp_path / "run", extra_pins=pins, time_limit_s=90.0,
        extra_hal=[f"loadusr -W {export / 'acc-force'}", "setp acc-force.enable 1",
                   "loadrt constant names=acc-test-force", "addf acc-test-force servo-thread",
                   "setp acc-test-force.value 1600",
                   "net acc-test-force acc-test-force.out => acc-force.force"],
    )
    assert leftovers() == []
    s = rec.signals
    assert s["acc-force.override"][-1] == pytest.approx(0.1)  # override_min
    assert s["acc-force.adaptive-feed"][-1] == pytest.approx(0.1 / 2.0)  # / feed override
    assert s["acc-force.overload"][-1] == 1 and s["acc-force.feed-inhibit"][-1] == 1
