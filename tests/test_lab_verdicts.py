"""Verdicts of the lab runs and the validation the labs rely on: one test per reproducer of
the issue "unstable lab runs are reported as results" (the command and what it printed
before is in each docstring), the bounds of :mod:`acc.engine.axis_verdicts` checked on
closed forms, and the linear check against python-control.

Numbers come from: the verdict rules (D = 100 path sizes of following error, D times the
drive's peak current: 30 A for Peng's amplifier, seed 000 L1780), ramps whose error is
written by hand, the Nyquist frequency 1/(2 T), a path's sample count from its duration,
and python-control's discrete closed loop built here from the thesis's equations.
"""

from __future__ import annotations

import csv
import math
import tracemalloc

import control
import numpy as np
import pytest

from acc import scenarios
from acc.design.contour_tuning import closed_loop_spectral_radius
from acc.engine.axis_simulate import simulate_axis
from acc.engine.axis_verdicts import linear_loop_spectral_radius
from acc.errors import ScenarioError
from acc.limits import MAX_PLANT_STEPS, MAX_TRACE_BYTES
from controllers.axis.lead_lag import LeadLagParams
from controllers.axis.pid import AxisPIDParams
from controllers.axis.trajectory import TrajectoryParams
from plants.axis.elastic_axis import xy_table_defaults, xy_table_high_speed
from plants.axis.servo_axis import ServoAxisParams
from tests.cli_run import ROOT, acc, assert_one_line_error
from tests.test_axis_servo import thesis_matrices

EXP = ROOT / "experiments"
AXIS_FILE = str(EXP / "peng_servo_axis.toml")
DIAMOND = str(EXP / "peng_diamond_mismatched.toml")
CIRCLE = str(EXP / "peng_circle.toml")
LACERDA = str(EXP / "lacerda_circle_40.toml")
BRIQUEZ = str(EXP / "briquez_huron_axis.toml")
FORCE = str(EXP / "kim_chung_2001.toml")
D = 100.0  # the labs' divergence factor
PEAK_A = 30.0  # Peng App. A amplifier peak current (seed 000, L1780)


def _row(out) -> dict[str, str]:  # noqa: ANN001
    with (out / "summary.csv").open(newline="", encoding="utf-8") as fh:
        (row,) = list(csv.DictReader(fh))
    return row


def _failed_run(tmp_path, scenario: str, *sets: str) -> tuple[dict[str, str], str]:  # noqa: ANN001
    """``acc run`` exits 0, its result line ends with ``[FAILED: <reason>]`` and the row
    says so; returns the row and the output line."""
    out = tmp_path / "out"
    args = [a for s in sets for a in ("--set", s)]
    r = acc("run", scenario, "--out", out, *args)
    assert r.status == 0, r.err
    row = _row(out)
    assert row["failed"] == "True", row
    assert row["failure_reason"], row
    first = r.out.splitlines()[0]
    assert first.endswith(f"[FAILED: {row['failure_reason']}]"), first
    return row, first


# --- 1. reproducers: diverged runs are flagged, their metrics never computed -------------


def test_unstable_axis_gain_is_flagged_and_stops_at_the_current_bound(tmp_path):
    """``acc run experiments/peng_servo_axis.toml --set lead_lag.gain=15`` printed 'max
    |following error| 8435.85 um' and drew 105 kA, exit 0 and no flag.  Now: failed, the
    metrics NaN, the run stopped when the current passed D x 30 A = 3 kA (every traced
    sample within it, the rest NaN), and the linear loop's spectral radius (python-control,
    below) is above 1 at gain 15 and below at Peng's 2.5."""
    row, line = _failed_run(tmp_path, AXIS_FILE, "lead_lag.gain=15")
    assert "current" in row["failure_reason"] and "3000 A" in row["failure_reason"]
    for k in ("max_abs_following_error_mm", "iae_mm_s", "max_abs_current_A"):
        assert math.isnan(float(row[k])), k
    assert "max |following error| nan um" in line
    tr = np.load(tmp_path / "out" / "traces.npz")
    current = tr["current_A"][0] if tr["current_A"].ndim == 2 else tr["current_A"]
    done = np.isfinite(current)
    assert 0 < done.sum() < current.size and not done[done.argmin():].any()
    assert np.abs(current[done]).max() <= D * PEAK_A
    assert float(row["spectral_radius"]) == pytest.approx(_peng_radius(15.0), rel=1e-9)
    assert _peng_radius(15.0) > 1.0 > _peng_radius(2.5)


def test_the_diamond_of_a_diverged_run_has_no_corner_metrics(tmp_path):
    """The mismatched diamond at gain 15 read M1 = 0.047 mm beside a 6.4 mm contour error.
    Now M1-M4, the segment error and the contour-error metrics are NaN, and the reason
    names the axis."""
    row, _ = _failed_run(tmp_path, DIAMOND, "lead_lag.gain=15")
    assert row["failure_reason"].startswith(("x axis: ", "y axis: "))
    for k in ("M1_vertex_distance_mm", "M2_max_path_distance_mm", "M3_max_linear_estimate_mm",
              "M4_bisector_distance_mm", "linear_segment_error_mm", "iae_contour_mm_s",
              "max_abs_contour_error_mm"):
        assert math.isnan(float(row[k])), k


def test_a_failed_row_has_the_columns_of_a_good_one(tmp_path):
    """Campaign summaries concatenate rows: a failed run's row keeps every column."""
    good = tmp_path / "good"
    assert acc("run", DIAMOND, "--out", good).status == 0
    row, _ = _failed_run(tmp_path, DIAMOND, "lead_lag.gain=15")
    assert list(row) == list(_row(good))
    assert _row(good)["failed"] == "False" and _row(good)["failure_reason"] == ""


def test_the_circle_of_a_diverged_run_is_flagged_not_fitted(tmp_path):
    """``acc run experiments/peng_circle.toml --set lead_lag.gain=50`` raised LinAlgError
    (the least-squares circle of NaN positions).  Now: failed, F, G and the glitches NaN."""
    row, _ = _failed_run(tmp_path, CIRCLE, "lead_lag.gain=50")
    for k in ("F_max_mm", "F_min_mm", "G_mm", "glitch_0_deg_mm", "rest_max_mm"):
        assert math.isnan(float(row[k])), k


def test_a_table_that_stands_still_draws_no_circle(tmp_path, capfd):
    """``--set lead_lag.gain=0`` on the circle raised LinAlgError (every position the start
    point).  Now exit 0, not failed (nothing diverged: the loop is open, spectral radius 1),
    G NaN (no least-squares circle), and F about the nominal centre 0: the start point lies
    on the circle."""
    out = tmp_path / "out"
    r = acc("run", CIRCLE, "--out", out, "--set", "lead_lag.gain=0")
    assert r.status == 0, r.err
    assert not r.err_lines, r.err
    fd = capfd.readouterr()  # LAPACK's "DLASCL ... illegal value" goes to fd 1 directly
    assert "illegal value" not in fd.out + fd.err
    row = _row(out)
    assert row["failed"] == "False"
    assert math.isnan(float(row["G_mm"]))
    assert float(row["F_max_mm"]) == pytest.approx(0.0, abs=1e-12)
    assert float(row["F_min_mm"]) == pytest.approx(0.0, abs=1e-12)


def test_the_axis_plot_of_a_run_that_overflowed(tmp_path):
    """``--set lead_lag.zero=1000`` (and command_gain=1000, dac_gain 50) ended in matplotlib's
    'arange: cannot compute length' traceback: the positions reached 1e303 and the current
    1e308.  Now the run stops at its bound and the figure is drawn."""
    row, _ = _failed_run(tmp_path, AXIS_FILE, "lead_lag.zero=1000.0")
    assert (tmp_path / "out" / "response.png").stat().st_size > 0
    assert row["failure_reason"]


def test_the_coupled_loop_flags_an_unstable_axis_with_the_cec_on(tmp_path):
    """Lacerda's circle (CEC on) with a 0.3 s controller period: each axis's own loop is
    checked with the CEC on too; on a table without Coulomb friction it is unstable."""
    row, _ = _failed_run(tmp_path, LACERDA, "simulation.control_period_s=0.3",
                         *NO_FRICTION)
    assert "linear loop is unstable" in row["failure_reason"]
    assert float(row["spectral_radius_x"]) > 1


#: The shipped circle's table sets its Coulomb friction per axis, so it is zeroed per axis.
NO_FRICTION = ("elastic_axis.x.coulomb_friction_N=0", "elastic_axis.y.coulomb_friction_N=0")
#: A Ziegler-Nichols PID with 4 times the derivative time (what E1-4 of
#: experiments/reproduce_lacerda_belo.py gives on the spec's M1-3 table) on the y axis of the
#: shipped circle's high-speed table: its linear loop is unstable (the undamped two-inertia
#: resonance), the simulated table with its Coulomb friction tracks.
ZN_Y = ["pid.y.p_gain_per_mm=3.060473691858886", "pid.y.i_gain_per_mm_s=174.3747109937716",
        "pid.y.d_gain_s_per_mm=0.053714779885111426"]


def test_dry_friction_leaves_the_verdict_to_the_bounds(tmp_path):
    """With the table's Coulomb friction the unstable linear loop is reported (spectral
    radius, from :func:`acc.design.contour_tuning.closed_loop_spectral_radius`) but does
    not fail the run; without friction it does."""
    _, ay = xy_table_high_speed()
    radius = closed_loop_spectral_radius(ay, 3.060473691858886, 174.3747109937716,
                                         0.053714779885111426, 1e-3)
    assert radius > 1.001
    out = tmp_path / "dry"
    r = acc("run", LACERDA, "--out", out, *[a for s in ZN_Y for a in ("--set", s)])
    assert r.status == 0, r.err
    row = _row(out)
    assert row["failed"] == "False"
    assert float(row["spectral_radius_y"]) == pytest.approx(radius, rel=1e-12)
    row, _ = _failed_run(tmp_path, LACERDA, *ZN_Y, *NO_FRICTION)
    assert row["failure_reason"].startswith("y axis: the linear loop is unstable")


# --- the bounds on closed forms ----------------------------------------------------------


def test_error_bound_stops_the_run_at_the_step_written_by_hand():
    """A ramp of 25 mm/s from 10 ms under a lead-lag of gain 0: the table stays at rest, so
    e(k) = 25 (k - 10) 1e-3 mm.  With L = 1 mm (the floor) and D = 2.01 the bound 2.01 mm
    is first passed at k - 10 = 81 (2.025 mm): the run fails at t = 0.091 s, its traces hold
    k = 0..90 and NaN after, the reason gives 2.025 mm."""
    res = simulate_axis(ServoAxisParams(), LeadLagParams(gain=0.0),
                        TrajectoryParams(kind="ramp", feed_mm_s=25.0, start_s=0.01),
                        duration_s=0.2, path_size_mm=0.5, divergence_factor=2.01)
    assert bool(res.metrics["failed"][0])
    reason = res.failure_reasons[0]
    assert "2.025 mm" in reason and "2.01 mm" in reason and "t = 0.091 s" in reason
    e = res.signals["following_error_mm"][0]
    assert np.isfinite(e[:91]).all() and np.isnan(e[91:]).all()
    np.testing.assert_allclose(e[10:91], 0.025 * np.arange(81), rtol=0, atol=1e-12)
    assert math.isnan(res.metrics["max_abs_following_error_mm"][0])


def test_a_non_finite_reference_fails_the_run_where_it_appears():
    """A reference sample NaN at step 30: the error is non-finite there."""
    ref = np.zeros(100)
    ref[30:] = np.nan
    res = simulate_axis(ServoAxisParams(), LeadLagParams(), reference_samples_mm=ref,
                        duration_s=0.1)
    assert res.failure_reasons[0] == "a state became non-finite at t = 0.03 s"


def test_saturated_share_of_a_limited_lead_lag_written_by_hand():
    """Peng's ramp (from step 10) under a 1 nV output limit, no load: the command is 0 up to
    step 10 (no error yet) and at the limit from step 11 on (the error grows, the table
    hardly moves: v(k) = K 25 dt [(k - 10) - 0.8825 (k - 11)] > 0), so 989 of 1000 steps.
    A limit never reached gives 0, no limit NaN."""
    traj = TrajectoryParams(kind="ramp", feed_mm_s=25.0, start_s=0.01)
    kw = dict(duration_s=1.0, record_every_steps=None)
    tiny = simulate_axis(ServoAxisParams(), LeadLagParams(output_limit_V=1e-9), traj, **kw)
    assert not tiny.metrics["failed"][0]
    assert tiny.metrics["saturated_fraction"][0] == pytest.approx(989 / 1000, abs=1e-15)
    wide = simulate_axis(ServoAxisParams(), LeadLagParams(output_limit_V=100.0), traj, **kw)
    assert wide.metrics["saturated_fraction"][0] == 0.0
    free = simulate_axis(ServoAxisParams(), LeadLagParams(), traj, **kw)
    assert math.isnan(free.metrics["saturated_fraction"][0])


# --- the linear check against python-control ---------------------------------------------


def _peng_radius(gain: float, **kw: object) -> float:
    """Spectral radius of Peng's sampled loop built here: the thesis block (2.24) by
    python-control's ZOH at 1 ms, in counts, the D/A gain and D(z) (with its integrator, as
    ``LeadLagParams.transfer_function``) and a delay of d samples, closed by feedback."""
    ax, ll = ServoAxisParams(), LeadLagParams(gain=gain, **kw)
    A, B = thesis_matrices(ax)
    C = np.array([[0.0, 0.0, ax.counts_per_mm]])
    plant = control.c2d(control.ss(A, B[:, :1], C, 0.0), 0.001, method="zoh")
    loop = control.tf(plant) * ll.transfer_function(0.001)
    d = ll.computational_delay_samples
    if d:
        loop = loop * control.tf([1.0], [1.0] + [0.0] * d, 0.001)
    return float(np.abs(control.poles(control.feedback(loop, 1))).max())


@pytest.mark.parametrize("kw", [
    {"gain": 2.5}, {"gain": 15.0}, {"gain": 4.0, "pole": -0.5, "zero": -0.7},
    {"gain": 2.5, "integrator_form": "discrete_parallel", "integrator_gain_per_sample": 0.01},
    {"gain": 2.5, "integrator_form": "continuous_CI", "integrator_gain_1_s": 20.0},
    {"gain": 2.5, "computational_delay_samples": 2},
    {"gain": 2.5, "pole": -1.0},
])
def test_lead_lag_loop_radius_equals_python_control(kw):
    """The check's closed loop equals python-control's to 1e-7 (eigenvalues of a loop with
    an integrator, a double root near 1, are accurate to about sqrt(eps))."""
    gain = kw.pop("gain")
    want = _peng_radius(gain, **kw)
    got = linear_loop_spectral_radius(ServoAxisParams(), LeadLagParams(gain=gain, **kw), 0.001)
    assert got == pytest.approx(want, abs=1e-7)


@pytest.mark.parametrize("gains", [(3.5, 106.3, 0.037), (4.0, 15.0, 0.012), (50.0, 10.0, 1e-3)])
def test_pid_on_the_elastic_axis_equals_the_tuning_module(gains):
    """Against :func:`acc.design.contour_tuning.closed_loop_spectral_radius`, written
    separately for the PID tuning (the same LinuxCNC law, its own matrices)."""
    _, ay = xy_table_defaults()
    pid = AxisPIDParams(p_gain_per_mm=gains[0], i_gain_per_mm_s=gains[1],
                        d_gain_s_per_mm=gains[2])
    assert linear_loop_spectral_radius(ay, pid, 1e-3) == pytest.approx(
        closed_loop_spectral_radius(ay, *gains, 1e-3), rel=1e-12)


# --- 2. validation: short paths, sizes before allocation, periods, blame -----------------


@pytest.mark.parametrize(("scenario", "sets", "key"), [
    # ValueError traceback (the circle fit of two points)
    (CIRCLE, ["path.revolutions=1e-9"], "path.revolutions"),
    # ValueError traceback (a polyline of one point)
    (DIAMOND, ["path.lead_in_s=0", "path.lead_out_s=0.001"], "path.lead_out_s"),
    # IndexError traceback (an empty corner path)
    (DIAMOND, ["path.lead_in_s=0", "path.lead_out_s=0"], "path.lead_in_s"),
    # "the contouring simulation failed" (a sinusoid of one sample)
    (CIRCLE, ["path.kind='sinusoid'", "path.duration_s=0.001"], "path.duration_s"),
])
def test_too_short_paths_are_refused(tmp_path, scenario, sets, key):
    """A contouring run needs three samples (the circle fit, the corner's polyline)."""
    args = [a for s in sets for a in ("--set", s)]
    line = assert_one_line_error(acc("run", scenario, "--out", tmp_path / "o", *args),
                                 "--set: ", key, "at least 3")
    assert "samples" in line


def test_path_size_is_refused_before_anything_is_allocated():
    """A 1 ps plant step makes Peng's circle 2 pi 10/20 / 1e-12 = 3.14e12 samples (PiB of
    arrays; before, validation interpolated them): refused from the parameters, naming the
    plant step, with under 1 MiB allocated by the validation of the override."""
    base = scenarios.load(CIRCLE)
    tracemalloc.start()
    try:
        with pytest.raises(ScenarioError, match="simulation.plant_step_s") as exc:
            base.with_values({"simulation.plant_step_s": 1e-12})
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1024**2
    assert str(exc.value).startswith("--set: simulation.plant_step_s:")
    assert f"{2 * math.pi * 10 / 20 / 1e-12 + 1:.3g} samples" in str(exc.value)
    assert f"at most {MAX_PLANT_STEPS:g}" in str(exc.value)


def test_revolutions_whose_memory_is_too_large_are_refused(tmp_path):
    """``--set path.revolutions=7100`` grew to 11.7 GB and ended in a MemoryError traceback:
    7100 x 2 pi 10/20 / 1e-3 = 2.23e7 samples, below the step limit but, at 1 KiB each,
    above the memory limit.  Refused in one line naming path.revolutions."""
    n = 7100 * 2 * math.pi * 10 / 20 / 1e-3 + 1
    assert n < MAX_PLANT_STEPS and n * 1024 > MAX_TRACE_BYTES
    assert_one_line_error(acc("run", CIRCLE, "--out", tmp_path / "o", "--set",
                              "path.revolutions=7100"),
                          "--set: path.revolutions:", f"{n:.3g} path samples", "(limit)")


@pytest.mark.parametrize(("scenario", "assignment", "key"), [
    # each was "the axis simulation failed" (validation passed, the engine refused)
    (AXIS_FILE, "trajectory.start_s=1e-09", "trajectory.start_s"),
    (AXIS_FILE, "cutting_load.start_s=1e-09", "cutting_load.start_s"),
    (BRIQUEZ, "simulation.duration_s=1e-09", "simulation.duration_s"),
    (BRIQUEZ, "simulation.control_period_s=15", "simulation.control_period_s"),
    (BRIQUEZ, "state_control.observer_frequency_Hz=1e6", "state_control.observer_frequency_Hz"),
    # a delay line of 1e9 control periods (8 GB per run)
    (AXIS_FILE, "lead_lag.computational_delay_samples=1000000000",
     "lead_lag.computational_delay_samples"),
])
def test_axis_values_the_engine_refused_are_validation_errors(tmp_path, scenario, assignment,
                                                              key):
    assert_one_line_error(acc("run", scenario, "--out", tmp_path / "o", "--set", assignment),
                          f"--set: {key}:")


def test_control_period_longer_than_the_run_is_refused(tmp_path):
    """A 3 s period in a 1 s run acts once (the axis never follows): refused."""
    assert_one_line_error(acc("run", AXIS_FILE, "--out", tmp_path / "o", "--set",
                              "simulation.control_period_s=3"),
                          "--set: simulation.control_period_s:", "duration_s")


@pytest.mark.parametrize(("frequency_hz", "ok"), [(49.9, True), (50.0, False), (60.0, False)])
def test_resonator_frequency_below_the_control_nyquist(frequency_hz, ok):
    """``controller.resonant_frequency_hz=60`` with the 10 ms control period passed
    validation and failed inside the simulation, blamed on the file.  The resonator needs
    W = 2 pi f0 T_c < pi: f0 below 1/(2 x 0.01 s) = 50 Hz; the error names --set."""
    assignment = [f"controller.resonant_frequency_hz={frequency_hz}"]
    if ok:
        scenarios.load(FORCE, assignment)
        return
    with pytest.raises(ScenarioError) as exc:
        scenarios.load(FORCE, assignment)
    text = str(exc.value)
    assert text.startswith("--set: controller.resonant_frequency_hz:")
    assert "Nyquist frequency 50 Hz" in text


@pytest.mark.parametrize("scenario", [AXIS_FILE, DIAMOND])
def test_an_override_is_blamed_and_the_file_kept(tmp_path, scenario):
    """Errors an override causes name --set; a scenario built with overrides keeps its file
    as its source (what the run's messages and outputs name)."""
    assert scenarios.load(scenario, ["simulation.seed=3"]).source == scenario
    line = assert_one_line_error(acc("run", scenario, "--out", tmp_path / "o", "--set",
                                     "simulation.plant_step_s=-1"), "--set: ")
    assert "simulation.plant_step_s" in line


def test_the_safety_net_names_the_file_and_the_overrides(tmp_path, monkeypatch):
    """An exception inside a lab run (validation should have caught it) is one line naming
    the file and the --set overrides that may have caused it, not the file alone."""
    import acc.scenarios.contour as contour_scenarios

    def boom(*args: object, **kwargs: object) -> None:
        raise RuntimeError("boom")

    monkeypatch.setattr(contour_scenarios.ContourScenario, "simulate", boom)
    line = assert_one_line_error(
        acc("run", DIAMOND, "--out", tmp_path / "o", "--set", "lead_lag.gain=3"),
        f"{DIAMOND} with --set lead_lag.gain=3: the contouring simulation failed", "boom")
    assert not (tmp_path / "o").exists(), line


def test_lab_run_writes_a_manifest_and_traces_csv_equal_to_the_npz(tmp_path):
    import json

    import numpy as np

    from tests.cli_run import ROOT, acc

    out = tmp_path / "axis"
    result = acc("run", ROOT / "experiments" / "peng_servo_axis.toml", "--out", out,
                 "--set", "lead_lag.gain=2.0")
    assert result.status == 0, result.err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["model"] == "axis" and manifest["overrides"] == ["lead_lag.gain=2.0"]
    assert manifest["scenario"]["lead_lag"]["gain"] == 2.0
    npz = np.load(out / "traces.npz")
    csv_table = np.genfromtxt(out / "traces.csv", delimiter=",", names=True)
    for name in csv_table.dtype.names:
        np.testing.assert_array_equal(csv_table[name], npz[name])  # repr: exact round trip


def test_trace_csv_is_streamed_in_blocks_not_held_whole(tmp_path, monkeypatch):
    import tracemalloc

    import numpy as np

    import acc.output as output

    n = 50_000
    rng = np.random.default_rng(1)
    signals = {f"s{j}": rng.standard_normal(n) for j in range(10)}
    time_s = np.arange(n) * 1e-3
    monkeypatch.setattr(output, "TRACE_CSV_BLOCK_ROWS", 2048)
    tracemalloc.start()
    output.write_signal_traces(tmp_path, time_s, signals)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    # a block of 2048 rows x 11 floats as Python objects is under 1 MB (the peak measured
    # 2.4 MiB); the whole table as dict rows (the former writer) was about 1.5 KB per row,
    # 75 MB here, and one block of all the rows about 18 MB
    assert peak < 8 * 2**20, peak
    table = np.loadtxt(tmp_path / "traces.csv", delimiter=",", skiprows=1)
    assert table.shape == (n, 11)
    np.testing.assert_array_equal(table[:, 1], signals["s0"])
    np.testing.assert_array_equal(table[:, 0], time_s)


def test_a_failed_runs_figure_title_says_why():
    from acc.cli.common import failed_title

    assert failed_title("axis", {"failed": False, "failure_reason": ""}) == "axis"
    title = failed_title("axis", {"failed": True, "failure_reason": "current 3117 A beyond "
                                  "the bound 3000 A (100 x the drive's peak) at t = 0.401 s"})
    lines = title.split("\n")
    assert lines[0] == "axis" and lines[1].startswith("FAILED: current 3117 A")
    assert all(len(line) <= 60 for line in lines)  # wrapped: no title clipped by the frame
    assert " ".join(lines[1:]).endswith("at t = 0.401 s")
