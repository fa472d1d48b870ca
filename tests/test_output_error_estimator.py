"""The output-error estimator of K2, p2: its step against an implementation written here from
the equations, its candidate models against python-control, no bias at the shipped 5 N noise
on every Table 1 row (with and without the 20 Hz low-pass), re-convergence after every depth
step, no drift in air, and its information guard."""

import math

import numpy as np
import pytest
from scipy.signal import cont2discrete

from acc.engine.element import call_runs, step_runs
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario
from controllers.gain_estimator import (
    POLE_GRID_POINTS,
    EstimatorOptions,
    estimates,
    estimator_records,
    record_command,
)

TABLE1 = [(2.0, 10.05, -2.35), (3.0, 12.57, -3.75), (4.0, 20.11, -5.35)]
A, TC, N, R, F = 29.33, 0.01, 10, 500.0, 120.0
K2N, P2N = 12.57, -3.75


def _records(settings: EstimatorOptions, runs: int = 1):
    return estimator_records(settings, A, K2N, P2N, N, [R] * runs, F, TC)


def _loop(values: dict, seeds, time_limit_s: float):
    """adaptive_pi with the output-error estimator in the project's loop (1 ms plant step,
    traces at the control instants)."""
    base = Scenario().with_values(
        {
            "controller.kind": "adaptive_pi",
            "controller.estimator": "output_error",
            "sensor.noise_std_N": 5.0,
            "simulation.time_limit_s": time_limit_s,
            **values,
        }
    )
    return simulate([base] * len(seeds), noise_ids=list(seeds), record_every_steps=10)


# --- the step, sample by sample, against numpy ------------------------------------------
class Reference:
    """The output-error method written from the module's equations with numpy/scipy: each
    candidate is ``scipy.signal.cont2discrete`` (zero-order hold) of the state-space model
    ``(v, x, z)``; sums, profile, guards vectorised over the candidates; the refinement by
    ``numpy.polyfit`` of a cubic and the roots of its derivative."""

    def __init__(self, s: EstimatorOptions):
        m = POLE_GRID_POINTS
        rmax = s.estimator_parameter_ratio_max
        self.log_p = np.linspace(math.log(-P2N / rmax), math.log(-P2N * rmax), m)
        self.h = self.log_p[1] - self.log_p[0]
        wc = 2 * math.pi * s.estimator_sensor_cutoff_hz
        self.Ad, self.Bd = [], []
        for p in -np.exp(self.log_p):
            Ac = np.array([[-A, 0, 0], [-p, p, 0], [0, wc, -wc]])
            if wc == 0:  # no filter: z is x
                Ac[2] = Ac[1]
            Ad, Bd, *_ = cont2discrete((Ac, np.array([[A], [0], [0]]), np.eye(3),
                                        np.zeros((3, 1))), TC, method="zoh")
            if wc == 0:
                Ad[2], Bd[2] = Ad[1], Bd[1]
            self.Ad.append(Ad)
            self.Bd.append(Bd[:, 0])
        self.Ad, self.Bd = np.array(self.Ad), np.array(self.Bd)
        self.s = s
        self.states = np.zeros((m, 3))
        self.u = []  # commands u[0], u[1], ...
        self.f = [0.0, 0.0]  # f[k-2], f[k-1]
        self.exc = 0.0
        self.skip = 0
        self.was_in_cut = self.was_large = False
        self.skip_after = (math.ceil(-math.log(1e-3) / (wc * TC)) if wc > 0 else 0)
        self.g_nom = K2N / -P2N
        self.p2, self.gain = P2N, self.g_nom
        self.clear()

    def clear(self):
        m = POLE_GRID_POINTS
        self.szz, self.syz, self.syy, self.n = np.zeros(m), np.zeros(m), 0.0, 0.0
        self.best, self.best_gain = -1, 0.0

    def command(self, k: int) -> float:
        return self.u[k] if k >= 0 else 0.0

    def step(self, f: float) -> int:
        s, k = self.s, len(self.u)
        u1, u2 = self.command(k - 1 - N), self.command(k - 2 - N)
        self.states = np.einsum("mij,mj->mi", self.Ad, self.states) + self.Bd * u1
        z = self.states[:, 2] / F
        du = (u1 - u2) / F
        self.exc = 0.9 * self.exc + 0.1 * du * du
        fmin = s.estimator_min_force_fraction * R
        in_cut = f > fmin and self.f[1] > fmin and self.f[0] > fmin
        self.f = [self.f[1], f]
        err = f / R - self.best_gain * z[self.best] if self.best >= 0 else 0.0
        large = in_cut and abs(err) > s.estimator_reset_error_fraction
        if in_cut and (not self.was_in_cut or (large and not self.was_large)):
            self.clear()
            self.skip = self.skip_after
        self.was_in_cut, self.was_large = in_cut, large
        if not in_cut:
            return 0
        if self.skip > 0:
            self.skip -= 1
            return 0
        lam = s.estimator_forgetting if self.exc > s.estimator_excitation_threshold else 1.0
        y = f / R
        self.szz = lam * self.szz + z * z
        self.syz = lam * self.syz + y * z
        self.syy = lam * self.syy + y * y
        self.n = lam * self.n + 1
        J = self.syy - self.syz**2 / self.szz
        if np.all(np.isnan(J)):
            return 1
        m = POLE_GRID_POINTS
        self.best = int(np.nanargmin(J))
        self.best_gain = self.syz[self.best] / self.szz[self.best]
        # the cubic through the four grid points around the least J (numpy's fit and roots)
        c = min(max(self.best, 1), m - 2)
        lower = c - 1 if J[c - 1] < J[c + 1] else c
        k = min(max(lower - 1, 0), m - 4)
        cubic = np.polyfit(np.arange(4.0), J[k : k + 4], 3)
        slope, curvature = np.polyder(cubic), np.polyder(cubic, 2)
        minima = [r.real for r in np.roots(slope)
                  if abs(r.imag) < 1e-12 and np.polyval(curvature, r.real) > 0]
        if minima and self.n > 3:
            t = np.clip(minima[0], c - 1 - k, c + 1 - k)  # within one step of c
            curv = np.polyval(curvature, t)
            if curv > 0:
                s2 = max(np.polyval(cubic, t), 0.0) / (self.n - 2)
                if math.sqrt(2 * s2 * self.h**2 / curv) < s.estimator_pole_std_max:
                    self.p2 = -math.exp(self.log_p[k] + t * self.h)
        t = np.clip((math.log(-self.p2) - self.log_p[0]) / self.h, 0, m - 1)
        i0 = min(max(math.floor(t), 0), m - 2)
        k = min(max(i0 - 1, 0), m - 4)
        g = self.syz / self.szz
        rmax = s.estimator_parameter_ratio_max
        g_at = np.polyval(np.polyfit(np.arange(4.0), g[k : k + 4], 3), t - k)
        self.gain = np.clip(g_at * R / F, self.g_nom / rmax, self.g_nom * rmax)
        return 1


@pytest.mark.parametrize("cutoff_hz", [0.0, 20.0])
def test_step_equals_numpy_reference(cutoff_hz):
    """Closed-loop data with 5 N noise and a 3 -> 4 -> 2 mm part (start of cut, two resets,
    the filter's skip): the compiled estimate equals the reference at every sample, 1e-9
    relative (the discretisations differ in rounding only)."""
    res = _loop(
        {
            "workpiece.segment_length_mm": [6.0, 6.0, 6.0],
            "workpiece.radial_depth_mm": [3.0, 4.0, 2.0],
            "workpiece.axial_depth_mm": [10.0] * 3,
            "sensor.lowpass_cutoff_hz": cutoff_hz,
            "controller.estimator_sensor_cutoff_hz": cutoff_hz,
        },
        [0], 9.0,
    )
    f = res.signal("measured_force_N")[0]
    u = res.signal("commanded_feed_mm_min")[0]
    n = int(np.sum(np.isfinite(f)))
    settings = EstimatorOptions(
        estimator_start="nominal", estimator="output_error", estimator_sensor_cutoff_hz=cutoff_hz)
    params, state = _records(settings)
    ref = Reference(settings)
    updates = moves = 0
    last_p2 = P2N
    for k in range(n):
        updated = step_runs(params, state, f[k : k + 1])[0]
        call_runs(record_command, params, state, u[k : k + 1])
        assert updated == ref.step(f[k])
        ref.u.append(u[k])
        k2_hat, p2_hat = (float(v[0]) for v in call_runs(estimates, params, state))
        assert p2_hat == pytest.approx(ref.p2, rel=1e-9)
        assert k2_hat == pytest.approx(-ref.p2 * ref.gain, rel=1e-9)
        updates += updated
        moves += p2_hat != last_p2
        last_p2 = p2_hat
    assert updates > 0.8 * n and moves > 50  # the data exercised the fit and the guard


def test_candidates_equal_python_control_discretisation():
    """A candidate's filtered chip load under a command step is the step response of
    python-control's zero-order-hold ``c2d`` of a/(s+a) * (-p)/(s-p) * w/(s+w), 1e-10."""
    import control as ct

    settings = EstimatorOptions(
        estimator_start="nominal", estimator="output_error", estimator_sensor_cutoff_hz=20.0)
    params, state = _records(settings)
    i = 17
    p = float(params["pole_grid_rad_s"][0, i])
    w = 2 * math.pi * 20.0
    plant = ct.tf([A], [1, A]) * ct.tf([-p], [1, -p]) * ct.tf([w], [1, w])
    expected = ct.step_response(ct.c2d(plant, TC, "zoh"), T=np.arange(60) * TC).outputs
    got = []
    for _ in range(60):  # the command steps to 1 mm/min at k = 0 and reaches x after N
        got.append(state["filtered_chip_load"][0, i])
        step_runs(params, state, [0.0])
        call_runs(record_command, params, state, [1.0])
    np.testing.assert_allclose(got[N + 1 :], expected[: 60 - N - 1], rtol=1e-10, atol=1e-14)


# --- closed loop: bias, re-convergence -----------------------------------------------------
SEEDS = (0, 1, 2)


@pytest.fixture(scope="module")
def table1_runs():
    """Each Table 1 row alone, 4 s of adaptive_pi at 5 N, without and with the 20 Hz
    low-pass (the estimator told its cut-off), three noise seeds each."""
    out = {}
    for cutoff in (0.0, 20.0):
        for depth, k2, p2 in TABLE1:
            res = _loop(
                {
                    "workpiece.segment_length_mm": [20.0],
                    "workpiece.radial_depth_mm": [depth],
                    "workpiece.axial_depth_mm": [10.0],
                    "sensor.lowpass_cutoff_hz": cutoff,
                    "controller.estimator_sensor_cutoff_hz": cutoff,
                },
                SEEDS, 4.0,
            )
            out[cutoff, depth] = (res, k2, p2)
    return out


@pytest.mark.parametrize("cutoff", [0.0, 20.0])
@pytest.mark.parametrize("depth", [2.0, 3.0, 4.0])
def test_no_bias_on_table1_rows_at_5_N(table1_runs, depth, cutoff):
    # 3 %: the bound (a K2 error e moves the crossover by about e).  Measured over
    # 8 seeds (experiments/estimator_convergence.py): |bias| <= 0.3 %, spread <= 0.3 %; the
    # equation-error rls runs to its bounds here without the filter.
    res, k2, p2 = table1_runs[cutoff, depth]
    k2_hat = res.signal("estimated_k2_N_min_per_mm_s")[:, -1]
    p2_hat = res.signal("estimated_p2_rad_s")[:, -1]
    assert np.all(np.abs(k2_hat / k2 - 1) < 0.03), k2_hat
    assert np.all(np.abs(p2_hat / p2 - 1) < 0.03), p2_hat
    assert abs(np.mean(k2_hat) / k2 - 1) < 0.01
    assert abs(np.mean(p2_hat) / p2 - 1) < 0.01


def test_reconverges_after_every_depth_step_at_the_shipped_noise():
    """The stepped part 2 -> 3 -> 4 -> 2 mm (8 mm each) with the shipped sensor (5 N, 20 Hz):
    after every step |K2 error| falls below 3 % within 1.5 s and stays there to the next."""
    res = _loop(
        {
            "workpiece.segment_length_mm": [8.0] * 4,
            "workpiece.radial_depth_mm": [2.0, 3.0, 4.0, 2.0],
            "workpiece.axial_depth_mm": [10.0] * 4,
            "sensor.lowpass_cutoff_hz": 20.0,
            "controller.estimator_sensor_cutoff_hz": 20.0,
        },
        SEEDS, 20.0,
    )
    k2_true = {d: k for d, k, _ in TABLE1}
    for r in range(len(SEEDS)):
        depth = res.signal("radial_depth_mm")[r]
        k2_hat = res.signal("estimated_k2_N_min_per_mm_s")[r]
        n = int(np.sum(np.isfinite(depth)))
        steps = [0, *np.flatnonzero(np.diff(depth[:n]) != 0) + 1, n]
        assert len(steps) == 5  # four segments: the whole part was cut
        for first, end in zip(steps[:-1], steps[1:], strict=False):
            err = np.abs(k2_hat[first:end] / k2_true[depth[first]] - 1)
            late = err[150:]  # 1.5 s after the step (measured: 0.4 s median, 4 s worst of 8)
            assert np.all(late < 0.03), (r, depth[first], late.max())


# --- guards ------------------------------------------------------------------------------
def test_no_drift_during_an_air_cut():
    """100 mm of air at the clamped override: the estimate and the fit stay as initialised."""
    res = _loop(
        {
            "workpiece.segment_length_mm": [100.0, 10.0],
            "workpiece.radial_depth_mm": [0.0, 3.0],
            "workpiece.axial_depth_mm": [10.0, 10.0],
        },
        [0], 2.0,
    )
    f = res.signal("measured_force_N")[0]
    u = res.signal("commanded_feed_mm_min")[0]
    params, state = _records(EstimatorOptions(
        estimator_start="nominal", estimator="output_error"))
    initial = state.copy()
    for k in range(int(np.sum(np.isfinite(f)))):
        assert step_runs(params, state, f[k : k + 1])[0] == 0
        call_runs(record_command, params, state, u[k : k + 1])
        for name in ("p2_rad_s", "static_gain_N_per_mm_min", "sum_zz", "sum_yy", "best"):
            np.testing.assert_array_equal(state[name], initial[name])


def test_a_settled_cut_moves_the_gain_not_the_pole():
    """An air approach and a 4 mm cut at one constant feed, 5 N noise: the static gain
    converges on force / feed, while p2, on which a constant feed carries no information,
    stays where it was: the information guard holds it (without it the minimum of a flat,
    noisy profile wanders over the grid)."""
    params, state = _records(EstimatorOptions(
        estimator_start="nominal", estimator="output_error"))
    p2_start = float(state["p2_rad_s"][0])
    rng = np.random.default_rng(7)
    g_true = 20.11 / 5.35
    feed = 130.0
    for _ in range(400):  # 4 s of air: the drive and the chip loads settle at the feed
        step_runs(params, state, [rng.standard_normal()])
        call_runs(record_command, params, state, [feed])
    for _ in range(300):
        step_runs(params, state, [g_true * feed + 5.0 * rng.standard_normal()])
        call_runs(record_command, params, state, [feed])
    k2_hat, p2_hat = (float(v[0]) for v in call_runs(estimates, params, state))
    assert p2_hat == p2_start == pytest.approx(P2N, rel=1e-12)
    assert k2_hat / -p2_hat == pytest.approx(g_true, rel=0.003)
    assert state["pole_log_std"][0] > 0.05


# --- the refined minimum against a brute-force profile, a known plant -------------------
def _chip_load(poles_rad_s, commands, cutoff_hz: float = 20.0):
    """Filtered chip loads [mm/min] of candidates with poles ``p`` under the commands
    ``u[0..n-1]``, shape (poles, n): the zero-order-hold discretisation
    (``scipy.signal.cont2discrete``) of a/(s+a) -> dx/dt = p (x - v) -> w/(s+w), the command
    reaching the drive N periods late (``z[k]`` sees ``u[k-1-N]``, as the estimator's model
    and the loop), run from rest."""
    wc = 2 * math.pi * cutoff_hz
    Ad, Bd = [], []
    for p in np.atleast_1d(poles_rad_s):
        Ac = np.array([[-A, 0, 0], [-p, p, 0], [0, wc, -wc]])
        d = cont2discrete((Ac, np.array([[A], [0], [0]]), np.eye(3), np.zeros((3, 1))), TC,
                          method="zoh")
        Ad.append(d[0])
        Bd.append(d[1][:, 0])
    Ad, Bd = np.array(Ad), np.array(Bd)
    delayed = np.r_[np.zeros(N), commands][: len(commands)]
    x = np.zeros((len(Ad), 3))
    out = np.empty((len(Ad), len(commands)))
    for k, u in enumerate(delayed):
        out[:, k] = x[:, 2]
        x = np.einsum("mij,mj->mi", Ad, x) + Bd * u
    return out


K2_TRUE, P2_TRUE = 15.0, -4.4  # a plant between the candidates (grid poles: 0.75 ... 18.75)


@pytest.fixture(scope="module")
def known_plant():
    """Six seconds of feed steps (0.4 s each, 0.6-1.4 x F) into the plant above, its force
    exact (``_chip_load``), and the estimator's settings: the 20 Hz filter modelled, no
    forgetting and no resets, so the criterion is the plain sum since the tool entered."""
    rng = np.random.default_rng(3)
    n = 600
    commands = F * np.repeat(rng.uniform(0.6, 1.4, n // 40), 40)
    force = K2_TRUE / -P2_TRUE * _chip_load(P2_TRUE, commands)[0]
    settings = EstimatorOptions(
        estimator="output_error", estimator_start="nominal", estimator_sensor_cutoff_hz=20.0,
        estimator_forgetting=1.0, estimator_reset_error_fraction=1e9)
    return commands, force, settings, rng


def _estimate_along(settings, force, commands):
    """The estimator fed ``force[k]`` then ``commands[k]``: (K2, p2, standard error of
    ln|p2|) after every sample."""
    params, state = _records(settings)
    out = []
    for k in range(len(force)):
        step_runs(params, state, force[k : k + 1])
        call_runs(record_command, params, state, commands[k : k + 1])
        k2_hat, p2_hat = (float(v[0]) for v in call_runs(estimates, params, state))
        out.append((k2_hat, p2_hat, float(state["pole_log_std"][0])))
    return np.array(out)


def test_refined_pole_is_the_minimum_of_the_criterion_on_a_fine_grid(known_plant):
    """With 5 N noise, at five instants: the estimate's ln|p2| is within 1e-3 of the minimum
    of the same criterion J(p) = S_yy - S_yz^2 / S_zz over 1001 poles spanning the same range,
    each candidate simulated by scipy (grid spacing 3.2e-3, its own parabola: its error is
    about 1e-6), and G within 1e-4 of that minimum's.  Measured: 2e-4 and 3e-5 at most; the
    24-point grid alone would be off by up to half its step, 0.07, and a parabola through
    its three points by up to about 8e-3 on closed-loop data."""
    commands, force, settings, rng = known_plant
    measured = force + 5.0 * rng.standard_normal(len(force))
    hist = _estimate_along(settings, measured, commands)
    # the samples the estimator absorbed: from entering the cut (three samples above 2 % of
    # r) plus the filter's skip, to the instant looked at
    fmin = settings.estimator_min_force_fraction * R
    above = measured > fmin
    entered = int(np.argmax(above[2:] & above[1:-1] & above[:-2])) + 2
    first = entered + math.ceil(-math.log(1e-3) / (2 * math.pi * 20.0 * TC))
    log_p = np.linspace(math.log(-P2N / 5), math.log(-P2N * 5), 1001)
    z = _chip_load(-np.exp(log_p), commands) / F
    y = measured / R
    h = log_p[1] - log_p[0]
    for end in (150, 200, 300, 450, 599):
        used = slice(first, end + 1)
        szz = np.sum(z[:, used] ** 2, axis=1)
        syz = np.sum(z[:, used] * y[used], axis=1)
        J = np.sum(y[used] ** 2) - syz**2 / szz
        c = int(np.clip(np.argmin(J), 1, len(J) - 2))
        q = log_p[c] + 0.5 * h * (J[c - 1] - J[c + 1]) / (J[c - 1] + J[c + 1] - 2 * J[c])
        gain = np.interp(q, log_p, syz / szz) * R / F
        k2_hat, p2_hat, std = hist[end]
        assert std < settings.estimator_pole_std_max  # the guard let the pole move here
        assert abs(math.log(-p2_hat) - q) < 1e-3, (end, math.log(-p2_hat) - q)
        assert k2_hat / -p2_hat == pytest.approx(gain, rel=1e-4)


def test_identifies_a_known_plant(known_plant):
    """Noise-free, the criterion's minimum is the plant itself (J = 0 there): K2 and p2 within
    1e-3 of the true ones after 3 s (measured: 1e-5; what is left is the interpolation between
    the candidates).  With 5 N noise within 1 % after 6 s (measured 0.16 %; the bound of the
    closed-loop tests is 3 %)."""
    commands, force, settings, rng = known_plant
    k2_hat, p2_hat, _ = _estimate_along(settings, force, commands)[300]
    assert p2_hat == pytest.approx(P2_TRUE, rel=1e-3)
    assert k2_hat == pytest.approx(K2_TRUE, rel=1e-3)
    noisy = force + 5.0 * np.random.default_rng(11).standard_normal(len(force))
    k2_hat, p2_hat, _ = _estimate_along(settings, noisy, commands)[-1]
    assert p2_hat == pytest.approx(P2_TRUE, rel=0.01)
    assert k2_hat == pytest.approx(K2_TRUE, rel=0.01)
