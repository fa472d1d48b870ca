"""Benchmark of the closed cutting-force loop: compiled engine, sweeps, python-control.

Run on demand (never in the test suite)::

    python benchmarks/bench_loop.py                  # everything, prints a Markdown report
    python benchmarks/bench_loop.py --write benchmarks/RESULTS.md
    python benchmarks/bench_loop.py --only throughput single compile sweep

The loop is Kim & Chung's (experiments/kim_chung_2001.toml: 1 ms plant step, 10 ms control
period, 0.1 s dead time) with the adaptive PI + disturbance observer (``dob_adaptive_pi``,
RLS estimator) and, for comparison, the fixed-gain PI, on a part long enough that every run
lasts the whole 30 s (so each run is exactly 30 000 plant steps).  Parts:

``throughput``  ``acc.simulate``, 1e4 identical runs, metrics only, all cores; with and
                without sensor noise
``single``      one 30 s run, one thread (median of repeated calls)
``compile``     every built-in kind, the geometric force model and current sensing, in a
                fresh process with an empty numba cache, and again with the cache warm
``sweep``       ``acc sweep`` (a subprocess, imports included) of 1e4 ``dob_adaptive_pi`` runs
                with random radial and axial depths per segment, metrics only, 2 workers,
                beside the engine's own throughput on identical runs measured just before
``control``     the same loop built from python-control ``nlsys`` blocks with ``interconnect``
                and simulated by ``input_output_response`` (one run; checked against ours)
``memory``      a 1e5-run dob_adaptive_pi campaign, metrics only, ``acc sweep``: peak
                resident memory of the whole process tree
``limit``       the hand-fused numba loop of ``../shared/bench/limit_kernel.py`` (the same
                observer + adaptive PI force loop, written as one function: what this
                machine can do for it) beside ``acc.simulate`` of ``dob_adaptive_pi`` with the
                default output-error estimator and with ``estimator = "rls"``, the same runs
                of 30 s, all cores, noise-free, in fresh processes; the three alternate
                within each repeat, and the ratios are of the medians.  ``--baseline DIR``
                measures an older source tree the same way, its probes alternating with
                this tree's (before/after in one run); ``--limit-cpu``: one thread each
                side and rates per CPU second (on a shared machine the wall-clock ratio of
                one repeat ranges over +-20 %; the CPU-second ratio over a few %)
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_report import wait_sampling_memory  # noqa: E402

SCENARIO = ROOT / "experiments" / "kim_chung_2001.toml"
#: A part long enough that no run finishes within the time limit: every run is 30 000 steps.
CHANGES = {
    "simulation.time_limit_s": 30.0,
    "workpiece.segment_length_mm": [40.0, 40.0, 40.0],
}


#: Controller kinds benchmarked: the adaptive PI with disturbance observer, and the PI.
KINDS = ("dob_adaptive_pi", "pi")


def base_scenario(noise_std_N: float = 5.0, kind: str = "dob_adaptive_pi"):  # noqa: ANN201
    """The benchmark scenario (sensor noise 5 N per step by default, as the shipped file)."""
    from acc.scenarios.force import load_scenario

    return load_scenario(SCENARIO).with_values(
        {**CHANGES, "sensor.noise_std_N": noise_std_N, "controller.kind": kind}
    )


def _steps(result) -> int:  # noqa: ANN001
    """Run-steps simulated: every run lasts the whole time limit (checked)."""
    m = result.metrics
    assert not np.any(m["failed"]), "a benchmark run failed"
    assert np.all(np.isnan(m["machining_time_s"])), "a run finished early"
    return result.runs * result.scenarios[0].simulation.max_steps


def bench_throughput(runs: int) -> dict[str, float]:
    """``acc.simulate``, ``runs`` identical runs, metrics only, all cores."""
    from acc.engine.simulate import simulate

    out = {}
    variants = [
        (kind, noise, label, {})
        for kind in KINDS
        for noise, label in ((0.0, "noise-free"), (5.0, "noisy"))
    ]
    # the default estimator (output error, 48 candidate poles) against the equation-error RLS
    variants.insert(
        2, ("dob_adaptive_pi", 5.0, "noisy, rls estimator", {"controller.estimator": "rls"})
    )
    for kind, noise, label, extra in variants:
        base = base_scenario(noise, kind).with_values(extra)
        simulate([base, base], record_every_steps=None)  # compiled / loaded
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            result = simulate([base] * runs, record_every_steps=None)
            times.append(time.perf_counter() - t0)
        out[f"{kind}: throughput, {runs} runs, {label} [run-steps/s]"] = _steps(result) / (
            statistics.median(times)
        )
    return out


def bench_single(repeats: int = 30) -> dict[str, float]:
    """One 30 s run, one thread: median over repeated calls (same and new parameters)."""
    from acc.engine.simulate import simulate

    out = {}
    for kind in KINDS:
        for noise, label in ((0.0, "noise-free"), (5.0, "noisy")):
            base = base_scenario(noise, kind)
            simulate(base, record_every_steps=None, threads=1)
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                simulate(base, record_every_steps=None, threads=1)
                times.append(time.perf_counter() - t0)
            out[f"{kind}: single 30 s run, {label} [ms]"] = 1e3 * statistics.median(times)
        times = []
        for i in range(repeats):
            fresh = base_scenario(5.0, kind).with_values(
                {"controller.reference_force_N": 500.0 + 1e-3 * (i + 1)}
            )
            t0 = time.perf_counter()
            simulate(fresh, record_every_steps=None, threads=1)
            times.append(time.perf_counter() - t0)
        out[f"{kind}: single 30 s run, new controller parameters (design included) [ms]"] = (
            1e3 * statistics.median(times)
        )
        shipped = base_scenario(5.0, "pi").with_values({"simulation.time_limit_s": 60.0})
        shipped = shipped.with_values({"workpiece.segment_length_mm": [20.0, 20.0, 20.0]})
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate(shipped, record_every_steps=1, threads=1)
        times.append(time.perf_counter() - t0)
    out["shipped scenario (kim_chung_2001.toml) with traces, as acc run [ms]"] = (
        1e3 * statistics.median(times)
    )
    return out


_COMPILE_PROBE = textwrap.dedent(
    """
    import time
    t0 = time.perf_counter()
    from acc.scenarios.force import load_scenario
    from acc.engine.simulate import simulate
    from controllers.registry import controller_kinds
    base = load_scenario({scenario!r}).with_values({{"simulation.time_limit_s": 0.05}})
    variants = [base.with_values({{"controller.kind": k}}) for k in controller_kinds()]
    variants.append(load_scenario({geometric!r}).with_values({{"simulation.time_limit_s": 0.05}}))
    variants.append(variants[-1].with_values({{"geometry.tooth_passing": True}}))
    t1 = time.perf_counter()
    for sc in variants:
        simulate(sc, record_every_steps=1, threads=1)
        simulate(sc, record_every_steps=None, threads=1)
    print(t1 - t0, time.perf_counter() - t1)
    """
)


def bench_compile() -> dict[str, float]:
    """Every built-in kind, the geometric model (average and tooth passing) and current
    sensing, in a fresh process: with an empty numba cache, then with the cache warm."""
    code = _COMPILE_PROBE.format(
        scenario=str(SCENARIO),
        geometric=str(ROOT / "experiments" / "current_sensing_geometric.toml"),
    )
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("empty cache", "warm cache"):
            done = subprocess.run(
                [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
            )
            imports, compile_s = (float(x) for x in done.stdout.split())
            out[f"compile of every kind and force model, {label} [s]"] = compile_s
        out["import acc (scenario, engine) [s]"] = imports
    return out


SWEEP_CAMPAIGN = """
[campaign]
name = "sweep_speed"
base = "{scenario}"
seed = 5
samples_per_point = {runs}
chunk_runs = 250

[set]
simulation.time_limit_s = 30.0
workpiece.segment_length_mm = [40.0, 40.0, 40.0]
controller.kind = "dob_adaptive_pi"

[random]
workpiece.radial_depth_mm = {{ dist = "uniform", low = 2.0, high = 4.0, size = 3 }}
workpiece.axial_depth_mm = {{ dist = "uniform", low = 5.0, high = 15.0, size = 3 }}
"""


def bench_sweep(runs: int) -> dict[str, float]:
    """``acc sweep`` (2 workers, metrics only, figures included) against the engine on
    identical runs, in the same benchmark run."""
    from acc.engine.simulate import simulate

    base = base_scenario(5.0, "dob_adaptive_pi")
    simulate([base, base], record_every_steps=None)
    t0 = time.perf_counter()
    result = simulate([base] * runs, record_every_steps=None)
    engine = _steps(result) / (time.perf_counter() - t0)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "sweep.toml"
        path.write_text(SWEEP_CAMPAIGN.format(scenario=SCENARIO, runs=runs), encoding="utf-8")
        cmd = [sys.executable, "-m", "acc.cli.main", "sweep", str(path), "--out",
               str(Path(d) / "out"), "--workers", "2", "--no-progress"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        seconds = time.perf_counter() - t0
        rows = sum(1 for _ in (Path(d) / "out" / "summary.csv").open()) - 1
    assert rows == runs
    sweep = runs * base.simulation.max_steps / seconds
    return {
        f"engine on {runs} identical dob_adaptive_pi runs [run-steps/s]": engine,
        f"acc sweep of {runs} dob_adaptive_pi runs, random depths, 2 workers [run-steps/s]": sweep,
        f"acc sweep of {runs} runs: wall time, imports and report included [s]": seconds,
        "acc sweep / engine throughput [-] (target >= 0.5)": sweep / engine,
    }


def control_loop(scenario):  # noqa: ANN001, ANN201
    """The loop as python-control ``nlsys`` blocks, connected by signal names.

    Blocks (discrete time, step ``dt``): ``cutting`` (feed drive with its dead-time delay
    line, chip-load state, tool position; output the force), ``sensor`` (noise and
    low-pass; output the measured force), ``controller`` (the scenario's controller every
    ``m`` steps, held in between; output the commanded feed).  Same exact discretisation as
    the engine, written here again for python-control; the controller is the engine's
    compiled element, its state record carried in the block's state vector.

    Returns
    -------
    control.InterconnectedSystem
        Input ``noise`` (standard normal per step); outputs ``force``, ``measured``,
        ``command``.
    """
    import control

    from acc.engine.element import step_runs
    from acc.engine.metrics import safe_feed_mm_min
    from controllers.registry import controller_records
    from plants.force_process import cascade_coefficients

    dt = scenario.simulation.plant_step_s
    m = scenario.simulation.steps_per_control
    n_delay = scenario.delay_steps
    a = scenario.feed_drive.bandwidth_rad_s
    part = scenario.workpiece
    table = scenario.force_process
    depths = np.asarray(part.radial_depth_mm)
    gains = np.append(table.static_gain_N_per_mm_min(depths), 0.0)
    poles = np.append(table.parameters(depths)[1], table.p2_rad_s[0])
    phi_p, c_v, c_u = cascade_coefficients(poles, a, dt)
    starts = part.segment_start_mm
    length = part.length_mm
    phi_d = np.exp(-a * dt)
    lag = -np.expm1(-a * dt) / a
    ctrl = scenario.controller
    ref, feed = ctrl.reference_force_N, ctrl.programmed_feed_mm_min
    sigma = scenario.sensor.noise_std_N
    wc = 2 * np.pi * scenario.sensor.lowpass_cutoff_hz
    phi_s = np.exp(-wc * dt) if wc > 0 else 0.0

    def segment(position: float) -> int:
        if position >= length:
            return len(starts)
        return max(int(np.count_nonzero(position >= starts)) - 1, 0)

    # cutting: states [v, x, position, u[k-1], ..., u[k-N]]
    def cut_update(t, z, u, params):  # noqa: ANN001, ANN202
        v, x, pos = z[0], z[1], z[2]
        hist = z[3:]
        cmd = u[0]
        delayed = hist[-1] if n_delay > 0 else cmd
        seg = segment(pos)
        travel = (delayed * dt + (v - delayed) * lag) / 60.0
        x_next = phi_p[seg] * x + c_v[seg] * v + c_u[seg] * delayed
        v_next = phi_d * v + (1.0 - phi_d) * delayed
        return np.concatenate([[v_next, x_next, pos + travel], [cmd], hist[:-1]])

    def cut_output(t, z, u, params):  # noqa: ANN001, ANN202
        return np.array([gains[segment(z[2])] * z[1]])

    cutting = control.nlsys(
        cut_update,
        cut_output,
        inputs=["command"],
        outputs=["force"],
        states=3 + n_delay,
        dt=dt,
        name="cutting",
    )

    def sensor_value(z, u) -> float:  # noqa: ANN001
        return phi_s * z[0] + (1.0 - phi_s) * (u[0] + sigma * u[1])

    sensor = control.nlsys(
        lambda t, z, u, params: np.array([sensor_value(z, u)]),
        lambda t, z, u, params: np.array([sensor_value(z, u)]),
        inputs=["force", "noise"],
        outputs=["measured"],
        states=1,
        dt=dt,
        name="sensor",
    )

    # controller: states [the controller's state record as float words..., override held]
    safe = safe_feed_mm_min(ref, gains[:-1])
    cp, cs0 = controller_records(
        [ctrl], [scenario.nominal_plant], scenario.simulation.control_period_s,
        np.array([safe / feed]),
    )
    flat0 = cs0.view(np.float64)
    ns = len(flat0)
    diag = np.full(7, np.nan)

    def control_law(t: float, z, y: float):  # noqa: ANN001, ANN202
        if int(round(t / dt)) % m:
            return z[:ns], z[ns]
        state = np.array(z[:ns], dtype=np.float64).view(cs0.dtype)
        override = step_runs(cp, state, [y], shared=(diag,))[0]
        return state.view(np.float64), override

    def ctrl_update(t, z, u, params):  # noqa: ANN001, ANN202
        state, override = control_law(t, z, u[0])
        return np.append(state, override)

    controller = control.nlsys(
        ctrl_update,
        lambda t, z, u, params: np.array([control_law(t, z, u[0])[1] * feed]),
        inputs=["measured"],
        outputs=["command"],
        states=ns + 1,
        dt=dt,
        name="controller",
    )
    loop = control.interconnect(
        [cutting, sensor, controller],
        inplist=["noise"],
        outlist=["force", "measured", "command"],
        name="closed_loop",
    )
    x0 = np.zeros(loop.nstates)
    x0[loop.nstates - ns - 1 : loop.nstates - 1] = flat0
    return loop, x0


_CONTROL_PROBE = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    import control
    sys.path.insert(0, {bench!r})
    from bench_loop import base_scenario, control_loop
    from acc.engine.rng import normals, STREAM_FORCE_SENSOR
    scenario = base_scenario(5.0, {kind!r})
    n = {steps} or scenario.simulation.max_steps
    scenario = scenario.with_values({{"simulation.time_limit_s": n * 0.001}})
    loop, x0 = control_loop(scenario)
    noise = normals(scenario.simulation.seed, 0, STREAM_FORCE_SENSOR, n)
    t = np.arange(n) * scenario.simulation.plant_step_s
    t0 = time.perf_counter()
    response = control.input_output_response(loop, t, noise, x0)
    seconds = time.perf_counter() - t0
    np.save({out!r}, response.outputs[0])
    print(seconds)
    """
)


def bench_control(kind: str, steps: int | None = None) -> dict[str, float]:
    """One run of the python-control model; its force is checked against the engine's."""
    from acc.engine.simulate import simulate

    with tempfile.TemporaryDirectory() as d:
        out = str(Path(d) / "force.npy")
        code = _CONTROL_PROBE.format(
            bench=str(Path(__file__).parent), kind=kind, steps=steps or 0, out=out
        )
        done = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        )
        seconds = float(done.stdout.strip().splitlines()[-1])
        force = np.load(out)
    n = len(force)
    scenario = base_scenario(5.0, kind).with_values({"simulation.time_limit_s": n * 0.001})
    ours = simulate(scenario, run_ids=[0], record_every_steps=1).signal("force_N")[0]
    diff = float(np.max(np.abs(force - ours[:n])) / np.max(np.abs(ours)))
    return {
        f"{kind}: single {n * 0.001:g} s run, python-control nlsys + interconnect [ms]": 1e3
        * seconds,
        f"{kind}: python-control force vs acc.simulate [max relative difference]": diff,
    }


MEMORY_CAMPAIGN = """
[campaign]
name = "memory_1e5"
base = "{scenario}"
seed = 1
samples_per_point = {runs}
chunk_runs = 500

[set]
simulation.time_limit_s = 30.0
controller.kind = "dob_adaptive_pi"

[random]
force_process.gain_multiplier = {{ dist = "uniform", low = 0.8, high = 1.25 }}
sensor.noise_std_N = {{ dist = "uniform", low = 0.0, high = 10.0 }}
"""


def bench_memory(runs: int) -> dict[str, float]:
    """``acc sweep`` of a ``runs``-run campaign, metrics only: peak memory of the process tree."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "memory.toml"
        path.write_text(MEMORY_CAMPAIGN.format(scenario=SCENARIO, runs=runs), encoding="utf-8")
        cmd = [sys.executable, "-c", "from acc.cli.main import main; raise SystemExit(main())"]
        args = ["sweep", str(path), "--out", str(Path(d) / "out")]
        t0 = time.perf_counter()
        proc = subprocess.Popen([*cmd, *args, "--no-progress", "--no-figures"])
        peak = wait_sampling_memory(proc)
        seconds = time.perf_counter() - t0
        if proc.returncode != 0:
            raise RuntimeError(f"acc sweep exited with {proc.returncode}")
        rows = sum(1 for _ in (Path(d) / "out" / "summary.csv").open()) - 1
    assert rows == runs
    return {
        f"{runs}-run sweep, metrics only: peak PSS of all processes [MiB]": peak[1] / 2**20,
        f"{runs}-run sweep, metrics only: peak RSS summed over processes [MiB]": peak[0] / 2**20,
        f"{runs}-run sweep: wall time [s]": seconds,
    }


#: Where the hand-fused reference loop lives (``/work/shared/bench`` beside the repository).
LIMIT_KERNEL_DIR = ROOT.parent / "shared" / "bench"


_LIMIT_PROBE = textwrap.dedent(
    """
    import json, sys, time
    sys.path.insert(0, {kernel_dir!r})
    import limit_kernel
    try:
        from acc.scenarios.force import load_scenario
    except ImportError:  # a tree from before acc.scenarios
        from acc.scenario import load_scenario
    from acc.engine.simulate import simulate
    base = load_scenario({scenario!r}).with_values({changes!r})
    engines = {{"output_error": base,
               "rls": base.with_values({{"controller.estimator": "rls"}})}}
    for sc in engines.values():
        simulate([sc, sc], record_every_steps=None)  # compiled / loaded
    limit_kernel.bench(2, t_end=0.1)
    cpu = {cpu!r}  # one thread each, process CPU seconds: what another job's load leaves alone
    clock = time.process_time if cpu else time.perf_counter
    threads = 1 if cpu else None
    if cpu:
        import numba
        numba.set_num_threads(1)
    rates = {{"hand-fused": [], "output_error": [], "rls": []}}
    for _ in range({repeats}):
        t0 = clock()
        limit_kernel.bench({runs}, t_end=30.0)
        rates["hand-fused"].append({runs} * 30000 / (clock() - t0))
        for label, sc in engines.items():
            t0 = clock()
            result = simulate([sc] * {runs}, record_every_steps=None, threads=threads)
            seconds = clock() - t0
            m = result.metrics
            assert not m["failed"].any() and all(m["machining_time_s"] != m["machining_time_s"])
            rates[label].append(result.runs * sc.simulation.max_steps / seconds)
    print(json.dumps(rates))
    """
)


def _limit_probe(tree: Path, runs: int, repeats: int, cpu: bool = False,
                 noise_std_N: float = 0.0) -> dict[str, list[float]]:
    """One probe of :func:`bench_limit` in a fresh process on the source tree ``tree``
    (``cpu``: one thread each, rates per CPU second; ``noise_std_N``: the engine's runs'
    sensor noise, the hand-fused loop has none)."""
    import json

    code = _LIMIT_PROBE.format(
        kernel_dir=str(LIMIT_KERNEL_DIR), scenario=str(tree / SCENARIO.relative_to(ROOT)),
        changes={**CHANGES, "sensor.noise_std_N": noise_std_N,
                 "controller.kind": "dob_adaptive_pi"},
        runs=runs, repeats=repeats, cpu=cpu,
    )
    env = {**os.environ, "PYTHONPATH": str(tree)}
    done = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env,
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def bench_limit(runs: int, repeats: int = 5, baseline: Path | None = None,
                rounds: int = 2, cpu: bool = False, noise_std_N: float = 0.0
                ) -> dict[str, float]:
    """The hand-fused loop against the engine (output-error and rls estimators), in fresh
    processes: within a probe the three alternate ``repeats`` times; ``rounds`` probes of
    this tree, alternating with probes of the ``baseline`` tree if given.  Ratios of the
    medians over all repeats of a tree.  ``cpu``: one thread each and rates per CPU second
    of the process (another job on the machine slows the wall clock of both sides by
    different amounts; it leaves their CPU seconds nearly alone).  ``noise_std_N``: sensor
    noise of the engine's runs (a normal drawn every plant step; the hand-fused loop has
    none), to measure what noise costs."""
    trees = {"this tree": ROOT, **({"baseline": Path(baseline)} if baseline else {})}
    rates: dict[str, dict[str, list[float]]] = {t: {} for t in trees}
    for _ in range(rounds):
        for label, tree in trees.items():
            for k, v in _limit_probe(tree, runs, repeats, cpu, noise_std_N).items():
                rates[label].setdefault(k, []).extend(v)
    out: dict[str, float] = {}
    for label in trees:
        median = {k: statistics.median(v) for k, v in rates[label].items()}
        tag = "" if label == "this tree" else f" ({label}: {Path(trees[label]).name})"
        tag += ", 1 thread, per CPU second" if cpu else ", 2 threads, wall clock"
        out[f"hand-fused numba loop (limit_kernel.py), {runs} runs of 30 s{tag} "
            "[run-steps/s]"] = median["hand-fused"]
        for est in ("output_error", "rls"):
            name = "output_error (default)" if est == "output_error" else est
            noise = f"{noise_std_N:g} N sensor noise" if noise_std_N else "noise-free"
            out[f"dob_adaptive_pi, {name} estimator, {runs} runs, {noise}{tag} "
                "[run-steps/s]"] = median[est]
            out[f"dob_adaptive_pi, {name} estimator / hand-fused loop{tag} [-]"] = (
                median[est] / median["hand-fused"])
    return out


PARTS = ("throughput", "single", "compile", "sweep", "control", "memory", "limit")


def main(argv: list[str] | None = None) -> int:
    """Run the chosen parts and print (or write) a Markdown report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=PARTS, default=list(PARTS))
    parser.add_argument("--runs", type=int, default=10_000, help="runs of the throughput batch")
    parser.add_argument("--sweep-runs", type=int, default=10_000, help="runs of the speed sweep")
    parser.add_argument(
        "--memory-runs", type=int, default=100_000, help="runs of the memory sweep"
    )
    parser.add_argument(
        "--control-steps", type=int, help="plant steps of the python-control run (default: 30 s)"
    )
    parser.add_argument("--limit-runs", type=int, default=4000,
                        help="runs of the comparison with the hand-fused loop")
    parser.add_argument("--limit-cpu", action="store_true",
                        help="limit: one thread each side, rates per CPU second of the "
                        "process (steadier on a shared machine than the wall clock)")
    parser.add_argument("--limit-noise", type=float, default=0.0, metavar="N",
                        help="limit: sensor noise of the engine's runs [N] (default 0; the "
                        "hand-fused loop is noise-free either way)")
    parser.add_argument("--baseline", type=Path,
                        help="limit: also measure this source tree (e.g. an older commit's "
                        "`git archive`), alternating with this one")
    parser.add_argument("--write", help="also write the report to this Markdown file")
    args = parser.parse_args(argv)

    load = os.getloadavg()
    results: dict[str, float] = {}
    for part in args.only:
        t0 = time.perf_counter()
        if part == "throughput":
            results.update(bench_throughput(args.runs))
        elif part == "single":
            results.update(bench_single())
        elif part == "compile":
            results.update(bench_compile())
        elif part == "sweep":
            results.update(bench_sweep(args.sweep_runs))
        elif part == "control":
            for kind in KINDS:
                results.update(bench_control(kind, args.control_steps))
        elif part == "memory":
            results.update(bench_memory(args.memory_runs))
        elif part == "limit":
            results.update(bench_limit(args.limit_runs, baseline=args.baseline,
                                       cpu=args.limit_cpu, noise_std_N=args.limit_noise))
        print(f"[{part}: {time.perf_counter() - t0:.1f} s]", file=sys.stderr)

    for kind in KINDS:
        single = results.get(f"{kind}: single 30 s run, noisy [ms]")
        other = results.get(f"{kind}: single 30 s run, python-control nlsys + interconnect [ms]")
        if single and other:
            results[f"{kind}: ratio python-control nlsys + interconnect / acc (noisy)"] = (
                other / single
            )

    import numba

    lines = [
        "| quantity | value |",
        "|---|---|",
        *(f"| {k} | {v:.4g} |" for k, v in results.items()),
        "",
        f"Load average before the run: {load[0]:.2f}, after: "
        f"{os.getloadavg()[0]:.2f} (1 min).",
        f"Machine: {os.cpu_count()} cores, {platform.processor() or platform.machine()}, "
        f"Python {platform.python_version()}, NumPy {np.__version__}, numba {numba.__version__}.",
        f"Command: `python benchmarks/bench_loop.py {' '.join(argv or sys.argv[1:])}`",
    ]
    report = "\n".join(lines)
    print(report)
    if args.write:
        Path(args.write).write_text(report + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
