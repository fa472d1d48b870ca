"""Analysis against simulation, with the 0.1 s dead time: a process-gain ratio the sampled-loop
analysis calls stable settles in simulation, one beyond its boundary does not.  What ``acc
analyze`` writes equals python-control's margins of the objects acc.analysis returns."""

import csv
import importlib
import sys

import control
import numpy as np
import pytest

from acc import analysis
from acc.cli.main import main
from acc.design.analysis import is_stable, loop_spec, max_gain_ratio, sampled_closed_loop
from acc.engine.element import unregister_element
from acc.engine.simulate import simulate
from acc.scenarios.force import Scenario, load_scenario
from controllers.registry import unregister_controller

SHIPPED = "experiments/kim_chung_2001.toml"
#: The added PID kind of tests/pid_kind.py, with a derivative (so its polynomial law differs
#: from the PI's).
PID_SET = "controller.pid_kd_s_per_N=2e-4"


def nominal_part(kind: str, gain_ratio: float) -> Scenario:
    # the 3 mm row of Table 1 is the nominal plant itself, so the multiplier is k / kn
    return Scenario().with_values(
        {
            "controller.kind": kind,
            "controller.override_max": 6.0,
            "workpiece.segment_length_mm": [1000.0],
            "workpiece.radial_depth_mm": [3.0],
            "workpiece.axial_depth_mm": [10.0],
            "force_process.gain_multiplier": gain_ratio,
            "sensor.noise_std_N": 0.0,
            "sensor.lowpass_cutoff_hz": 20.0,
            "simulation.time_limit_s": 24.0,
        }
    )


@pytest.mark.parametrize("kind", ["pi", "dob_pi"])
def test_simulation_agrees_with_the_gain_ratio_boundary_on_both_sides(kind):
    boundary = max_gain_ratio(loop_spec(nominal_part(kind, 1.0), None, kind))
    # shipped design: fixed PI about 3.08, DOB (tau = 0.1 s) about 1.89
    assert 1.5 < boundary < 4.0
    ratios = (0.8 * boundary, 1.2 * boundary)
    for k, expected in zip(ratios, (True, False), strict=True):
        spec = loop_spec(nominal_part(kind, k), 3.0, kind)
        assert is_stable(sampled_closed_loop(spec)) is expected
    res = simulate([nominal_part(kind, k) for k in ratios], record_every_steps=10)
    f = res.signal("force_N")
    t = res.time_s
    swing_late = np.ptp(f[:, t >= 20.0], axis=1)
    # stable side: the start-up oscillation has died out (below 1 N)
    assert swing_late[0] < 1.0
    # unstable side: it has not; it grew into a limit cycle held by the override clamps
    assert swing_late[1] > 0.2 * 500.0
    assert np.any(res.signal("override")[1, t >= 20.0] == 0.1)  # touches the lower clamp


@pytest.fixture(scope="module")
def analyzed(tmp_path_factory):
    """``acc analyze`` of the shipped scenario, with the added PID kind registered too."""
    importlib.import_module("tests.pid_kind")
    out = tmp_path_factory.mktemp("analyze")
    try:
        assert main(["analyze", SHIPPED, "--out", str(out), "--set", PID_SET, "-q"]) == 0
        with (out / "analysis.csv").open() as fh:
            rows = list(csv.DictReader(fh))
        yield out, rows, analysis.analysable_kinds()
    finally:
        unregister_controller("pid_test")
        unregister_element("controller.pid_test")
        sys.modules.pop("tests.pid_kind", None)


def test_acc_analyze_writes_the_table_and_figures(analyzed):
    out, rows, kinds = analyzed
    plants = {"nominal", "2 mm", "3 mm", "4 mm"}
    assert set(kinds) == {"pi", "adaptive_pi", "dob_pi", "dob_adaptive_pi", "fsp_pi",
                          "fsp_adaptive_pi", "pid_test"}
    # and the corners of the [design] set (defaults: gain x0.2 and x5, dead time +-20 %)
    design = load_scenario(SHIPPED).design
    dead = load_scenario(SHIPPED).nominal_plant.dead_time_s
    plants |= {f"design corner G x{g:g} L {d:g} s" for g in design.gain_ratio_range
               for d in (0.8 * dead, 1.2 * dead)}
    analysed = {(r["controller"], r["plant"]) for r in rows if r["analysable"] == "True"}
    assert analysed == {(k, p) for k in kinds for p in plants}
    # the constant feed has no linear model: listed by name, not analysed
    assert [r["controller"] for r in rows if r["analysable"] == "False"] == ["constant"]
    pi_nominal = next(r for r in rows if r["controller"] == "pi" and r["plant"] == "nominal")
    # the design rule asks 60 deg with theta = L + Tc/2; the sensor's 20 Hz low-pass takes
    # about atan(3.77 / 125.7) = 1.7 deg more
    assert float(pi_nominal["phase_margin_deg"]) == pytest.approx(60.0 - 1.7, abs=0.3)
    for name in ["analysis.png", *(f"analysis_{k}.png" for k in kinds)]:
        assert (out / name).stat().st_size > 50_000, name


def test_written_margins_are_python_controls_on_the_returned_objects(analyzed):
    """For every analysable kind and plant, control.stability_margins on open_loop gives the
    numbers acc analyze wrote, and the loop a user assembles from the returned controller,
    sensor and plant (FRD arithmetic, L = (K_e - K_y) H P, the error input and minus the
    force input) is open_loop's response at every frequency (so its margins are these); the
    peaks of S and T, and max |Q Delta|, likewise.  The CSV holds Python's shortest
    round-trip repr, so the match is to 1e-12."""
    _, rows, _ = analyzed
    sc = load_scenario(SHIPPED).with_values({"controller.pid_kd_s_per_N": 2e-4})
    checked = 0
    for r in rows:
        if r["analysable"] != "True" or r["plant"].startswith("design corner"):
            continue  # the corners: tests/test_tune_options.py
        kind, depth = r["controller"], (None if r["plant"] == "nominal" else
                                         float(r["plant"].removesuffix(" mm")))
        L = analysis.open_loop(sc, depth, kind)
        gm, pm, _, _, wgc, _ = control.stability_margins(L)
        K = analysis.controller(sc, depth, kind, delay="frd")
        ke = K.frdata[0, 0]
        ky = K.frdata[0, 1] if K.ninputs == 2 else 0.0
        HP = analysis.sensor(sc, delay="frd").frdata[0, 0] * analysis.plant(
            sc, depth, delay="frd").frdata[0, 0]
        np.testing.assert_array_equal(K.omega, L.omega)
        np.testing.assert_allclose((ke - ky) * HP, L.frdata[0, 0], rtol=1e-12, atol=0.0)
        np.testing.assert_allclose(
            (gm, pm, wgc),
            [float(r["gain_margin"]), float(r["phase_margin_deg"]), float(r["crossover_rad_s"])],
            rtol=1e-12,
        )
        S = analysis.sensitivity(sc, depth, kind)
        T = analysis.complementary_sensitivity(sc, depth, kind)
        assert np.abs(S.frdata).max() == pytest.approx(float(r["peak_sensitivity"]), rel=1e-12)
        assert np.abs(T.frdata).max() == pytest.approx(
            float(r["peak_complementary_sensitivity"]), rel=1e-12
        )
        if kind.startswith("dob"):
            qd = analysis.observer_loop(sc, depth, kind)
            assert np.abs(qd.frdata).max() == pytest.approx(float(r["dob_max_delta_q"]),
                                                            rel=1e-12)
        checked += 1
    assert checked == 7 * 4
    # the published numbers (README): PI nominal GM 3.04, PM 58.3 deg, k/kn 3.08;
    # dob_pi nominal PM 28.9 deg (28.2 before the observer's command path read the held
    # command, as the sampled observer does; the sampled loop's is 28.8)
    row = {(r["controller"], r["plant"]): r for r in rows}
    assert float(row["pi", "nominal"]["gain_margin"]) == pytest.approx(3.04, abs=0.005)
    assert float(row["pi", "nominal"]["max_gain_ratio_sampled"]) == pytest.approx(3.08,
                                                                                 abs=0.005)
    assert float(row["dob_pi", "nominal"]["phase_margin_deg"]) == pytest.approx(28.9, abs=0.05)


def test_acc_analyze_bad_scenario_is_one_line(capsys, tmp_path):
    assert main(["analyze", "missing.toml", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def _independent_gain_limit(kind: str) -> float:
    """Largest k/kn of the sampled loop, from its characteristic polynomial written here.

    Plant ``k a K2 / ((s + a)(s - p2))`` by ZOH at T_c with N = L/T_c periods of delay, the
    PI in feed units ``F (kp + ki T_c/(z - 1))``; with the observer (Eqs. 10-11)
    ``u = C e - d_hat``, ``d_hat = F_Q f - G_Q z^-N u`` (F_Q = Q P_n0^-1 by FOH, G_Q = Q by
    ZOH), so ``(1 - G_Q z^-N) + k (C + F_Q) P z^-N = 0``, multiplied out."""
    import control

    sc = Scenario().with_values({"controller.kind": kind, "sensor.lowpass_cutoff_hz": 0.0})
    spec = loop_spec(sc, None, kind)
    a, k2, p2 = spec.bandwidth_rad_s, spec.k2_N_min_per_mm_s, spec.p2_rad_s
    tc, feed = spec.control_period_s, spec.programmed_feed_mm_min
    n = round(spec.dead_time_s / tc)
    zoh = control.c2d(control.tf([a * k2], np.polymul([1, a], [1, -p2])), tc, "zoh")
    num_p, den_p = np.squeeze(zoh.num[0][0]), np.squeeze(zoh.den[0][0])
    num_c = feed * np.array([spec.kp_per_N, spec.ki_per_N_s * tc - spec.kp_per_N])
    shift = np.zeros(n + 1)
    shift[0] = 1.0  # z^N
    if spec.dob_tau_s is None:
        one = np.polymul(np.polymul(shift, [1.0, -1.0]), den_p)  # z^N (z - 1) den_p
        other = np.polymul(num_c, num_p)
    else:
        tau = spec.dob_tau_s
        q_den = np.poly([-1 / tau] * 3) * tau**3
        f_q = control.c2d(
            control.tf([1.0], q_den) * control.tf([1.0, a - p2, -a * p2], [a * k2]), tc, "foh"
        )
        g_q = control.c2d(control.tf([1.0], q_den), tc, "zoh")
        num_f, den_f = np.squeeze(f_q.num[0][0]), np.squeeze(f_q.den[0][0])
        num_g, den_g = np.squeeze(g_q.num[0][0]), np.squeeze(g_q.den[0][0])
        one = np.polymul(
            np.polymul(np.polysub(np.polymul(den_g, shift), num_g), [1.0, -1.0]),
            np.polymul(den_f, den_p),
        )
        c_plus_f = np.polyadd(np.polymul(num_c, den_f), np.polymul(num_f, [1.0, -1.0]))
        other = np.polymul(np.polymul(c_plus_f, num_p), den_g)

    def stable(k: float) -> bool:
        return np.abs(np.roots(np.polyadd(one, k * other))).max() < 1.0

    assert stable(1.0)
    k = 1.0
    while stable(k + 0.01):
        k += 0.01
    lo, hi = k, k + 0.01
    while hi - lo > 1e-6:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


@pytest.mark.parametrize("kind", ["pi", "dob_pi"])
def test_largest_gain_ratio_equals_the_characteristic_equation_written_here(kind):
    sc = Scenario().with_values({"controller.kind": kind, "sensor.lowpass_cutoff_hz": 0.0})
    got = max_gain_ratio(loop_spec(sc, None, kind))
    assert got == pytest.approx(_independent_gain_limit(kind), rel=1e-3)


@pytest.mark.parametrize("model", ["sampled", "continuous"])
def test_closed_loop_state_matrix_is_affine_in_the_plant_gain(model, monkeypatch):
    """The bisection's ``A(k) = A0 + k A1`` (two assembled loops) against the loop python-
    control's interconnect assembles for the plant gain times k, at k = 0.3, 2.7 and 6, for
    every analysable kind (the observer loop alone too): equal state matrices, entry by
    entry to 1e-9, and to 1e-9 of the largest entry the plant gain moves (both realise the
    blocks in the same order; they differ in rounding; the Pade loop's entries span some 13
    decades, so a tolerance on its largest entry would hide an error in the plant's)."""
    from acc.design import analysis as an
    from acc.design import linear

    def python_control(blocks, name, inputs, outputs):
        return control.interconnect(blocks, name=name, inputs=inputs, outputs=outputs)

    sc = load_scenario(SHIPPED)
    build = {"sampled": sampled_closed_loop, "continuous": an.continuous_closed_loop}[model]
    for kind in analysis.analysable_kinds():
        spec = loop_spec(sc, 4.0, kind)
        for with_pi in (True, False) if spec.has_observer else (True,):
            a0, a1, discrete = an.closed_loop_matrices(spec, model, with_pi)
            assert discrete == (model == "sampled")
            for k in (0.3, 2.7, 6.0):
                with monkeypatch.context() as m:
                    m.setattr(linear, "connect", python_control)
                    direct = np.asarray(build(spec.with_gain_ratio(k), with_pi=with_pi).A)
                np.testing.assert_allclose(a0 + k * a1, direct, rtol=1e-9,
                                           atol=1e-9 * np.abs(a1).max())


def test_frd_margins_are_python_controls_stability_margins():
    """analysis.frd_margins against control.stability_margins (gm, pm and both crossover
    frequencies) on the exact-delay loop of every analysable kind on the nominal plant and
    the design set's stiffest corner (gain x5: the least gain margin, several phase crossings
    near it), and of the shipped kind at every table depth: equal to 1e-12 (the same spline
    and root search; only the crossings that cannot win are not refined)."""
    from acc.design.analysis import design_corner_spec, frd_margins

    sc = load_scenario(SHIPPED)
    for kind in analysis.analysable_kinds():
        depths = (None, 2.0, 3.0, 4.0) if kind == sc.controller.kind else (None,)
        specs = [loop_spec(sc, d, kind) for d in depths]
        specs.append(design_corner_spec(sc, kind, 5.0, 0.12))
        for spec in specs:
            L = analysis.open_loop(spec)
            gm, pm, _, wpc, wgc, _ = control.stability_margins(L)
            got = frd_margins(L.frdata.ravel(), L.omega)
            np.testing.assert_allclose(got, [gm, pm, wpc, wgc], rtol=1e-12)
    # conditionally stable: the first phase crossing (|L| 29) is not the margin; the second
    # (GM 1.88 at 15 rad/s) is, among dozens the dead time adds above it
    w = analysis.OMEGA_RAD_S
    s = 1j * w
    L = 2.0 * (s / 0.5 + 1) ** 2 / s**3 * np.exp(-0.1 * s)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(control.frd(L, w))
    assert gm == pytest.approx(1.878, abs=1e-3)
    np.testing.assert_allclose(frd_margins(L, w), [gm, pm, wpc, wgc], rtol=1e-12)
