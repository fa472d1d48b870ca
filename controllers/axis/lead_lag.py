"""Peng's digital position loop: lead-lag D(z), D/A converter and switched integral action.

Seed 000, Sec. 2.3.3 (Eqs. 2.19-2.30) and Sec. 4.4.2 (4.106-4.107, spec A0-7).  Error in
counts ``E = X_r - X_a`` (2.19); filter ``D(z) = K_p (z + a)/(z + b)`` (2.20); D/A gain
``K_d`` [V/count]::

    V_c(k)   = K_p K_d E(k) + V_d(k)                        (2.30)
    V_d(k+1) = -b V_d(k) + K_p K_d (a - b) E(k)              (2.29)

so ``V_c(z)/E(z) = K_p K_d (z + a)/(z + b)`` (2.26), with no computational delay (``V_c(k)``
uses ``X_a(k)``).  Peng's filter is ``D(z) = 2.5 (z - 0.8825)/z`` (L598).  ``b = -1`` puts an
integrator in ``D`` (``b' = 0``: a Type-2 loop, Sec. 4.2.1 Case 2).

Integral action (A0-7), added to ``V_c`` before the output limit:

=======================  ========================================================================
``"discrete_parallel"``  ``V_i(k) = K_d k_i I(k)``, ``I(k) = I(k-1) + E(k)`` (``k_i`` per sample)
``"continuous_CI"``      Tustin of ``K_d C_I / s`` (4.107): ``V_i(k) = V_i(k-1) +
                         K_d C_I (T/2) (E(k) + E(k-1))`` (``C_I`` in 1/s)
=======================  ========================================================================

The thesis's ``C_I = 0.5`` has no stated scaling in the DMC-230 (spec O-12), so both forms
are offered with their own units.  Switching (Sec. 4.4.2): the integrator is off from
``integrator_off_from_s`` until ``integrator_on_from_s``, its state frozen (default) or
reset meanwhile.

Units: the workbench measures position in mm; the error in counts is ``E = c (x_r - x)``
with ``c`` counts/mm (the encoder's, given when the records are built), so every gain in
the records is per mm.  Defaults follow the spec: ``K_d = 0.078125 = 10/128`` V/count
(App. A prints 0.0781; the structural entries of the printed G(T) imply 0.078125, spec O-6).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import delay_size, init_states, jit, record, register_element

#: Integral-action forms and their codes in compiled records.
INTEGRATOR_FORMS = {"none": 0, "discrete_parallel": 1, "continuous_CI": 2}
#: What the integrator does while switched off.
INTEGRATOR_WHEN_OFF = ("frozen", "reset")


@dataclass(frozen=True)
class LeadLagParams:
    """Peng's position controller ``V_c = K_d [K_p (z + a)/(z + b) E + integral]``.

    Attributes
    ----------
    gain : float
        ``K_p`` [-] (2.5).
    zero : float
        ``a`` of ``(z + a)`` [-] (-0.8825).
    pole : float
        ``b`` of ``(z + b)`` [-] (0), with ``|b| <= 1``.
    dac_gain_V_per_count : float
        ``K_d`` [V/count] (0.078125).
    integrator_form : {"none", "discrete_parallel", "continuous_CI"}
    integrator_gain_per_sample : float
        ``k_i`` of ``"discrete_parallel"`` [1/sample].
    integrator_gain_1_s : float
        ``C_I`` of ``"continuous_CI"`` [1/s] (Peng: 0.5, scaling unstated).
    integrator_off_from_s, integrator_on_from_s : float
        Integrator switched off for ``off <= t < on`` [s] (default: never off).
    integrator_when_off : {"frozen", "reset"}
    computational_delay_samples : int
        Control periods between reading the encoder and applying ``V_c`` (0: thesis).
    output_limit_V : float
        ``|V_c|`` limit [V]; 0 = none (thesis; the DMC-230 DAC gives +-10 V).
    """

    gain: float = 2.5
    zero: float = -0.8825
    pole: float = 0.0
    dac_gain_V_per_count: float = 0.078125
    integrator_form: str = "none"
    integrator_gain_per_sample: float = 0.0
    integrator_gain_1_s: float = 0.0
    integrator_off_from_s: float = math.inf
    integrator_on_from_s: float = math.inf
    integrator_when_off: str = "frozen"
    computational_delay_samples: int = 0
    output_limit_V: float = 0.0

    def __post_init__(self) -> None:
        for name in ("gain", "zero", "pole", "dac_gain_V_per_count", "integrator_gain_per_sample",
                     "integrator_gain_1_s", "output_limit_V"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"{name} must be a finite number, got {v!r}")
        if not self.dac_gain_V_per_count > 0:
            raise ValueError(f"dac_gain_V_per_count must be > 0, got {self.dac_gain_V_per_count}")
        if not abs(self.pole) <= 1.0:
            raise ValueError(f"pole must satisfy |pole| <= 1 (a stable filter), got {self.pole}")
        if self.output_limit_V < 0:
            raise ValueError(f"output_limit_V must be >= 0, got {self.output_limit_V}")
        if self.integrator_form not in INTEGRATOR_FORMS:
            raise ValueError(
                f"integrator_form must be one of {', '.join(INTEGRATOR_FORMS)}, got "
                f"{self.integrator_form!r}"
            )
        if self.integrator_when_off not in INTEGRATOR_WHEN_OFF:
            raise ValueError(
                f"integrator_when_off must be one of {', '.join(INTEGRATOR_WHEN_OFF)}, got "
                f"{self.integrator_when_off!r}"
            )
        if not self.integrator_off_from_s >= 0 or math.isnan(self.integrator_on_from_s):
            raise ValueError("integrator_off_from_s must be >= 0 and integrator_on_from_s a number")
        if self.integrator_on_from_s < self.integrator_off_from_s:
            raise ValueError("integrator_on_from_s must be >= integrator_off_from_s")
        d = self.computational_delay_samples
        if not (isinstance(d, (int, np.integer)) and d >= 0):
            raise ValueError(f"computational_delay_samples must be a whole number >= 0, got {d!r}")

    @property
    def loop_gain_V_per_count(self) -> float:
        """``K_p K_d`` [V/count] (0.1953 for Peng)."""
        return self.gain * self.dac_gain_V_per_count

    @property
    def dc_gain(self) -> float:
        """``D(1) = K_p (1 + a)/(1 + b)`` [-] (infinite for ``b = -1``)."""
        return math.inf if self.pole == -1.0 else self.gain * (1 + self.zero) / (1 + self.pole)

    def tustin_equivalent(self, period_s: float) -> tuple[float, float, float]:
        """``(K'_p, a', b')`` of (3.44): ``D(s) = K'_p (s + a')/(s + b')`` from ``D(z)`` by
        Tustin, ``K'_p = K_p (1 - a)/(1 - b)``, ``a' = (2/T)(1 + a)/(1 - a)``,
        ``b' = (2/T)(1 + b)/(1 - b)`` [-, rad/s, rad/s]."""
        a, b, t = self.zero, self.pole, period_s
        return (
            self.gain * (1 - a) / (1 - b),
            2.0 / t * (1 + a) / (1 - a),
            2.0 / t * (1 + b) / (1 - b),
        )

    def transfer_function(self, period_s: float) -> Any:
        """``K_d D(z)`` [V/count] as a discrete python-control ``TransferFunction`` from
        ``error_counts`` to ``command_V`` (the integrator, when set, in parallel)."""
        import control

        kd, kp, a, b = self.dac_gain_V_per_count, self.gain, self.zero, self.pole
        tf = control.tf([kd * kp, kd * kp * a], [1.0, b], period_s)
        if self.integrator_form == "discrete_parallel":
            tf = tf + control.tf([kd * self.integrator_gain_per_sample, 0.0], [1.0, -1.0], period_s)
        elif self.integrator_form == "continuous_CI":
            c = kd * self.integrator_gain_1_s * period_s / 2.0
            tf = tf + control.tf([c, c], [1.0, -1.0], period_s)
        return control.tf(tf, inputs=["error_counts"], outputs=["command_V"], name="lead_lag")


# --- compiled element ------------------------------------------------------------------
def _dtypes(ring: int = 8) -> tuple[np.dtype, np.dtype]:
    params = record(
        "position_controller.lead_lag",
        [
            ("kpkd_V_per_mm", "f8"),  # K_p K_d counts/mm
            ("zero", "f8"),
            ("pole", "f8"),
            ("integrator_form", "i8"),
            ("integrator_gain_V_per_mm", "f8"),  # K_d k_i c, or K_d C_I (T/2) c
            ("integrator_off_step", "i8"),
            ("integrator_on_step", "i8"),
            ("reset_when_off", "b1"),
            ("delay_samples", "i8"),
            ("ring_mask", "i8"),
            ("output_limit_V", "f8"),
        ],
    )
    state = record(
        "position_controller.lead_lag",
        [
            ("lead_state_V", "f8"),  # V_d
            ("integral_V", "f8"),
            ("previous_error_mm", "f8"),
            ("head", "i8"),
            ("history_V", "f8", (ring,)),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At rest: no stored error, no past command."""
    s.lead_state_V = 0.0
    s.integral_V = 0.0
    s.previous_error_mm = 0.0
    s.head = 0
    for i in range(s.history_V.shape[0]):
        s.history_V[i] = 0.0


@jit
def lead_lag_law(p, s, k: int, error_mm: float) -> float:  # noqa: ANN001
    """One control period of (2.29)/(2.30) plus the integrator, limit and delay: error
    ``x_r - x`` [mm] at plant step ``k`` in, ``V_c`` [V] out."""
    e = error_mm
    v = p.kpkd_V_per_mm * e + s.lead_state_V
    s.lead_state_V = -p.pole * s.lead_state_V + p.kpkd_V_per_mm * (p.zero - p.pole) * e
    if p.integrator_form != 0:
        on = k < p.integrator_off_step or k >= p.integrator_on_step
        if on:
            if p.integrator_form == 1:
                s.integral_V += p.integrator_gain_V_per_mm * e
            else:
                s.integral_V += p.integrator_gain_V_per_mm * (e + s.previous_error_mm)
        elif p.reset_when_off:
            s.integral_V = 0.0
        v += s.integral_V
    s.previous_error_mm = e
    if p.output_limit_V > 0.0:
        if v > p.output_limit_V:
            v = p.output_limit_V
        elif v < -p.output_limit_V:
            v = -p.output_limit_V
    s.history_V[s.head] = v
    out = s.history_V[(s.head - p.delay_samples) & p.ring_mask]
    s.head = (s.head + 1) & p.ring_mask
    return out


@jit
def step(p, s, k, reference_mm, reference_velocity_mm_s, reference_acceleration_mm_s2,  # noqa: ANN001
         measured_position_mm, measured_velocity_mm_s, measured_acceleration_mm_s2) -> float:
    """Controller slot: the position error in, the velocity command ``V_c`` [V] out."""
    return lead_lag_law(p, s, k, reference_mm - measured_position_mm)


LEAD_LAG = register_element(
    "position_controller.lead_lag",
    _dtypes,
    init,
    step,
    "Peng's lead-lag D(z) with D/A gain (2.29)-(2.30), switched integrator (4.107)",
)


def lead_lag_records(
    controllers: LeadLagParams | Sequence[LeadLagParams],
    counts_per_mm: ArrayLike,
    control_period_s: float,
    plant_step_s: float | None = None,
    *,
    runs: int | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of lead-lag controllers.

    Parameters
    ----------
    controllers : LeadLagParams or sequence of them, length runs
    counts_per_mm : array_like, shape (runs,) or scalar
        Encoder counts per mm of each run's axis.
    control_period_s : float
        ``T`` [s] (the filter's sample time).
    plant_step_s : float, optional
        The engine's plant step [s] (default: the control period); the integrator switching
        times are converted to plant steps (rounded up).
    runs : int, optional
        Batch size when ``controllers`` is one parameter set.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    if isinstance(controllers, LeadLagParams):
        controllers = [controllers] * (1 if runs is None else int(runs))
    ctrls = list(controllers)
    n = len(ctrls)
    cpm = np.broadcast_to(np.asarray(counts_per_mm, dtype=float), (n,))
    dt = control_period_s if plant_step_s is None else plant_step_s
    delay = max(c.computational_delay_samples for c in ctrls)
    params, state = LEAD_LAG.records(n, ring=delay_size(delay + 1))

    def to_step(t: float) -> int:
        return np.iinfo(np.int64).max if math.isinf(t) else int(math.ceil(t / dt - 1e-9))

    for r, c in enumerate(ctrls):
        row = params[r]
        kd_c = c.dac_gain_V_per_count * cpm[r]
        row["kpkd_V_per_mm"] = c.gain * kd_c
        row["zero"] = c.zero
        row["pole"] = c.pole
        row["integrator_form"] = INTEGRATOR_FORMS[c.integrator_form]
        if c.integrator_form == "discrete_parallel":
            row["integrator_gain_V_per_mm"] = kd_c * c.integrator_gain_per_sample
        elif c.integrator_form == "continuous_CI":
            row["integrator_gain_V_per_mm"] = kd_c * c.integrator_gain_1_s * control_period_s / 2
        row["integrator_off_step"] = to_step(c.integrator_off_from_s)
        row["integrator_on_step"] = to_step(c.integrator_on_from_s)
        row["reset_when_off"] = c.integrator_when_off == "reset"
        row["delay_samples"] = c.computational_delay_samples
        row["output_limit_V"] = c.output_limit_V
    params["ring_mask"] = state.dtype["history_V"].shape[0] - 1
    return params, init_states(params, state)


__all__ = [
    "INTEGRATOR_FORMS",
    "INTEGRATOR_WHEN_OFF",
    "LEAD_LAG",
    "LeadLagParams",
    "lead_lag_law",
    "lead_lag_records",
]
