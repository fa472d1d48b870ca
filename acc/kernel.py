"""Compiled closed-loop kernel: the loop of :mod:`acc.simulator`, one run at a time, in numba.

:func:`simulate_compiled` takes and returns what :func:`acc.simulator.simulate` does and
gives the same numbers (tested to 1e-12 relative on metrics and traces; in practice the
same bits).  The NumPy simulator stays the reference: it defines the loop, and this module
follows it operation for operation, in the same order:

* the per-run parameters (process gain and pole per segment, exact discretisation
  coefficients, resolved controller gains, safe feed, metrics thresholds) are computed by
  the same plant, controller and metrics objects as in :mod:`acc.simulator`;
* the time loop runs per run, in compiled code, with the run's own noise generator
  (``numpy.random.Generator`` used from numba draws the same normals as NumPy);
* per-run accumulators are handed back to :class:`acc.metrics.MetricsAccumulator`, so the
  metric definitions live in one place.

A run stops at its first step that is finished or failed.  The NumPy simulator advances a
batch until every run has stopped, and a run's metrics do not change after it stops; so
without traces each run stops at its own step.  With traces, every run is advanced to the
batch's last step, as the NumPy simulator records them.

Controllers.  Each kind that the kernel can run has a step function (``_pi_step``,
``_constant_step``, and :func:`acc.kernel_robust.robust_step` for ``adaptive_pi``,
``dob_pi`` and ``dob_adaptive_pi`` with the RLS estimator: parameters, state and measured
force in, override out, state updated in place) and a packer in :data:`PACKERS` that turns
the batch controller of :func:`controllers.registry.build_controller` into a parameter array
``(runs, P)`` and an initial state ``(runs, S)``.  Adding a kind is a step function, a branch in
``_controller_step`` and a packer.

Parallelism.  Runs are independent; :func:`simulate_compiled` hands them to ``threads``
threads, and the compiled loop releases the GIL.  Compiled code is cached on disk
(``cache=True``), so only the first call on a machine pays the compile time.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from acc.kernel_robust import pack_robust, robust_step, unsupported_robust
from acc.metrics import MetricsAccumulator, constant_feed_time_s, safe_feed_mm_min
from acc.result import SimulationResult
from acc.scenario import Scenario, ScenarioError
from acc.simulator import _TRACE_NAMES, merge_results
from controllers.pi import ConstantOverride, FeedOverridePI
from controllers.registry import ControllerParams, build_controller, resolved_gains
from controllers.robust_force_controller import DIAGNOSTIC_NAMES, RobustForceController
from plants.feed_drive import FeedDrive
from plants.force_process import ForceProcess
from plants.force_sensor import ForceSensor
from plants.nominal_plant import NominalPlant
from plants.workpiece import WorkpieceBatch

#: Controller codes of the kernel.
PI_CODE = 0
CONSTANT_CODE = 1
ROBUST_CODE = 2
#: Controller diagnostics recorded with the traces (NaN for kinds without them).
N_DIAGNOSTICS = len(DIAGNOSTIC_NAMES)


@numba.njit(cache=True, nogil=True)
def _pi_step(p: NDArray, s: NDArray, y: float, diag: NDArray) -> float:
    """PI with clamping anti-windup (:class:`controllers.pi.FeedOverridePI`).

    ``p = [reference_N, kp, ki, lo, hi, period_s, clamping]``, ``s = [integral]``.
    """
    e = p[0] - y
    i = s[0]
    w = p[1] * e + i
    lo = p[3]
    hi = p[4]
    override = w
    if w < lo:
        override = lo
    elif w > hi:
        override = hi
    di = p[2] * p[5] * e
    if p[6] > 0.5 and (((w > hi) and (e > 0)) or ((w < lo) and (e < 0))):
        di = 0.0
    s[0] = i + di
    return override


@numba.njit(cache=True, nogil=True)
def _constant_step(p: NDArray, s: NDArray, y: float, diag: NDArray) -> float:
    """Fixed override (:class:`controllers.pi.ConstantOverride`), ``p = [override]``."""
    return p[0]


@numba.njit(cache=True, nogil=True)
def _controller_step(code: int, p: NDArray, s: NDArray, y: float, diag: NDArray) -> float:
    """Dispatch on the controller code; ``diag`` receives diagnostics (robust kinds only)."""
    if code == PI_CODE:
        return _pi_step(p, s, y, diag)
    if code == ROBUST_CODE:
        return robust_step(p, s, y, diag)
    return _constant_step(p, s, y, diag)


@numba.njit(cache=True, nogil=True)
def _run_one(
    r: int,
    n_steps: int,
    stop_early: bool,
    m: int,
    rec: int,
    dt: float,
    starts: NDArray,
    length: NDArray,
    gain: NDArray,
    phi_p: NDArray,
    c_v: NDArray,
    c_u: NDArray,
    cutting: NDArray,
    phi_d: NDArray,
    lag: NDArray,
    delay: NDArray,
    history: NDArray,
    sigma: NDArray,
    phi_s: NDArray,
    noise: NDArray,
    code: int,
    cparams: NDArray,
    cstate: NDArray,
    reference: NDArray,
    programmed: NDArray,
    divergence: NDArray,
    band: NDArray,
    sums: NDArray,
    counts: NDArray,
    peak: NDArray,
    enter: NDArray,
    last_out: NDArray,
    last_in: NDArray,
    traces: NDArray,
    trace_segment: NDArray,
) -> None:
    """Advance run ``r`` for up to ``n_steps`` plant steps (see :func:`simulate_compiled`).

    ``noise`` holds the run's standard normal samples, one per step (empty without noise);
    ``sums[r] = [iae, ise]``; ``counts[r] = [cut_steps, finish_step, failed, stop_step]``;
    ``traces[r, i, j]``: the first seven of ``_TRACE_NAMES``, then the diagnostics.  Modulo
    operations of the NumPy loop (control instant, trace sample, delay-line slot) are counters here.
    """
    nseg = starts.shape[1]
    size = history.shape[1]
    d = delay[r]
    ref = reference[r]
    prog = programmed[r]
    div = divergence[r]
    bnd = band[r]
    sig = sigma[r]
    ps = phi_s[r]
    pd = phi_d[r]
    lg = lag[r]
    cp = cparams[r]
    cs = cstate[r]
    diag = np.full(N_DIAGNOSTICS, np.nan)
    v = 0.0
    x = 0.0
    y = 0.0
    position = 0.0
    override = 0.0
    command = 0.0
    head = 0
    tail = (-d) % size  # slot of u[k - d]
    ctrl_count = 0  # steps to the next control instant
    rec_count = 0  # steps to the next trace sample
    jj = 0
    failed = False
    iae = 0.0
    ise = 0.0
    cut_steps = 0
    finish = -1
    stop = n_steps - 1
    # the segment's coefficients and metric accumulators, kept in locals while the tool is
    # in it and written back when it leaves (same values as updating the arrays every step)
    cur = -1
    g = 0.0
    pp = 0.0
    cv = 0.0
    cu = 0.0
    cut = False
    pk = 0.0
    k_in = -1
    k_out = -1
    for k in range(n_steps):
        count = 0
        for j in range(nseg):
            if position >= starts[r, j]:
                count += 1
        seg = max(count - 1, 0)
        if position >= length[r]:
            seg = nseg
        finished = seg == nseg
        if seg != cur:
            if cur >= 0:
                peak[r, cur] = pk
                last_in[r, cur] = k_in
                last_out[r, cur] = k_out
            cur = seg
            g = gain[r, seg]
            pp = phi_p[r, seg]
            cv = c_v[r, seg]
            cu = c_u[r, seg]
            cut = cutting[r, seg]
            pk = peak[r, seg]
            k_out = last_out[r, seg]
            if enter[r, seg] < 0:
                enter[r, seg] = k
        force = g * x
        if not (abs(force) <= div):
            failed = True
        raw = force
        if sig > 0.0:
            raw = force + sig * noise[k]
        y = ps * y + (1.0 - ps) * raw
        if ctrl_count == 0:
            override = _controller_step(code, cp, cs, y, diag)
            command = override * prog
            ctrl_count = m
        ctrl_count -= 1
        # metrics of step k (acc.metrics.MetricsAccumulator.update)
        e = force - ref
        if cut:
            iae += abs(e) * dt
            ise += e * e * dt
            cut_steps += 1
        if math.isnan(pk) or math.isnan(force):
            pk = math.nan
        elif force > pk:
            pk = force
        k_in = k
        if abs(e) > bnd:
            k_out = k
        if finished and finish < 0:
            finish = k
        if rec > 0 and rec_count == 0:
            rec_count = rec
            traces[r, 0, jj] = force
            traces[r, 1, jj] = y
            traces[r, 2, jj] = ref
            traces[r, 3, jj] = override
            traces[r, 4, jj] = command
            traces[r, 5, jj] = v
            traces[r, 6, jj] = position
            for i in range(N_DIAGNOSTICS):
                traces[r, 7 + i, jj] = diag[i]
            trace_segment[r, jj] = seg
            jj += 1
        rec_count -= 1
        if stop_early and (finished or failed):
            stop = k
            break
        # feed drive (plants.feed_drive.FeedDrive.step)
        history[r, head] = command
        delayed = history[r, tail]
        v_k = v
        v = pd * v + (1.0 - pd) * delayed
        travel = (delayed * dt + (v_k - delayed) * lg) / 60.0
        # force process (plants.force_process.ForceProcess.step)
        x = pp * x + cv * v_k + cu * delayed
        position = position + travel
        head += 1
        if head == size:
            head = 0
        tail += 1
        if tail == size:
            tail = 0
    if cur >= 0:
        peak[r, cur] = pk
        last_in[r, cur] = k_in
        last_out[r, cur] = k_out
    sums[r, 0] = iae
    sums[r, 1] = ise
    counts[r, 0] = cut_steps
    counts[r, 1] = finish
    counts[r, 2] = 1 if failed else 0
    counts[r, 3] = stop


@dataclass(frozen=True)
class _LoopOutput:
    """Per-run accumulators of one pass (shapes (runs, ...))."""

    sums: NDArray
    counts: NDArray
    peak: NDArray
    enter: NDArray
    last_out: NDArray
    last_in: NDArray
    traces: NDArray
    trace_segment: NDArray


@dataclass(frozen=True)
class _Loop:
    """Everything the compiled loop needs for a batch (arrays of shape (runs, ...))."""

    m: int
    dt: float
    starts: NDArray
    length: NDArray
    gain: NDArray
    phi_p: NDArray
    c_v: NDArray
    c_u: NDArray
    cutting: NDArray
    phi_d: NDArray
    lag: NDArray
    delay: NDArray
    sigma: NDArray
    phi_s: NDArray
    code: int
    cparams: NDArray
    cstate: NDArray
    reference: NDArray
    programmed: NDArray
    divergence: NDArray
    band: NDArray
    seeds: list[int]
    run_ids: NDArray
    threads: int

    def run(self, n_steps: int, stop_early: bool, rec: int, n_rec: int) -> _LoopOutput:
        """One pass over every run, each from rest; threads take runs in turn (strided)."""
        runs, ncol = self.gain.shape
        history = np.zeros((runs, int(self.delay.max()) + 1))
        cstate = self.cstate.copy()
        out = _LoopOutput(
            sums=np.zeros((runs, 2)),
            counts=np.zeros((runs, 4), dtype=np.int64),
            peak=np.full((runs, ncol), -np.inf),
            enter=np.full((runs, ncol), -1, dtype=np.int64),
            last_out=np.full((runs, ncol), -1, dtype=np.int64),
            last_in=np.full((runs, ncol), -1, dtype=np.int64),
            traces=np.empty((runs, 7 + N_DIAGNOSTICS, n_rec)),
            trace_segment=np.zeros((runs, n_rec), dtype=np.int64),
        )
        no_noise = np.empty(0)

        def one(r: int, buffer: NDArray) -> None:
            noise = no_noise
            if self.sigma[r] > 0:
                # the run's stream (acc.simulator.run_generators), n_steps normals at once,
                # into the thread's own buffer
                seq = np.random.SeedSequence(self.seeds[r], spawn_key=(int(self.run_ids[r]),))
                noise = np.random.default_rng(seq).standard_normal(out=buffer)
            _run_one(
                r, n_steps, stop_early, self.m, rec, self.dt,
                self.starts, self.length, self.gain, self.phi_p, self.c_v, self.c_u,
                self.cutting, self.phi_d, self.lag, self.delay, history,
                self.sigma, self.phi_s, noise, self.code, self.cparams, cstate,
                self.reference, self.programmed, self.divergence, self.band,
                out.sums, out.counts, out.peak, out.enter, out.last_out, out.last_in,
                out.traces, out.trace_segment,
            )  # fmt: skip

        def strided(t: int) -> None:
            buffer = np.empty(n_steps)
            for r in range(t, runs, self.threads):
                one(r, buffer)

        if self.threads <= 1 or runs == 1:
            buffer = np.empty(n_steps)
            for r in range(runs):
                one(r, buffer)
        else:
            with ThreadPoolExecutor(max_workers=self.threads) as pool:
                list(pool.map(strided, range(self.threads)))
        return out


def _pack_pi(ctrl: FeedOverridePI) -> tuple[int, NDArray, NDArray]:
    params = np.column_stack(
        [
            ctrl.reference_force_N,
            ctrl.kp_per_N,
            ctrl.ki_per_N_s,
            ctrl.override_min,
            ctrl.override_max,
            np.full(ctrl.runs, ctrl.control_period_s),
            np.full(ctrl.runs, 1.0 if ctrl.anti_windup == "clamping" else 0.0),
        ]
    )
    return PI_CODE, params, ctrl.init().integral[:, None].copy()


def _pack_constant(ctrl: ConstantOverride) -> tuple[int, NDArray, NDArray]:
    return CONSTANT_CODE, ctrl.override[:, None].copy(), np.zeros((ctrl.runs, 1))


def _pack_robust(ctrl: RobustForceController) -> tuple[int, NDArray, NDArray]:
    why = unsupported_robust(ctrl)
    if why is not None:
        raise NotImplementedError(f"the compiled kernel cannot run {why}; use acc.simulator")
    params, state = pack_robust(ctrl)
    return ROBUST_CODE, params, state


#: Controller classes the kernel runs -> packer (code, params (runs, P), state (runs, S)).
PACKERS: dict[type, Callable[..., tuple[int, NDArray, NDArray]]] = {
    FeedOverridePI: _pack_pi,
    ConstantOverride: _pack_constant,
    RobustForceController: _pack_robust,
}


#: Controller kinds the kernel runs.
KERNEL_KINDS = ("pi", "constant", "adaptive_pi", "dob_pi", "dob_adaptive_pi")
#: Kinds with a gain estimator (the kernel runs its "rls" method).
_ESTIMATING_KINDS = ("adaptive_pi", "dob_adaptive_pi")


def unsupported(scenario: Scenario) -> str | None:
    """Why the kernel cannot run a scenario (None if it can).

    The kernel follows the simulator's loop for the force-process model with the force
    sensor; the geometric force model and force sensing from feed-drive currents (when a
    scenario enables them) and other controller kinds run in :func:`acc.simulator.simulate`.
    """
    if scenario.controller.kind not in KERNEL_KINDS:
        return f"controller.kind {scenario.controller.kind!r} (kernel kinds: {KERNEL_KINDS})"
    if scenario.controller.kind in _ESTIMATING_KINDS and scenario.controller.estimator != "rls":
        return f"controller.estimator {scenario.controller.estimator!r} (kernel: 'rls')"
    for section in ("geometry", "current_sensing"):
        if getattr(getattr(scenario, section, None), "enabled", False):
            return f"[{section}] enabled = true"
    return None


def simulate_compiled(
    scenarios: Scenario | Sequence[Scenario],
    *,
    run_ids: Sequence[int] | None = None,
    record_every_steps: int | None = 1,
    threads: int | None = None,
) -> SimulationResult:
    """Simulate a batch with the compiled kernel; same contract as :func:`acc.simulator.simulate`.

    Parameters
    ----------
    scenarios : Scenario or sequence of Scenario, length runs
    run_ids : sequence of int, shape (runs,), optional
    record_every_steps : int or None
        Trace decimation in plant steps; None records no traces.
    threads : int or None
        Threads that run the compiled loop (default: all cores).

    Returns
    -------
    SimulationResult
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
    if record_every_steps is not None and record_every_steps < 1:
        raise ValueError("record_every_steps must be >= 1 or None")
    for s in scenarios:
        why = unsupported(s)
        if why is not None:
            raise NotImplementedError(f"the compiled kernel cannot run {why}; use acc.simulator")
    n_threads = (os.cpu_count() or 1) if threads is None else threads
    if n_threads < 1:
        raise ValueError(f"threads must be >= 1, got {n_threads}")
    kinds = sorted({s.controller.kind for s in scenarios})
    if len(kinds) == 1:
        return _one_kind(scenarios, ids, record_every_steps, n_threads)
    groups = [[i for i, s in enumerate(scenarios) if s.controller.kind == k] for k in kinds]
    parts = [
        _one_kind([scenarios[i] for i in g], ids[g], record_every_steps, n_threads) for g in groups
    ]
    return merge_results(parts, groups)


def _shared(scenarios: Sequence[Scenario], attr: str) -> float:
    values = {getattr(s.simulation, attr) for s in scenarios}
    if len(values) != 1:
        raise ScenarioError(f"simulation.{attr} must be the same for every run of a batch")
    return values.pop()


@functools.lru_cache(maxsize=1024)
def packed_controller(
    params: ControllerParams,
    nominal: NominalPlant,
    control_period_s: float,
    safe_override: float,
) -> tuple[int, NDArray, NDArray]:
    """Kernel code, parameter row and initial state row of one run's controller.

    Built by :func:`controllers.registry.build_controller` and a packer of :data:`PACKERS`;
    memoised per parameter set (the controller design and the observer's and estimator's
    discretisations are done once per set, not once per call).  The rows are read-only.
    """
    controller = build_controller([params], [nominal], control_period_s, np.array([safe_override]))
    packer = PACKERS.get(type(controller))
    if packer is None:
        raise NotImplementedError(
            f"the compiled kernel has no controller kind {params.kind!r}; use acc.simulator"
        )
    code, cparams, cstate = packer(controller)
    rows = (cparams[0].copy(), cstate[0].copy())
    for row in rows:
        row.flags.writeable = False
    return code, *rows


def _stack_rows(rows: Sequence[NDArray]) -> NDArray:
    """Rows of possibly different lengths as one zero-padded array (runs, max length).

    Each run's layout (ring sizes, filter orders) is read from its own parameter row, so
    padding at the end is never read.
    """
    out = np.zeros((len(rows), max(len(r) for r in rows)))
    for i, row in enumerate(rows):
        out[i, : len(row)] = row
    return out


def _distinct(keys: Sequence[object]) -> tuple[list[int], NDArray[np.intp]]:
    """First index of each distinct hashable key, and the distinct number of every key."""
    seen: dict[object, int] = {}
    first: list[int] = []
    of = np.empty(len(keys), dtype=np.intp)
    for i, key in enumerate(keys):
        u = seen.setdefault(key, len(first))
        if u == len(first):
            first.append(i)
        of[i] = u
    return first, of


def _one_kind(
    scenarios: list[Scenario], ids: NDArray[np.int64], record_every_steps: int | None, threads: int
) -> SimulationResult:
    runs = len(scenarios)
    dt = _shared(scenarios, "plant_step_s")
    _shared(scenarios, "control_period_s")
    _shared(scenarios, "time_limit_s")
    sim = scenarios[0].simulation
    m = sim.steps_per_control
    n_max = sim.max_steps

    # --- per-run parameters: as in acc.simulator, once per distinct set of inputs ------
    parts = WorkpieceBatch([s.workpiece for s in scenarios])
    nseg = parts.segments
    proc_first, proc_of = _distinct([(s.force_process, s.workpiece) for s in scenarios])
    gain_u = np.empty((len(proc_first), nseg + 1))
    pole_u = np.empty((len(proc_first), nseg + 1))
    for u, i in enumerate(proc_first):
        gain_u[u], pole_u[u] = scenarios[i].force_process.segment_parameters(
            parts.radial_depth_mm[i]
        )
    gain = gain_u[proc_of]
    pole = pole_u[proc_of]
    bandwidth = np.array([s.feed_drive.bandwidth_rad_s for s in scenarios])
    delays = np.array([s.delay_steps for s in scenarios], dtype=np.int64)
    reference = np.array([s.controller.reference_force_N for s in scenarios])
    programmed = np.array([s.controller.programmed_feed_mm_min for s in scenarios])
    feed_first, feed_of = _distinct(
        [(proc_of[i], reference[i], bandwidth[i], delays[i]) for i in range(runs)]
    )
    safe_u = np.array([safe_feed_mm_min(reference[i], gain[i, :nseg]) for i in feed_first])
    conventional_u = np.array(
        [
            constant_feed_time_s(parts.length_mm[i], safe_u[u], bandwidth[i], delays[i] * dt)
            for u, i in enumerate(feed_first)
        ]
    )
    safe_feed = safe_u[feed_of]
    conventional = conventional_u[feed_of]
    drive = FeedDrive(bandwidth, delays, dt, runs)
    process = ForceProcess(gain, pole, bandwidth, dt)
    sensor = ForceSensor(
        np.array([s.sensor.noise_std_N for s in scenarios]),
        np.array([s.sensor.lowpass_cutoff_hz for s in scenarios]),
        dt,
    )
    safe_override = safe_feed / programmed
    ctrl_first, ctrl_of = _distinct(
        [(s.controller, s.nominal_plant, safe_override[i]) for i, s in enumerate(scenarios)]
    )
    packed = [
        packed_controller(
            scenarios[i].controller,
            scenarios[i].nominal_plant,
            sim.control_period_s,
            float(safe_override[i]),
        )
        for i in ctrl_first
    ]
    code = packed[0][0]
    cparams = _stack_rows([pk[1] for pk in packed])[ctrl_of]
    cstate = _stack_rows([pk[2] for pk in packed])[ctrl_of]
    metrics = MetricsAccumulator(
        reference,
        gain > 0,
        np.array([s.metrics.settling_band_pct for s in scenarios]),
        dt,
    )
    divergence = reference * np.array([s.metrics.divergence_factor for s in scenarios])

    # --- the compiled loop, run by run -------------------------------------------------
    loop = _Loop(
        m=m,
        dt=dt,
        starts=np.ascontiguousarray(parts.segment_start_mm),
        length=parts.length_mm,
        gain=np.ascontiguousarray(process.static_gain_N_per_mm_min),
        phi_p=np.ascontiguousarray(process.phi),
        c_v=np.ascontiguousarray(process.c_v),
        c_u=np.ascontiguousarray(process.c_u),
        cutting=np.ascontiguousarray(metrics.cutting),
        phi_d=drive.phi,
        lag=drive.lag_integral_s,
        delay=drive.delay_steps,
        sigma=sensor.noise_std_N,
        phi_s=sensor.phi,
        code=code,
        cparams=np.ascontiguousarray(cparams),
        cstate=cstate,
        reference=reference,
        programmed=programmed,
        divergence=divergence,
        band=metrics.band,
        seeds=[s.simulation.seed for s in scenarios],
        run_ids=ids,
        threads=threads,
    )
    out = loop.run(n_max, stop_early=True, rec=0, n_rec=0)
    k_end = int(out.counts[:, 3].max())
    record = record_every_steps is not None
    n_done = 0
    if record:
        n_done = k_end // record_every_steps + 1
        out = loop.run(k_end + 1, stop_early=False, rec=record_every_steps, n_rec=n_done)
    sums, counts, traces, trace_segment = out.sums, out.counts, out.traces, out.trace_segment

    # --- metrics through the one definition --------------------------------------------
    metrics.iae = sums[:, 0].copy()
    metrics.ise = sums[:, 1].copy()
    metrics.cut_steps = counts[:, 0].copy()
    metrics.finish_step = counts[:, 1].copy()
    metrics.peak = out.peak
    metrics.enter_step = out.enter
    metrics.last_out_step = out.last_out
    metrics.last_step_in = out.last_in
    failed = counts[:, 2].astype(bool)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        result_metrics = metrics.result(nseg)
        result_metrics = {k_: np.where(failed, np.nan, v) for k_, v in result_metrics.items()}
        result_metrics["conventional_time_s"] = conventional
        result_metrics["productivity_gain_pct"] = 100.0 * (
            conventional / result_metrics["machining_time_s"] - 1.0
        )
    result_metrics["failed"] = failed.copy()

    gains_first, gains_of = _distinct([(s.controller, s.nominal_plant) for s in scenarios])
    gains_u = [
        resolved_gains(scenarios[i].controller, scenarios[i].nominal_plant, sim.control_period_s)
        for i in gains_first
    ]
    gains = [gains_u[u] for u in gains_of]
    parameters = {
        "kp_per_N": np.array([g.kp_per_N for g in gains]),
        "ki_per_N_s": np.array([g.ki_per_N_s for g in gains]),
        "design_crossover_rad_s": np.array([g.crossover_rad_s for g in gains]),
        "dead_time_steps": delays.astype(float),
        "safe_feed_mm_min": safe_feed,
    }
    signals: dict[str, NDArray] = {}
    if record:
        rows = np.arange(runs)[:, None]
        for i, name in enumerate(_TRACE_NAMES[:7]):
            signals[name] = traces[:, i, :n_done].copy()
        signals["radial_depth_mm"] = parts.radial_depth_mm[rows, trace_segment]
        signals["axial_depth_mm"] = parts.axial_depth_mm[rows, trace_segment]
        for i, name in enumerate(DIAGNOSTIC_NAMES):
            signals[name] = traces[:, 7 + i, :n_done].copy()
    step_index = np.arange(n_done) * (record_every_steps or 1)
    return SimulationResult(
        time_s=step_index * dt,
        signals=signals,
        metrics=result_metrics,
        scenarios=tuple(scenarios),
        run_ids=ids,
        parameters=parameters,
    )


__all__ = ["KERNEL_KINDS", "PACKERS", "simulate_compiled", "unsupported"]
