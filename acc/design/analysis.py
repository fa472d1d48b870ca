"""Frequency-domain and stability analysis of the force loop with PI, adaptive PI and DOB.

Continuous loop, exact dead time.  With the plant ``P = P0 e^{-L s}`` (Eq. 8, times the
sensor low-pass when the scenario has one), the override PI ``C(s) = F (kp + ki / s)``
[(mm/min)/N] and the sample-and-hold of a controller of period ``T_c`` taken as
``e^{-s T_c / 2}`` (the rule of :mod:`controllers.pi_design`), the loop broken at the
force is

* PI: ``L = C P e^{-s T_c/2}``;
* DOB + PI (:mod:`controllers.disturbance_observer`): the controller from force to command
  is ``K = (C + Q P_{n0}^{-1}) / (1 - Q e^{-L_n s})`` and ``L = K P e^{-s T_c/2}``.

Margins come from python-control's :func:`control.stability_margins` on the exact-delay
frequency response (an FRD), so no Pade enters them; ``S = 1 / (1 + L)``,
``T = L / (1 + L)``.  The adaptive PI with a converged estimate has, at every depth, the
designed loop (its gains are rescaled to the plant), so its margins are the design's.

DOB robust stability: ``max_w |Delta(jw) Q(jw)| < 1`` with ``Delta = P / Pn - 1`` (exact
delays; with equal dead times it is the ratio of the rational parts).

Largest tolerated gain ratio ``k / kn`` (plant ``k P`` against design ``Pn``): found by
bisection on closed-loop stability.  Two models are given:

* ``sampled``: the loop the simulator runs, exactly: ``P0`` discretised with a zero-order
  hold at ``T_c`` times ``z^-N``, the discrete PI, and the observer's own discrete filters
  (closed-loop poles inside the unit circle).  This is the one simulation agrees with.
* ``continuous``: the continuous loop above with the delays replaced by Pade approximants
  (order :data:`PADE_ORDER`), for the design view of the paper.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import numpy as np
from numpy.typing import NDArray

from acc.scenario import Scenario
from controllers.disturbance_observer import observer_filters
from controllers.linear_loop import LoopSpec
from controllers.q_filter import q_filter, q_frequency_response
from controllers.registry import controller_kind, controller_kinds

#: Pade order for delays in rational (continuous) closed loops.
PADE_ORDER = 10
#: Frequency grid of the FRD analysis [rad/s].
OMEGA_RAD_S = np.logspace(-2, np.log10(2000.0), 4000)


class NotAnalysableError(ValueError):
    """A controller kind without a linear model (its registration has no ``linear_loop``)."""


def plant_spec(scenario: Scenario, radial_depth_mm: float | None = None) -> LoopSpec:
    """The loop of a scenario at a table depth (None: the nominal plant itself), with no
    controller yet (gains 0): plant, design model, feed, control period, sensor filter."""
    n = scenario.nominal_plant
    if radial_depth_mm is None:
        k2, p2 = n.k2_N_min_per_mm_s, n.p2_rad_s
    else:
        k2a, p2a = scenario.force_process.parameters([radial_depth_mm])
        k2, p2 = float(k2a[0]), float(p2a[0])
    return LoopSpec(
        bandwidth_rad_s=scenario.feed_drive.bandwidth_rad_s,
        dead_time_s=scenario.feed_drive.dead_time_s,
        k2_N_min_per_mm_s=k2,
        p2_rad_s=p2,
        nominal_k2_N_min_per_mm_s=n.k2_N_min_per_mm_s,
        nominal_p2_rad_s=n.p2_rad_s,
        nominal_dead_time_s=n.dead_time_s,
        kp_per_N=0.0,
        ki_per_N_s=0.0,
        programmed_feed_mm_min=scenario.controller.programmed_feed_mm_min,
        control_period_s=scenario.simulation.control_period_s,
        sensor_cutoff_hz=scenario.sensor.lowpass_cutoff_hz,
    )


def loop_spec(
    scenario: Scenario, radial_depth_mm: float | None = None, kind: str | None = None
) -> LoopSpec:
    """The loop of a scenario's controller kind at a table depth (None: the nominal plant).

    The kind's registered ``linear_loop`` fills the controller (an adaptive kind with its
    estimate converged to the plant; an observer kind with its Q filter).

    Parameters
    ----------
    scenario : Scenario
    radial_depth_mm : float or None
        Depth whose Table-1 model (times the gain multiplier) is the plant.
    kind : str or None
        Controller kind to analyse (default: the scenario's), with the scenario's options.

    Raises
    ------
    NotAnalysableError
        The kind has no linear model.
    """
    params = scenario.controller
    if kind is not None and kind != params.kind:
        params = params.replace_values({"kind": kind})
    hook = controller_kind(params.kind).linear_loop
    if hook is None:
        raise NotAnalysableError(f"controller kind {params.kind!r} has no linear model")
    return hook(plant_spec(scenario, radial_depth_mm), params, scenario.nominal_plant)


def analysable_kinds() -> tuple[str, ...]:
    """Registered kinds with a linear model."""
    return tuple(n for n, k in controller_kinds().items() if k.linear_loop is not None)


# --- frequency responses (exact delay) ---------------------------------------------------
def plant_response(spec: LoopSpec, omega: NDArray) -> NDArray[np.complex128]:
    """``P(jw)`` [N/(mm/min)] with the exact delay and the sensor low-pass."""
    s = 1j * omega
    a = spec.bandwidth_rad_s
    p = a * spec.k2_N_min_per_mm_s * np.exp(-spec.dead_time_s * s) / ((s + a) * (s - spec.p2_rad_s))
    if spec.sensor_cutoff_hz > 0:
        p = p / (1.0 + s / (2 * math.pi * spec.sensor_cutoff_hz))
    return p


def nominal_rational_response(spec: LoopSpec, omega: NDArray) -> NDArray[np.complex128]:
    """``Pn0(jw)``, the delay-free nominal plant."""
    s = 1j * omega
    a = spec.bandwidth_rad_s
    return a * spec.nominal_k2_N_min_per_mm_s / ((s + a) * (s - spec.nominal_p2_rad_s))


def controller_response(spec: LoopSpec, omega: NDArray) -> NDArray[np.complex128]:
    """Force-to-command controller ``K(jw)`` [(mm/min)/N] including the hold's half period."""
    s = 1j * omega
    if spec.is_pi:
        c = spec.programmed_feed_mm_min * (spec.kp_per_N + spec.ki_per_N_s / s)
    else:
        num, den = spec.continuous_controller
        c = np.polyval(num, s) / np.polyval(den, s)
    if spec.dob_tau_s is not None:
        q = q_frequency_response(omega, spec.dob_tau_s)
        c = (c + q / nominal_rational_response(spec, omega)) / (
            1.0 - q * np.exp(-spec.nominal_dead_time_s * s)
        )
    return c * np.exp(-s * spec.control_period_s / 2.0)


def loop_response(spec: LoopSpec, omega: NDArray = OMEGA_RAD_S) -> NDArray[np.complex128]:
    """Loop gain ``L(jw) = K(jw) P(jw)`` [-]."""
    return controller_response(spec, omega) * plant_response(spec, omega)


@dataclass(frozen=True)
class LoopMargins:
    """Margins of one loop (exact delay).

    Attributes
    ----------
    gain_margin : float
        [-] (inf if the phase never crosses -180 deg).
    phase_margin_deg : float
    crossover_rad_s : float
        Gain crossover [rad/s].
    phase_crossover_rad_s : float
    peak_sensitivity : float
        ``max |S|`` [-].
    peak_complementary_sensitivity : float
        ``max |T|`` [-].
    """

    gain_margin: float
    phase_margin_deg: float
    crossover_rad_s: float
    phase_crossover_rad_s: float
    peak_sensitivity: float
    peak_complementary_sensitivity: float


def margins(spec: LoopSpec, omega: NDArray = OMEGA_RAD_S) -> LoopMargins:
    """Margins and sensitivity peaks of a loop from its exact-delay frequency response."""
    L = loop_response(spec, omega)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(control.frd(L, omega))
    S = 1.0 / (1.0 + L)
    return LoopMargins(
        float(gm),
        float(pm),
        float(wgc),
        float(wpc),
        float(np.abs(S).max()),
        float(np.abs(L * S).max()),
    )


def dob_robustness(spec: LoopSpec, omega: NDArray = OMEGA_RAD_S) -> float:
    """``max_w |Delta(jw) Q(jw)|`` with ``Delta = P / Pn - 1`` (exact delays); < 1 is robust."""
    if spec.dob_tau_s is None:
        raise ValueError("the loop has no disturbance observer (dob_tau_s is None)")
    s = 1j * omega
    pn = nominal_rational_response(spec, omega) * np.exp(-spec.nominal_dead_time_s * s)
    delta = plant_response(spec, omega) / pn - 1.0
    return float(np.abs(delta * q_frequency_response(omega, spec.dob_tau_s)).max())


# --- closed loops: sampled (exact) and continuous (Pade) ---------------------------------
def _delay_d(n: int, dt: float) -> control.TransferFunction:
    return control.tf([1.0], np.r_[1.0, np.zeros(n)], dt)


def sampled_closed_loop(spec: LoopSpec, with_pi: bool = True) -> control.StateSpace:
    """The closed loop the simulator runs, at the control period (module docstring).

    Input: reference [N]; output: force [N].  The dead times are rounded to whole periods.
    ``with_pi=False`` returns the observer loop alone (input: the PI's feed request).
    """
    Tc = spec.control_period_s
    a = spec.bandwidth_rad_s
    p0 = control.tf([a * spec.k2_N_min_per_mm_s], np.polymul([1.0, a], [1.0, -spec.p2_rad_s]))
    if spec.sensor_cutoff_hz > 0:
        p0 = p0 * control.tf([1.0], [1.0 / (2 * math.pi * spec.sensor_cutoff_hz), 1.0])
    n_plant = int(round(spec.dead_time_s / Tc))
    plant = control.ss(control.c2d(p0, Tc, "zoh") * _delay_d(n_plant, Tc))
    F = spec.programmed_feed_mm_min
    if spec.is_pi:
        pi = control.ss(
            control.tf(
                [F * spec.kp_per_N, F * (spec.ki_per_N_s * Tc - spec.kp_per_N)], [1.0, -1.0], Tc
            )
        )
    else:
        pi = control.ss(control.tf(*spec.discrete_controller, Tc))
    if spec.dob_tau_s is None:
        return control.feedback(pi * plant, 1)
    filt = observer_filters(q_filter(spec.dob_tau_s), Tc)
    kn, pn = spec.nominal_k2_N_min_per_mm_s, spec.nominal_p2_rad_s
    comb = np.array([[1.0, a - pn, -a * pn]]) / (a * kn)
    bank = filt.force_bank
    qy = control.ss(bank.A, bank.B, comb @ bank.C, comb @ bank.D, Tc)
    n_nom = int(round(spec.nominal_dead_time_s / Tc))
    qu = control.ss(filt.input_filter) * control.ss(_delay_d(n_nom, Tc))
    inner = control.feedback(control.ss([], [], [], [[1.0]], Tc), qu, sign=1)
    # u = inner (C (r - y) - Qy y): the observer loop first, then the PI around it
    observed = control.feedback(inner * plant, qy)
    return control.feedback(pi * observed, 1) if with_pi else observed


def continuous_closed_loop(
    spec: LoopSpec, with_pi: bool = True, pade_order: int = PADE_ORDER
) -> control.StateSpace:
    """The continuous loop with Pade delays (hold half-period included); input r, output f.

    ``with_pi=False`` returns the observer loop alone, whose characteristic equation for
    ``P = k Pn`` without dead time is ``(tau s + 1)^3 + k - 1 = 0`` (stable for ``0 < k < 9``).
    """
    a = spec.bandwidth_rad_s

    def delay(t: float) -> control.TransferFunction:
        if t <= 0:
            return control.tf([1.0], [1.0])
        return control.tf(*control.pade(t, pade_order))

    p0 = control.tf([a * spec.k2_N_min_per_mm_s], np.polymul([1.0, a], [1.0, -spec.p2_rad_s]))
    if spec.sensor_cutoff_hz > 0:
        p0 = p0 * control.tf([1.0], [1.0 / (2 * math.pi * spec.sensor_cutoff_hz), 1.0])
    plant = control.ss(p0 * delay(spec.dead_time_s + spec.control_period_s / 2.0))
    F = spec.programmed_feed_mm_min
    if spec.is_pi:
        c = control.ss(control.tf([F * spec.kp_per_N, F * spec.ki_per_N_s], [1.0, 0.0]))
    else:
        c = control.ss(control.tf(*spec.continuous_controller))
    if spec.dob_tau_s is None:
        return control.feedback(c * plant, 1)
    q = q_filter(spec.dob_tau_s)
    kn, pn = spec.nominal_k2_N_min_per_mm_s, spec.nominal_p2_rad_s
    qy = control.ss(q * control.tf(np.polymul([1.0, a], [1.0, -pn]), [a * kn]))
    qu = control.ss(q * delay(spec.nominal_dead_time_s))
    inner = control.feedback(control.ss([], [], [], [[1.0]]), qu, sign=1)
    observed = control.feedback(inner * plant, qy)
    return control.feedback(c * observed, 1) if with_pi else observed


def is_stable(sys: control.StateSpace) -> bool:
    """Closed-loop stability from the poles (unit circle for discrete, left half-plane)."""
    p = control.poles(sys)
    if len(p) == 0:
        return True
    if sys.isdtime():
        return bool(np.max(np.abs(p)) < 1.0 - 1e-9)
    return bool(np.max(p.real) < -1e-9)


def max_gain_ratio(
    spec: LoopSpec,
    model: str = "sampled",
    k_max: float = 100.0,
    rtol: float = 1e-4,
    with_pi: bool = True,
) -> float:
    """Largest ``k`` with the loop stable for the plant gain times every value in ``[1, k]``.

    Bisection on :func:`is_stable`; returns ``k_max`` if still stable there, 0 if the loop
    is unstable at ``k = 1``.

    Parameters
    ----------
    spec : LoopSpec
    model : {"sampled", "continuous"}
    k_max : float
    rtol : float
        Relative width of the final bracket.
    with_pi : bool
        False: the observer loop alone.
    """
    build = {"sampled": sampled_closed_loop, "continuous": continuous_closed_loop}[model]

    def stable(k: float) -> bool:
        return is_stable(build(spec.with_gain_ratio(k), with_pi=with_pi))

    if not stable(1.0):
        return 0.0
    if stable(k_max):
        return k_max
    lo, hi = 1.0, k_max
    while hi - lo > rtol * lo:
        mid = math.sqrt(lo * hi) if hi / lo > 2 else 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo


__all__ = [
    "LoopMargins",
    "LoopSpec",
    "NotAnalysableError",
    "OMEGA_RAD_S",
    "PADE_ORDER",
    "analysable_kinds",
    "continuous_closed_loop",
    "controller_response",
    "dob_robustness",
    "is_stable",
    "loop_response",
    "loop_spec",
    "margins",
    "max_gain_ratio",
    "plant_response",
    "plant_spec",
    "sampled_closed_loop",
]


# --- the table and the figure of ``acc analyze`` -----------------------------------------
def analysis_table(
    scenario: Scenario, kinds: tuple[str, ...] | None = None
) -> list[dict[str, float | str]]:
    """One row per analysable controller kind and plant (nominal, then every table depth).

    Columns: margins (exact delay), sensitivity peaks, ``max |Delta Q|`` for observer kinds
    and the largest tolerated gain ratio ``k / kn`` (sampled, exact).  Each kind's loop is
    its registered linear model: the adaptive kinds with a converged estimate (gains
    rescaled to the plant; an observer on the estimate then has ``Delta = 0``).

    Parameters
    ----------
    scenario : Scenario
    kinds : tuple of str or None
        Kinds to analyse (default: every analysable registered kind).
    """
    rows: list[dict[str, float | str]] = []
    depths: list[float | None] = [None, *scenario.force_process.radial_depth_mm]
    for kind in kinds if kinds is not None else analysable_kinds():
        for d in depths:
            spec = loop_spec(scenario, d, kind)
            m = margins(spec)
            rows.append(
                {
                    "controller": kind,
                    "plant": "nominal" if d is None else f"{d:g} mm",
                    "k2_N_min_per_mm_s": spec.k2_N_min_per_mm_s,
                    "p2_rad_s": spec.p2_rad_s,
                    "kp_per_N": spec.kp_per_N if spec.is_pi else float("nan"),
                    "ki_per_N_s": spec.ki_per_N_s if spec.is_pi else float("nan"),
                    "gain_margin": m.gain_margin,
                    "phase_margin_deg": m.phase_margin_deg,
                    "crossover_rad_s": m.crossover_rad_s,
                    "peak_sensitivity": m.peak_sensitivity,
                    "peak_complementary_sensitivity": m.peak_complementary_sensitivity,
                    "dob_max_delta_q": dob_robustness(spec) if spec.dob_tau_s else float("nan"),
                    "max_gain_ratio_sampled": max_gain_ratio(spec, "sampled", rtol=1e-3),
                    "max_gain_ratio_continuous": max_gain_ratio(spec, "continuous", rtol=1e-3),
                    "stable_sampled": float(is_stable(sampled_closed_loop(spec))),
                }
            )
    return rows


def plot_analysis(scenario: Scenario, axes: NDArray) -> NDArray:
    """Draw the analysis on four Axes (2 x 2) and return them.

    ``axes[0, 0]``: ``|L|`` of fixed PI and DOB + PI per depth; ``axes[0, 1]``: ``|S|`` and
    ``|T|``; ``axes[1, 0]``: ``|Delta Q|`` per depth against 1; ``axes[1, 1]``: the largest
    tolerated ``k / kn`` against ``tau`` (DOB + PI, and fixed PI for reference).
    """
    w = OMEGA_RAD_S
    depths = scenario.force_process.radial_depth_mm
    ax = axes[0, 0]
    for kind, ls in (("pi", "-"), ("dob_pi", "--")):
        for d in depths:
            ax.loglog(
                w,
                np.abs(loop_response(loop_spec(scenario, d, kind), w)),
                ls,
                label=f"{kind} {d:g} mm",
            )
    ax.axhline(1.0, color="k", lw=0.5)
    ax.set(xlabel="w [rad/s]", ylabel="|L(jw)|", title="Loop gain (exact delay)")
    ax.legend(fontsize=7)
    ax = axes[0, 1]
    for kind, ls in (("pi", "-"), ("dob_pi", "--")):
        for d in depths:
            L = loop_response(loop_spec(scenario, d, kind), w)
            ax.loglog(w, np.abs(1 / (1 + L)), ls, label=f"|S| {kind} {d:g} mm")
            ax.loglog(w, np.abs(L / (1 + L)), ls, alpha=0.4)
    ax.set(xlabel="w [rad/s]", ylabel="|S|, |T| (faint)", title="Sensitivities")
    ax.legend(fontsize=7)
    ax = axes[1, 0]
    for d in depths:
        spec = loop_spec(scenario, d, "dob_pi")
        s = 1j * w
        pn = nominal_rational_response(spec, w) * np.exp(-spec.nominal_dead_time_s * s)
        dq = (plant_response(spec, w) / pn - 1.0) * q_frequency_response(w, spec.dob_tau_s)
        ax.loglog(w, np.abs(dq), label=f"{d:g} mm")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set(xlabel="w [rad/s]", ylabel="|Delta Q|", title="DOB robust stability (< 1)")
    ax.legend(fontsize=7)
    ax = axes[1, 1]
    taus = np.geomspace(0.02, 0.5, 10)
    base = loop_spec(scenario, None, "dob_pi")
    ks = [max_gain_ratio(base.replace(dob_tau_s=float(t)), rtol=1e-2) for t in taus]
    ko = [max_gain_ratio(base.replace(dob_tau_s=float(t)), rtol=1e-2, with_pi=False) for t in taus]
    ax.semilogx(taus, ks, "o-", label="DOB + PI")
    ax.semilogx(taus, ko, "s--", label="observer loop alone")
    ax.axhline(
        max_gain_ratio(loop_spec(scenario, None, "pi"), rtol=1e-2),
        color="k",
        ls=":",
        label="fixed PI",
    )
    ax.axvline(scenario.controller.dob_tau_s, color="gray", lw=0.5)
    ax.set(
        xlabel="tau [s]", ylabel="largest stable k / kn", title="Gain tolerance (sampled, exact)"
    )
    ax.legend(fontsize=7)
    return axes
