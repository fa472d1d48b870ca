"""Scenarios in, a :class:`~acc.engine.result.SimulationResult` out: the compiled force loop.

:func:`simulate` builds each slot's records from the scenarios (designs and exact
discretisations once per distinct parameter set), runs :func:`acc.engine.force_loop.run_runs`
on threads (the compiled loop releases the GIL) and turns the metric states and traces into
a result.  Runs that need different compiled elements (a different controller kind, the
geometric force model, current sensing) are simulated in groups and merged back in order;
a run's numbers do not depend on which other runs share its batch.
"""

from __future__ import annotations

import os
from collections.abc import Hashable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from acc.engine import force_loop
from acc.engine.current_sensing import feed_current_records
from acc.engine.element import delay_size, init_states
from acc.engine.loop_compile import compiled_aside, prepare_loop
from acc.engine.metrics import (
    constant_feed_time_s,
    event_marks,
    excess_iae_N_s,
    metrics_records,
    metrics_result,
    revolution_steps,
    safe_feeds_mm_min,
)
from acc.engine.result import SimulationResult, merge_results
from acc.limits import MAX_TRACE_BYTES, format_bytes
from acc.scenarios.force import Scenario, ScenarioError
from controllers.monitoring.breakage_monitor import (
    breakage_monitor_records,
    breakage_run_metrics,
    monitor_off_records,
)
from controllers.registry import controller_records, resolved_gains, uses_safe_feed
from plants.disturbance import disturbance_records
from plants.feed_drive import feed_drive_records
from plants.force_process import force_process_records
from plants.force_sensor import force_sensor_records
from plants.geometric_process import GeometricForceOutput
from plants.linuxcnc_drive import (
    LINUXCNC_DRIVE,
    chip_load_bandwidth_rad_s,
    linuxcnc_drive_records,
)
from plants.workpiece import WorkpieceBatch


def _shared(scenarios: Sequence[Scenario], attr: str) -> float:
    values = {getattr(s.simulation, attr) for s in scenarios}
    if len(values) != 1:
        raise ScenarioError(f"simulation.{attr} must be the same for every run of a batch")
    return values.pop()


def engine_key(scenario: Scenario) -> tuple:
    """What runs simulated in one compiled call must share: the controller kind, the
    feed-drive model, the sensor kind and, where enabled, the geometric force model and
    current-sensing sections."""
    return (
        scenario.controller.kind,
        (scenario.geometry, scenario.cutting_coefficients) if scenario.geometry.enabled else None,
        scenario.current_sensing if scenario.current_sensing.enabled else None,
        scenario.feed_drive.kind,
        scenario.sensor.kind,
        scenario.tool_breakage if scenario.tool_breakage.enabled else None,
    )


def batch_memory_bytes(
    scenarios: Sequence[Scenario], runs: int | None = None, record_every_steps: int | None = 1
) -> int:
    """Estimate of the memory a batch allocates for traces and delay lines [bytes].

    Counts the trace array and its copy into the result's signals (every signal of
    :data:`acc.engine.force_loop.TRACE_NAMES`, the segment index and the two depth
    signals, 8 bytes a sample) and each run's delay lines (the feed drive's in plant steps;
    the observer's and estimator's in control periods); the other records are small.

    Parameters
    ----------
    scenarios : sequence of Scenario
        The runs (or representatives of them: the largest dead times count).
    runs : int or None
        Runs in the batch (default ``len(scenarios)``).
    record_every_steps : int or None
        Trace decimation (None: no traces).
    """
    n = len(scenarios) if runs is None else runs
    sim = scenarios[0].simulation
    samples = 0
    if record_every_steps is not None:
        samples = -(-sim.max_steps // max(int(record_every_steps), 1))
    per_sample = 8 * (2 * len(force_loop.TRACE_NAMES) + 3)
    delay = max(s.delay_steps for s in scenarios)
    periods = max(
        int(round(s.nominal_plant.dead_time_s / sim.control_period_s)) for s in scenarios
    )
    per_run = samples * per_sample + 8 * delay_size(delay + 1) + 16 * delay_size(periods + 1)
    return int(n) * int(per_run)


def check_batch_memory(
    scenarios: Sequence[Scenario],
    runs: int | None = None,
    record_every_steps: int | None = 1,
    what: str | None = None,
) -> None:
    """Refuse a batch whose :func:`batch_memory_bytes` exceeds
    :data:`acc.limits.MAX_TRACE_BYTES`, before allocating it.

    Raises
    ------
    ScenarioError
        Naming ``simulation.time_limit_s``, with the estimate.
    """
    need = batch_memory_bytes(scenarios, runs, record_every_steps)
    if need <= MAX_TRACE_BYTES:
        return
    n = len(scenarios) if runs is None else runs
    sim = scenarios[0].simulation
    every = "no traces" if record_every_steps is None else (
        f"traces every {record_every_steps} plant step(s)"
    )
    raise ScenarioError.at(
        what or scenarios[0].source,
        "simulation.time_limit_s",
        f"{n} run(s) of {sim.max_steps} plant steps with {every} need about "
        f"{format_bytes(need)} for traces and delay lines (limit "
        f"{format_bytes(MAX_TRACE_BYTES)}); shorten the time limit, lengthen the plant step, "
        "record fewer steps or simulate fewer runs at once",
    )


def simulate(
    scenarios: Scenario | Sequence[Scenario],
    *,
    run_ids: Sequence[int] | None = None,
    noise_ids: Sequence[int] | None = None,
    record_every_steps: int | None = 1,
    threads: int | None = None,
) -> SimulationResult:
    """Simulate a batch of closed-loop runs that share a time grid.

    Parameters
    ----------
    scenarios : Scenario or sequence of Scenario, length runs
        One scenario per run.  Plant step, control period and time limit must agree.
    run_ids : sequence of int, shape (runs,), optional
        Campaign index of each run (default ``0 .. runs-1``).
    noise_ids : sequence of int, shape (runs,), optional
        Key of each run's random streams with its seed (default: the run ids).  Runs with
        the same seed and noise id see the same noise, whatever their controller.
    record_every_steps : int or None
        Record the signals every this many plant steps; None records no traces (metrics
        only).
    threads : int or None
        Threads that run the compiled loop (default: all cores).

    Returns
    -------
    SimulationResult
        Each run's signals end at its own last step (the part finished, the run failed or
        the time limit); later samples are NaN.
    """
    if isinstance(scenarios, Scenario):
        scenarios = [scenarios]
    scenarios = list(scenarios)
    runs = len(scenarios)
    if runs == 0:
        raise ValueError("simulate needs at least one scenario")
    ids = np.arange(runs) if run_ids is None else np.asarray(run_ids, dtype=np.int64)
    if ids.shape != (runs,):
        raise ValueError(f"run_ids must have shape ({runs},), got {ids.shape}")
    nids = ids if noise_ids is None else np.asarray(noise_ids, dtype=np.int64)
    if nids.shape != (runs,):
        raise ValueError(f"noise_ids must have shape ({runs},), got {nids.shape}")
    if record_every_steps is not None and record_every_steps < 1:
        raise ValueError("record_every_steps must be >= 1 or None")
    n_threads = (os.cpu_count() or 1) if threads is None else int(threads)
    if n_threads < 1:
        raise ValueError(f"threads must be >= 1, got {n_threads}")
    for attr in ("plant_step_s", "control_period_s", "time_limit_s"):
        _shared(scenarios, attr)
    check_batch_memory(scenarios, runs, record_every_steps)
    groups: dict[Hashable, list[int]] = {}
    for i, s in enumerate(scenarios):
        groups.setdefault(engine_key(s), []).append(i)
    parts = [
        _simulate_group(
            [scenarios[i] for i in g], ids[g], nids[g], record_every_steps, n_threads
        )
        for g in groups.values()
    ]
    if len(parts) == 1:
        return parts[0]
    return merge_results(parts, list(groups.values()))


def _distinct(keys: Sequence[Hashable]) -> tuple[list[int], NDArray[np.intp]]:
    """First index of each distinct key, and the distinct number of every key."""
    seen: dict[Hashable, int] = {}
    first: list[int] = []
    of = np.empty(len(keys), dtype=np.intp)
    for i, key in enumerate(keys):
        u = seen.setdefault(key, len(first))
        if u == len(first):
            first.append(i)
        of[i] = u
    return first, of


def _gathered(records: tuple[NDArray, NDArray], of: NDArray[np.intp]) -> tuple[NDArray, NDArray]:
    """Records of distinct designs, one row per run (copies: states are advanced)."""
    return records[0][of], records[1][of]


def _simulate_group(
    scenarios: list[Scenario],
    ids: NDArray[np.int64],
    noise_ids: NDArray[np.int64],
    record_every_steps: int | None,
    threads: int,
) -> SimulationResult:
    runs = len(scenarios)
    first = scenarios[0]
    sim = first.simulation
    dt = sim.plant_step_s
    what = engine_key(first)
    with compiled_aside(
        force_loop.run_runs,
        lambda: _group_inputs(scenarios, noise_ids, record_every_steps).args,
        what,
    ):
        g = _group_inputs(scenarios, noise_ids, record_every_steps)
    prepare_loop(force_loop.run_runs, g.args, what)
    shares = [np.arange(t, runs, threads, dtype=np.int64) for t in range(min(threads, runs))]
    if len(shares) == 1:
        force_loop.run_runs(shares[0], *g.args)
    else:
        with ThreadPoolExecutor(max_workers=len(shares)) as pool:
            list(pool.map(lambda share: force_loop.run_runs(share, *g.args), shares))
    record, every = record_every_steps is not None, g.every  # every: 0 without traces

    # --- results -------------------------------------------------------------------------
    m_params, m_state = g.metrics
    result_metrics = metrics_result(m_params, m_state, g.parts.segments)
    result_metrics["conventional_time_s"] = g.conventional
    with np.errstate(invalid="ignore", divide="ignore"):
        gain = 100.0 * (g.conventional / result_metrics["machining_time_s"] - 1.0)
    gain = np.where(np.isfinite(g.conventional), gain, np.nan)  # no safe constant feed
    # no productivity is credited to a run that oscillates or overloads
    result_metrics["productivity_gain_pct"] = np.where(
        result_metrics["oscillating"] | result_metrics["overload"], np.nan, gain
    )
    result_metrics["failed"] = m_state["failed"].copy()
    if any(s.metrics.excess_iae for s in scenarios):
        asked = np.array([s.metrics.excess_iae for s in scenarios])
        result_metrics["excess_iae_N_s"] = np.where(
            asked, excess_iae_N_s(scenarios, result_metrics["iae_N_s"]), np.nan
        )
    if first.tool_breakage.enabled:
        result_metrics.update(
            breakage_run_metrics(g.monitor[1], first.tool_breakage.max_delay_periods)
        )

    gains_first, gains_of = _distinct([(s.controller, s.nominal_plant) for s in scenarios])
    gains_u = [
        resolved_gains(scenarios[i].controller, scenarios[i].nominal_plant, sim.control_period_s)
        for i in gains_first
    ]
    parameters = {
        "kp_per_N": np.array([gains_u[u].kp_per_N for u in gains_of]),
        "ki_per_N_s": np.array([gains_u[u].ki_per_N_s for u in gains_of]),
        "design_crossover_rad_s": np.array([gains_u[u].crossover_rad_s for u in gains_of]),
        "dead_time_steps": g.delays.astype(float),
        "safe_feed_mm_min": g.safe_feed,
    }
    signals: dict[str, NDArray] = {}
    n_done = 0
    measures_current = first.current_sensing.enabled or first.sensor.kind != "dynamometer"
    if record:
        n_done = int(m_state["stop_step"].max()) // every + 1
        rows = np.arange(runs)[:, None]
        seg = g.trace_segment[:, :n_done]
        reached = seg >= 0
        safe = np.where(reached, seg, 0)
        for i, name in enumerate(force_loop.TRACE_NAMES):
            if name == "feed_current_A" and not measures_current:
                continue
            if name in ("disturbance_force_N", "disturbance_feed_mm_min") and not g.disturbed:
                continue
            if name == "breakage_monitor_signal" and not first.tool_breakage.enabled:
                continue
            signals[name] = g.traces[:, i, :n_done].copy()
        signals["radial_depth_mm"] = np.where(reached, g.parts.radial_depth_mm[rows, safe], np.nan)
        signals["axial_depth_mm"] = np.where(reached, g.parts.axial_depth_mm[rows, safe], np.nan)
    return SimulationResult(
        time_s=np.arange(n_done) * (every or 1) * dt,
        signals=signals,
        metrics=result_metrics,
        scenarios=tuple(scenarios),
        run_ids=ids,
        parameters=parameters,
    )


@dataclass(frozen=True)
class _GroupInputs:
    """A group's records and arrays: the loop's arguments and what the result reads."""

    args: tuple
    parts: WorkpieceBatch
    delays: NDArray[np.int64]
    safe_feed: NDArray[np.float64]
    conventional: NDArray[np.float64]
    metrics: tuple[NDArray, NDArray]
    monitor: tuple[NDArray, NDArray]
    disturbed: bool
    every: int
    traces: NDArray[np.float64]
    trace_segment: NDArray[np.int64]


def _group_inputs(
    scenarios: list[Scenario], noise_ids: NDArray[np.int64], record_every_steps: int | None
) -> _GroupInputs:
    """Build a group's records (designs and discretisations once per distinct parameter
    set) and trace arrays: :func:`acc.engine.force_loop.run_runs`'s arguments after the
    run list."""
    runs = len(scenarios)
    sim = scenarios[0].simulation
    dt = sim.plant_step_s
    n_max = sim.max_steps
    parts = WorkpieceBatch([s.workpiece for s in scenarios])
    nseg = parts.segments

    # --- plant: gain and pole per segment, every part of a table at once -----------------
    table_first, table_of = _distinct([s.force_process for s in scenarios])
    gain = np.empty((runs, nseg + 1))
    pole = np.empty((runs, nseg + 1))
    for u, i in enumerate(table_first):
        rows = table_of == u
        gain[rows], pole[rows] = scenarios[i].force_process.segment_parameters(
            parts.radial_depth_mm[rows], parts.axial_depth_mm[rows]
        )
    bandwidth = np.array([s.feed_drive.bandwidth_rad_s for s in scenarios])
    if scenarios[0].feed_drive.kind == "linuxcnc":  # the chip load behind the axis's lag
        bandwidth_process = np.array([chip_load_bandwidth_rad_s(
            s.feed_drive.linuxcnc, s.feed_drive.bandwidth_rad_s) for s in scenarios])
    else:
        bandwidth_process = bandwidth
    delays = np.array([s.delay_steps for s in scenarios], dtype=np.int64)
    reference = np.array([s.controller.reference_force_N for s in scenarios])
    programmed = np.array([s.controller.programmed_feed_mm_min for s in scenarios])
    seeds = np.array([s.simulation.seed for s in scenarios], dtype=np.uint64)

    first = scenarios[0]
    if first.geometry.enabled:
        geo = GeometricForceOutput(
            first.geometry, first.cutting_coefficients, parts.radial_depth_mm,
            parts.axial_depth_mm, dt,
        )
        monitored = first.tool_breakage.enabled
        process = geo.records(
            gain, pole, bandwidth_process, first.tool_breakage.faults if monitored else None
        )
        cutting = geo.cutting
        safe_feed = np.array([geo.safe_feed_mm_min(reference[i], i) for i in range(runs)])
    else:
        process = force_process_records(gain, pole, bandwidth_process, dt)
        cutting = gain > 0
        safe_feed = safe_feeds_mm_min(reference, gain[:, :nseg])
    travel = list(zip(parts.length_mm.tolist(), safe_feed.tolist(), bandwidth.tolist(),
                      (delays * dt).tolist(), strict=True))  # Python floats: 3 us a run less
    conv_first, conv_of = _distinct(travel)
    conventional = np.array([constant_feed_time_s(*travel[i]) for i in conv_first])[conv_of]

    # --- sensor, controller, drive, metrics ----------------------------------------------
    sensor = force_sensor_records(
        np.array([s.sensor.noise_std_N for s in scenarios]),
        np.array([s.sensor.lowpass_cutoff_hz for s in scenarios]),
        dt,
        seeds,
        noise_ids,
    )
    if first.current_sensing.enabled:
        sensor = feed_current_records(first.current_sensing, sensor, dt, seeds, noise_ids)
    elif first.sensor.kind != "dynamometer":
        # the servo axis's models (and scipy.linalg) are imported by the runs that use them
        from acc.engine.servo_current_sensing import servo_current_sensor_records

        sensor = servo_current_sensor_records(
            first.sensor.kind, sensor, [s.sensor.current_noise_std_A for s in scenarios], dt,
            seeds, noise_ids,
        )
    safe_override = safe_feed / programmed
    ctrl_first, ctrl_of = _distinct(
        [
            (s.controller, s.nominal_plant, safe_override[i] if _uses_safe_feed(s) else None,
             s.design)
            for i, s in enumerate(scenarios)
        ]
    )
    controller = _gathered(
        controller_records(
            [scenarios[i].controller for i in ctrl_first],
            [scenarios[i].nominal_plant for i in ctrl_first],
            sim.control_period_s,
            safe_override[ctrl_first],
            [scenarios[i].design for i in ctrl_first],
        ),
        ctrl_of,
    )
    if first.feed_drive.kind == "servo_axis":
        from controllers.axis.servo_feed_drive import servo_feed_drive_records

        drive = servo_feed_drive_records(delays, dt)
    elif first.feed_drive.kind == "linuxcnc":
        drive = _linuxcnc_records(scenarios, programmed, dt)
    else:
        drive = feed_drive_records(bandwidth, delays, dt)
    threshold = np.maximum(
        np.array([s.metrics.oscillation_threshold_pct for s in scenarios]) / 100.0 * reference,
        3.0 * np.array([s.sensor.noise_std_N for s in scenarios]),
    )
    metrics = metrics_records(
        reference,
        cutting,
        np.array([s.metrics.settling_band_pct for s in scenarios]),
        np.array([s.metrics.divergence_factor for s in scenarios]),
        dt,
        np.array([s.metrics.oscillation_window_s for s in scenarios]),
        np.array(
            [np.inf if s.metrics.force_limit_N is None else s.metrics.force_limit_N
             for s in scenarios]
        ),
        threshold,
        n_max,
        np.array([revolution_steps(s) for s in scenarios], dtype=np.int64),
        np.array([s.metrics.oscillation_decay_ratio for s in scenarios]),
        np.array([s.metrics.overload_tolerance_pct for s in scenarios]),
        [event_marks(s) for s in scenarios],
    )
    monitor = _monitor_records(first, process, seeds, noise_ids, dt, scenarios)
    workpiece = parts.records()
    disturbances = disturbance_records(
        [tuple(getattr(s, "disturbances", ())) for s in scenarios],
        dt,
        [s.geometry.spindle_speed_rpm for s in scenarios],
        [s.geometry.teeth for s in scenarios],
        seeds,
        noise_ids,
    )
    disturbed = any(getattr(s, "disturbances", ()) for s in scenarios)

    # --- the compiled loop, runs shared among threads ----------------------------------
    record = record_every_steps is not None
    every = record_every_steps if record else 0
    n_rec = (n_max + every - 1) // every if record else 0
    traces = np.full((runs, len(force_loop.TRACE_NAMES), n_rec), np.nan)
    trace_segment = np.full((runs, n_rec), -1, dtype=np.int64)
    slots = (
        *workpiece, *process, *disturbances, *sensor, *controller, *drive, *metrics, *monitor
    )
    args = (
        n_max, sim.steps_per_control, every, programmed, reference, slots, traces,
        trace_segment, force_loop.scratch_records(runs),
    )
    return _GroupInputs(
        args, parts, delays, safe_feed, conventional, metrics, monitor, disturbed, every,
        traces, trace_segment,
    )


def _linuxcnc_records(
    scenarios: Sequence[Scenario], programmed_feed_mm_min: NDArray, dt: float
) -> tuple[NDArray, NDArray]:
    """LinuxCNC drives of a group (:mod:`plants.linuxcnc_drive`), one design per distinct
    ``[feed_drive]``, each run at its programmed feed."""
    first, of = _distinct([s.feed_drive.linuxcnc for s in scenarios])
    designs = [linuxcnc_drive_records(scenarios[i].feed_drive.linuxcnc,
                                      programmed_feed_mm_min[of == u], dt)
               for u, i in enumerate(first)]
    params, state = designs[0]
    if len(designs) > 1:  # ring sizes differ with the dead time: the largest for all
        ring = max(d[1].dtype["history_mm_min"].shape[0] for d in designs)
        params, state = LINUXCNC_DRIVE.records(len(scenarios), ring=ring)
        for u, (p, _) in enumerate(designs):
            rows = np.flatnonzero(of == u)
            for name in p.dtype.names:
                params[name][rows] = p[name]
            params["ring_mask"][rows] = ring - 1
        init_states(params, state)
    return params, state


def _monitor_records(
    first: Scenario,
    process: tuple[NDArray, NDArray],
    seeds: NDArray,
    noise_ids: NDArray,
    dt: float,
    scenarios: Sequence[Scenario],
) -> tuple[NDArray, NDArray]:
    """The in-loop breakage monitor of a group (disabled unless ``[tool_breakage]`` is):
    tooth positions from the entry angle of each run's first cutting segment."""
    params = first.tool_breakage
    geo = first.geometry
    runs = len(scenarios)
    if not params.enabled:
        return monitor_off_records(runs)
    entry = np.zeros(runs)
    if params.enabled:
        pp = process[0]
        for r in range(runs):
            entry[r] = pp["entry_rad"][r, int(np.flatnonzero(pp["cutting"][r])[0])]
    from plants.axis.servo_axis import ServoAxisParams

    axis = ServoAxisParams()
    return breakage_monitor_records(
        params, geo.teeth, geo.spindle_speed_rpm, dt, entry,
        axis.force_to_torque_m / axis.torque_constant_Nm_A,
        np.array([s.sensor.current_noise_std_A for s in scenarios]), seeds, noise_ids,
    )


def _uses_safe_feed(scenario: Scenario) -> bool:
    """Whether a run's controller depends on its part's safe feed (the constant feed)."""
    return uses_safe_feed(scenario.controller)


__all__ = ["batch_memory_bytes", "check_batch_memory", "engine_key", "simulate"]
