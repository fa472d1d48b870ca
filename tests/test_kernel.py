"""The compiled kernel gives the NumPy simulator's numbers (metrics and traces, 1e-12)."""

from __future__ import annotations

import numpy as np
import pytest

from acc.campaign import load_campaign
from acc.kernel import simulate_compiled, unsupported
from acc.scenario import scenario_from_dict
from acc.simulator import simulate
from acc.sweep import read_summary, run_sweep
from tests.campaign_files import SMALL, write

#: Relative tolerance of the agreement, on each quantity's scale (its largest magnitude over
#: the batch, so an overshoot near 0 % is compared on the scale of the others).  Both paths
#: evaluate the same floating-point operations in the same order; for the PI and constant
#: feed they agree bit for bit (asserted).  The adaptive controllers' logarithm and 3-term
#: dot products may round differently by an ulp (NumPy's SIMD ``log``, ``einsum``); those
#: differences stay near 1e-14 over a run.  A modelling difference would be >= 1e-6.
RTOL = 1e-12

BASE = {
    "simulation": {"plant_step_s": 0.002, "time_limit_s": 3.0},
    "workpiece": {
        "segment_length_mm": [2.0, 2.0],
        "radial_depth_mm": [2.0, 3.0],
        "axial_depth_mm": [10.0, 10.0],
    },
    "sensor": {"noise_std_N": 5.0, "lowpass_cutoff_hz": 20.0},
}


def _scenario(**changes: dict) -> object:
    data = {k: dict(v) for k, v in BASE.items()}
    for section, values in changes.items():
        data.setdefault(section, {}).update(values)
    return scenario_from_dict(data)


def _batch() -> list:
    """Runs that exercise every branch: noise or none, filter or none, dead times, parts of
    different lengths and segment counts (padding), air cuts, the constant feed, a tight
    override clamp, a time-limited run and an unstable (failed) run."""
    return [
        _scenario(),
        _scenario(sensor={"noise_std_N": 0.0, "lowpass_cutoff_hz": 0.0}),
        _scenario(feed_drive={"dead_time_s": 0.05}, force_process={"gain_multiplier": 1.2}),
        _scenario(
            workpiece={
                "segment_length_mm": [1.0, 1.5, 1.0],
                "radial_depth_mm": [4.0, 0.0, 2.5],
                "axial_depth_mm": [10.0, 0.0, 10.0],
            }
        ),
        _scenario(controller={"kind": "constant"}),
        _scenario(controller={"kind": "constant", "constant_override": 0.7}),
        _scenario(controller={"override_max": 1.2, "initial_override": 1.5}),
        _scenario(workpiece={"segment_length_mm": [2.0, 40.0]}),
        _scenario(force_process={"gain_multiplier": 1000.0}),
        _scenario(controller={"kp_per_N": 0.004, "ki_per_N_s": 0.02}),
    ]


def _close(x: np.ndarray, y: np.ndarray, name: str, exact: bool) -> None:
    if exact or x.dtype == bool:
        np.testing.assert_array_equal(y, x, err_msg=name)
        return
    finite = np.abs(x[np.isfinite(x)])
    scale = float(finite.max()) if finite.size else 0.0
    np.testing.assert_allclose(y, x, rtol=RTOL, atol=RTOL * scale, equal_nan=True, err_msg=name)


def _assert_same(a, b, exact: bool = True) -> None:
    assert set(a.metrics) == set(b.metrics)
    for name in a.metrics:
        _close(np.asarray(a.metrics[name]), np.asarray(b.metrics[name]), name, exact)
    for name in a.parameters:
        np.testing.assert_array_equal(a.parameters[name], b.parameters[name], err_msg=name)
    np.testing.assert_array_equal(a.time_s, b.time_s)
    assert set(a.signals) == set(b.signals)
    for name in a.signals:
        _close(np.asarray(a.signals[name]), np.asarray(b.signals[name]), name, exact)


@pytest.mark.parametrize("record_every_steps", [None, 1, 7])
@pytest.mark.parametrize("threads", [1, 2])
def test_kernel_matches_numpy_simulator(record_every_steps, threads):
    scenarios = _batch()
    ids = [3, 14, 15, 92, 65, 35, 89, 79, 32, 38]
    ref = simulate(scenarios, run_ids=ids, record_every_steps=record_every_steps)
    got = simulate_compiled(
        scenarios, run_ids=ids, record_every_steps=record_every_steps, threads=threads
    )
    # the batch has what it should: a failed run, a time-limited one, finished ones
    assert ref.metrics["failed"].tolist() == [False] * 8 + [True, False]
    assert np.isnan(ref.metrics["machining_time_s"][7])
    assert np.all(np.isfinite(ref.metrics["machining_time_s"][[0, 1, 2, 3, 4, 5, 6, 9]]))
    _assert_same(ref, got)
    np.testing.assert_array_equal(got.run_ids, ids)


def test_kernel_matches_without_anti_windup():
    scenarios = [
        _scenario(controller={"anti_windup": "none", "override_max": 1.2}),
        _scenario(controller={"anti_windup": "none"}, feed_drive={"dead_time_s": 0.0}),
    ]
    ref = simulate(scenarios, record_every_steps=3)
    _assert_same(ref, simulate_compiled(scenarios, record_every_steps=3))


def test_a_run_alone_equals_the_run_in_a_batch():
    scenarios = _batch()
    batch = simulate_compiled(scenarios, run_ids=range(10, 20), record_every_steps=None)
    alone = simulate_compiled(scenarios[2], run_ids=[12], record_every_steps=None)
    for name, value in alone.metrics.items():
        np.testing.assert_array_equal(value[0], batch.metrics[name][2], err_msg=name)


def test_compiled_sweep_matches_numpy_sweep(tmp_path):
    campaign = load_campaign(write(tmp_path, "c.toml", SMALL))
    numpy_sweep = run_sweep(campaign, tmp_path / "np", workers=1, engine="numpy", progress=False)
    a = read_summary(numpy_sweep.summary_path)
    b = read_summary(
        run_sweep(
            campaign, tmp_path / "nb", workers=2, engine="compiled", progress=False
        ).summary_path
    )
    assert list(a) == list(b)
    for name in a:
        if a[name].dtype.kind == "f":
            np.testing.assert_allclose(b[name], a[name], rtol=RTOL, equal_nan=True)
        else:
            np.testing.assert_array_equal(b[name], a[name])


@pytest.mark.parametrize("kind", ["adaptive_pi", "dob_pi", "dob_adaptive_pi"])
def test_kernel_matches_numpy_for_adaptive_and_observer_kinds(kind):
    # depth steps both ways (estimator resets), harder and softer material, noise or none
    part = {
        "segment_length_mm": [3.0, 3.0, 3.0],
        "radial_depth_mm": [2.0, 4.0, 3.0],
        "axial_depth_mm": [10.0, 10.0, 10.0],
    }
    scenarios = [
        _scenario(
            simulation={"time_limit_s": 6.0},
            workpiece=part,
            controller={"kind": kind},
            force_process={"gain_multiplier": g},
            sensor={"noise_std_N": noise},
        )
        for g, noise in [(0.8, 5.0), (1.0, 0.0), (1.3, 2.0)]
    ]
    ref = simulate(scenarios, record_every_steps=2)
    assert not ref.metrics["failed"].any()
    assert np.all(np.isfinite(ref.metrics["machining_time_s"]))
    if "adaptive" in kind:  # the estimator did update: the gains moved off the nominal ones
        kp = ref.signals["kp_per_N"]
        assert np.nanmax(kp) > 1.01 * np.nanmin(kp)
    _assert_same(ref, simulate_compiled(scenarios, record_every_steps=2), exact=False)
    alone = simulate_compiled(scenarios, record_every_steps=None)
    for name in ("rms_error_N", "peak_force_N", "machining_time_s"):
        _close(ref.metrics[name], alone.metrics[name], name, exact=False)


def test_kernel_refuses_what_it_does_not_model():
    pi = _scenario()
    assert unsupported(pi) is None
    kalman = pi.with_values({"controller.kind": "adaptive_pi", "controller.estimator": "kalman"})
    assert "kalman" in unsupported(kalman)
    with pytest.raises(NotImplementedError, match="kalman"):
        simulate_compiled([pi, kalman])
