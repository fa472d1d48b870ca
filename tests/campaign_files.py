"""Small campaign files shared by the campaign, sweep and gate tests.

Short parts and a coarse plant step (2 ms, dead time 0.1 s = 50 steps) keep every sweep
to a fraction of a second per run.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

SMALL_SET = """
[set]
simulation.plant_step_s = 0.002
simulation.time_limit_s = 3.0
workpiece.segment_length_mm = [2.0, 2.0]
workpiece.radial_depth_mm = [2.0, 3.0]
workpiece.axial_depth_mm = [10.0, 10.0]
sensor.noise_std_N = 5.0
sensor.lowpass_cutoff_hz = 20.0
"""

#: 2 kinds x 2 profiles x 3 samples = 12 runs, random hardness and noise.
SMALL = (
    """
[campaign]
name = "small"
seed = 11
samples_per_point = 3
chunk_runs = 4
"""
    + SMALL_SET
    + """
[grid]
controller.kind = ["pi", "constant"]
workpiece.radial_depth_mm = [[2.0, 3.0], [4.0, 2.0]]

[random]
force_process.gain_multiplier = { dist = "uniform", low = 0.85, high = 1.15 }
sensor.noise_std_N = { dist = "uniform", low = 0.0, high = 10.0 }
"""
)

#: Grid point 1 is a material 1000 times harder than the table: the loop (PI designed on
#: the nominal plant) is unstable and the force leaves 100 x the reference.
WITH_UNSTABLE = (
    """
[campaign]
name = "with_unstable"
seed = 5
samples_per_point = 2
chunk_runs = 3
"""
    + SMALL_SET
    + """
[grid]
force_process.gain_multiplier = [1.0, 1000.0, 0.9]
"""
)


def write(directory: Path, name: str, text: str) -> Path:
    """Write a campaign file and return its path."""
    path = directory / name
    path.write_text(text, encoding="utf-8")
    return path


def kill_sweep_after(path: Path, out: Path, chunks: int, timeout_s: float = 120.0) -> int:
    """Start ``acc sweep path --out out`` (1 worker, 1-run chunks) in a process, SIGKILL it
    once ``chunks`` chunk files exist, and return how many it finished."""
    cmd = [sys.executable, "-c", "from acc.cli.main import main; raise SystemExit(main())",
           "sweep", str(path), "--out", str(out), "--workers", "1", "--chunk-runs", "1",
           "--no-progress", "--no-figures"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + timeout_s
        while len(list((out / "chunks").glob("runs_*.csv"))) < chunks:
            assert proc.poll() is None, "the sweep ended before it could be interrupted"
            assert time.monotonic() < deadline
            time.sleep(0.005)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    assert not (out / "summary.csv").exists()
    return len(list((out / "chunks").glob("runs_*.csv")))
