"""Fixed-step, two-rate, batch-first simulator of the closed cutting-force loop.

Clock.  Plant step ``dt``; step ``k`` is at ``t_k = k dt`` (an integer clock, never an
accumulated float).  The controller runs every ``m = T_c / dt`` steps, at ``k = 0, m, 2m, ...``
and its override is held until the next control instant (zero-order hold).

One plant step ``k``, for every run at once (arrays of shape ``(runs,)``):

1. the workpiece segment from the tool position ``p_k``: the depths the tool meets;
2. the force ``f_k = G(segment) x_k`` and its measurement ``y_k`` (noise, low-pass);
3. at a control instant: ``override = controller(y_k)``, ``u = override x F_prog``;
4. metrics of step ``k``; the trace sample, if recorded;
5. the feed drive (Eq. 6: delay line of whole steps, exact lag) and the chip-load state
   (Eq. 7, exact given the drive's lag) advance to ``k + 1``; the position by the exact
   travel.

The only approximation is that the depth is constant over a plant step.  For a constant
depth the loop is the exact sampled-data system (tested against python-control).

A run whose force leaves ``[-D r, D r]`` (``D`` = ``metrics.divergence_factor``) or becomes
non-finite is marked failed; the batch carries on.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from acc.metrics import MetricsAccumulator, constant_feed_time_s, safe_feed_mm_min
from acc.result import SimulationResult
from acc.scenario import Scenario, ScenarioError
from controllers.registry import build_controller, resolved_gains
from controllers.robust_force_controller import DIAGNOSTIC_NAMES
from plants.current_sensor import FeedCurrentForceSensor, identify_feed_drives
from plants.feed_drive import FeedDrive
from plants.force_process import ForceProcess
from plants.force_sensor import ForceSensor
from plants.geometric_process import GeometricForceOutput
from plants.motor_drive import BallScrew, ServoMotor
from plants.workpiece import WorkpieceBatch

#: Plant steps of sensor noise drawn from each run's generator at a time.
NOISE_BLOCK_STEPS = 1024


def _shared(scenarios: Sequence[Scenario], attr: str) -> float:
    values = {getattr(s.simulation, attr) for s in scenarios}
    if len(values) != 1:
        raise ScenarioError(f"simulation.{attr} must be the same for every run of a batch")
    return values.pop()


def _uniform(scenarios: Sequence[Scenario], section: str):
    """A section that must be the same for every run of a batch."""
    values = [getattr(s, section) for s in scenarios]
    if any(v != values[0] for v in values[1:]):
        raise ScenarioError(f"[{section}] must be the same for every run of a batch")
    return values[0]


def identification_generators(
    scenarios: Sequence[Scenario], run_ids: NDArray
) -> list[np.random.Generator]:
    """Per-run generators for the air-cut identification, ``spawn_key=(run_id, 1)``.

    Separate from the runs' in-loop noise streams, and like them independent of the batch.
    """
    return [
        np.random.default_rng(np.random.SeedSequence(s.simulation.seed, spawn_key=(int(r), 1)))
        for s, r in zip(scenarios, run_ids, strict=True)
    ]


def run_generators(scenarios: Sequence[Scenario], run_ids: NDArray) -> list[np.random.Generator]:
    """One generator per run, ``SeedSequence(seed, spawn_key=(run_id,))``.

    This is child ``run_id`` of ``SeedSequence(seed).spawn(...)``, so a run's numbers do not
    depend on the batch it is simulated in.
    """
    return [
        np.random.default_rng(np.random.SeedSequence(s.simulation.seed, spawn_key=(int(r),)))
        for s, r in zip(scenarios, run_ids, strict=True)
    ]


def simulate(
    scenarios: Scenario | Sequence[Scenario],
    *,
    run_ids: Sequence[int] | None = None,
    record_every_steps: int | None = 1,
) -> SimulationResult:
    """Simulate a batch of closed-loop runs that share a time grid.

    Runs with different controller kinds are simulated kind by kind and merged back in the
    given order; a run's numbers do not depend on which other runs share its batch.

    Parameters
    ----------
    scenarios : Scenario or sequence of Scenario, length runs
        One scenario per run.  Plant step, control period and time limit must agree.
    run_ids : sequence of int, shape (runs,), optional
        Campaign index of each run (default ``0 .. runs-1``); selects the run's random stream.
    record_every_steps : int or None
        Record the signals every this many plant steps; None records no traces (metrics
        only).

    Returns
    -------
    SimulationResult
        Signals of runs that stopped earlier than others are padded with NaN.
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
    kinds = sorted({s.controller.kind for s in scenarios})
    if len(kinds) == 1:
        return _simulate_one_kind(scenarios, ids, record_every_steps)
    groups = [[i for i, s in enumerate(scenarios) if s.controller.kind == k] for k in kinds]
    parts = [
        _simulate_one_kind([scenarios[i] for i in g], ids[g], record_every_steps) for g in groups
    ]
    return merge_results(parts, groups)


def merge_results(
    parts: Sequence[SimulationResult], positions: Sequence[Sequence[int]]
) -> SimulationResult:
    """Merge results of disjoint runs back into one, run ``positions[g][j]`` from part ``g``.

    Time axes must share the step; shorter ones are padded with NaN signals.
    """
    runs = sum(len(p) for p in positions)
    longest = max(parts, key=lambda r: len(r.time_s))
    n = len(longest.time_s)
    order = np.concatenate([np.asarray(p, dtype=np.int64) for p in positions])
    inverse = np.empty(runs, dtype=np.int64)
    inverse[order] = np.arange(runs)

    def stack(name: str, attr: str, width: int | None) -> np.ndarray:
        blocks = []
        for r in parts:
            table = getattr(r, attr)
            if name in table:
                a = np.asarray(table[name])
            elif width is not None:
                a = np.full((r.runs, 0), np.nan)
            else:
                a = np.full((r.runs,), np.nan)
            if width is not None:
                pad = np.full((r.runs, width), np.nan)
                pad[:, : a.shape[1]] = a
                a = pad
            blocks.append(a)
        return np.concatenate(blocks)[inverse]

    def names(attr: str) -> list[str]:
        out: list[str] = []
        for r in parts:
            out += [k for k in getattr(r, attr) if k not in out]
        return out

    scenarios = [sc for r in parts for sc in r.scenarios]
    return SimulationResult(
        time_s=longest.time_s,
        signals={k: stack(k, "signals", n) for k in names("signals")},
        metrics={k: stack(k, "metrics", None) for k in names("metrics")},
        scenarios=tuple(scenarios[j] for j in inverse),
        run_ids=np.concatenate([r.run_ids for r in parts])[inverse],
        parameters={k: stack(k, "parameters", None) for k in names("parameters")},
    )


def _simulate_one_kind(
    scenarios: list[Scenario],
    ids: NDArray[np.int64],
    record_every_steps: int | None,
) -> SimulationResult:
    """Simulate runs that share one controller kind (see :func:`simulate`)."""
    runs = len(scenarios)
    if record_every_steps is not None and record_every_steps < 1:
        raise ValueError("record_every_steps must be >= 1 or None")

    dt = _shared(scenarios, "plant_step_s")
    _shared(scenarios, "control_period_s")
    _shared(scenarios, "time_limit_s")
    sim = scenarios[0].simulation
    m = sim.steps_per_control
    n_max = sim.max_steps

    # --- per-run parameters, computed once -------------------------------------------
    parts = WorkpieceBatch([s.workpiece for s in scenarios])
    nseg = parts.segments
    gain = np.empty((runs, nseg + 1))
    pole = np.empty((runs, nseg + 1))
    for i, s in enumerate(scenarios):
        gain[i], pole[i] = s.force_process.segment_parameters(parts.radial_depth_mm[i])
    bandwidth = np.array([s.feed_drive.bandwidth_rad_s for s in scenarios])
    delays = np.array([s.delay_steps for s in scenarios], dtype=np.int64)
    reference = np.array([s.controller.reference_force_N for s in scenarios])
    programmed = np.array([s.controller.programmed_feed_mm_min for s in scenarios])
    geometry = _uniform(scenarios, "geometry") if scenarios[0].geometry.enabled else None
    if geometry is not None:
        geo = GeometricForceOutput(
            geometry,
            _uniform(scenarios, "cutting_coefficients"),
            parts.radial_depth_mm,
            parts.axial_depth_mm,
            dt,
        )
        cutting = geo.cutting
        safe_feed = np.array([geo.safe_feed_mm_min(reference[i], i) for i in range(runs)])
    else:
        geo = None
        cutting = gain > 0
        safe_feed = np.array([safe_feed_mm_min(reference[i], gain[i, :nseg]) for i in range(runs)])
    conventional = np.array(
        [
            constant_feed_time_s(parts.length_mm[i], safe_feed[i], bandwidth[i], delays[i] * dt)
            for i in range(runs)
        ]
    )

    drive = FeedDrive(bandwidth, delays, dt, runs)
    process = ForceProcess(gain, pole, bandwidth, dt)
    sensor = ForceSensor(
        np.array([s.sensor.noise_std_N for s in scenarios]),
        np.array([s.sensor.lowpass_cutoff_hz for s in scenarios]),
        dt,
    )
    controller = build_controller(
        [s.controller for s in scenarios],
        [s.nominal_plant for s in scenarios],
        sim.control_period_s,
        safe_feed / programmed,
    )
    sensing = _uniform(scenarios, "current_sensing")
    current_sensor = (
        FeedCurrentForceSensor(
            sensing,
            identify_feed_drives(
                sensing,
                ServoMotor(),
                BallScrew(),
                dt,
                identification_generators(scenarios, ids),
            ),
            dt,
        )
        if sensing.enabled
        else None
    )
    metrics = MetricsAccumulator(
        reference,
        cutting,
        np.array([s.metrics.settling_band_pct for s in scenarios]),
        dt,
    )
    divergence = reference * np.array([s.metrics.divergence_factor for s in scenarios])

    # --- traces -------------------------------------------------------------------------
    record = record_every_steps is not None
    n_rec = (n_max + record_every_steps - 1) // record_every_steps if record else 0
    names = _TRACE_NAMES + DIAGNOSTIC_NAMES
    names += ("feed_current_A",) if current_sensor is not None else ()
    has_diagnostics = hasattr(controller, "diagnostics")
    diagnostics = {name: np.full(runs, np.nan) for name in DIAGNOSTIC_NAMES}
    traces = {name: np.empty((runs, n_rec)) for name in names} if record else {}

    # --- random streams: per block, each run draws its force noise, then current noise --
    current_noisy = current_sensor is not None and current_sensor.noise_std_A > 0
    any_noise = sensor.noisy or current_noisy
    gens = run_generators(scenarios, ids) if any_noise else []
    force_noise = np.zeros((runs, NOISE_BLOCK_STEPS))
    current_noise = np.zeros((runs, NOISE_BLOCK_STEPS))
    current_state = current_sensor.init() if current_sensor is not None else None
    feed_current = np.zeros(runs)

    # --- the loop -----------------------------------------------------------------------
    drive_state = drive.init(0.0)
    process_state = process.init(0.0)
    sensor_state = sensor.init(0.0)
    ctrl_state = controller.init()
    position = np.zeros(runs)
    override = np.zeros(runs)
    command = np.zeros(runs)
    failed = np.zeros(runs, dtype=bool)
    rows = np.arange(runs)
    k = 0
    n_done = 0
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(n_max):
            segment = parts.segment(position)
            finished = segment == nseg
            if geo is None:
                force = process.force_N(process_state, segment)
                feed_force = force
            else:
                force, feed_force = geo.forces(process_state.chip_load_mm_min, segment, k)
            failed |= ~(np.abs(force) <= divergence)
            b = k % NOISE_BLOCK_STEPS
            if any_noise and b == 0:
                for r in range(runs):
                    if sensor.noise_std_N[r] > 0:
                        force_noise[r] = gens[r].standard_normal(NOISE_BLOCK_STEPS)
                    if current_noisy:
                        current_noise[r] = gens[r].standard_normal(NOISE_BLOCK_STEPS)
            sensed = force
            if current_sensor is not None:
                current_state, sensed, feed_current = current_sensor.step(
                    current_state,
                    feed_force,
                    drive_state.velocity_mm_min,
                    current_noise[:, b] if current_noisy else None,
                )
            sensor_state, measured = sensor.step(
                sensor_state, sensed, force_noise[:, b] if sensor.noisy else None
            )
            if k % m == 0:
                ctrl_state, override = controller.step(ctrl_state, measured)
                command = override * programmed
                if has_diagnostics and record:
                    diagnostics = controller.diagnostics(ctrl_state)
            metrics.update(k, force, segment, finished)
            if record and k % record_every_steps == 0:
                j = k // record_every_steps
                traces["force_N"][:, j] = force
                traces["measured_force_N"][:, j] = measured
                traces["reference_force_N"][:, j] = reference
                traces["override"][:, j] = override
                traces["commanded_feed_mm_min"][:, j] = command
                traces["feed_velocity_mm_min"][:, j] = drive_state.velocity_mm_min
                traces["position_mm"][:, j] = position
                traces["radial_depth_mm"][:, j] = parts.radial_depth_mm[rows, segment]
                traces["axial_depth_mm"][:, j] = parts.axial_depth_mm[rows, segment]
                if current_sensor is not None:
                    traces["feed_current_A"][:, j] = feed_current
                for name in DIAGNOSTIC_NAMES:
                    traces[name][:, j] = diagnostics[name]
                n_done = j + 1
            if np.all(finished | failed):
                break
            drive_state, out = drive.step(drive_state, command)
            process_state, _ = process.step(
                process_state, segment, out.velocity_mm_min, out.delayed_command_mm_min
            )
            position = position + out.travel_mm

    result_metrics = metrics.result(nseg)
    result_metrics = {k_: np.where(failed, np.nan, v) for k_, v in result_metrics.items()}
    result_metrics["conventional_time_s"] = conventional
    result_metrics["productivity_gain_pct"] = 100.0 * (
        conventional / result_metrics["machining_time_s"] - 1.0
    )
    result_metrics["failed"] = failed.copy()

    gains = [resolved_gains(s.controller, s.nominal_plant, sim.control_period_s) for s in scenarios]
    parameters = {
        "kp_per_N": np.array([g.kp_per_N for g in gains]),
        "ki_per_N_s": np.array([g.ki_per_N_s for g in gains]),
        "design_crossover_rad_s": np.array([g.crossover_rad_s for g in gains]),
        "dead_time_steps": delays.astype(float),
        "safe_feed_mm_min": safe_feed,
    }
    step_index = np.arange(n_done) * (record_every_steps or 1)
    return SimulationResult(
        time_s=step_index * dt,
        signals={name: arr[:, :n_done].copy() for name, arr in traces.items()},
        metrics=result_metrics,
        scenarios=tuple(scenarios),
        run_ids=ids,
        parameters=parameters,
    )


_TRACE_NAMES = (
    "force_N",
    "measured_force_N",
    "reference_force_N",
    "override",
    "commanded_feed_mm_min",
    "feed_velocity_mm_min",
    "position_mm",
    "radial_depth_mm",
    "axial_depth_mm",
)

__all__ = ["NOISE_BLOCK_STEPS", "run_generators", "simulate"]
