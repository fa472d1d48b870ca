"""Optional resonant term of the override PI: an internal model of a sinusoid at ``f0``.

A periodic force disturbance at a known frequency (the spindle-frequency runout) is rejected
by a resonator on the force error added to the PI output (the internal-model principle).  At
control period ``T_c`` with ``W = 2 pi f0 T_c`` [rad], pole radius ``r = exp(-zeta W)`` (a
small damping ``zeta`` for robustness to a mistuned frequency) and phase lead ``phi``:

.. math:: R(z) = k_r T_c \\frac{z\\,(z \\cos\\varphi - r \\cos(W - \\varphi))}
                 {z^2 - 2 r \\cos W\\, z + r^2}

whose impulse response is ``k_r T_c r^k cos(W k + phi)`` (the impulse-invariant form of
``k_r (s cos phi - w0 sin phi) / (s^2 + w0^2)``).  As a difference equation on the force
error ``e[k]`` [N], output ``u[k]`` [override, -]:

``u[k] = k_r T_c (cos(phi) e[k] - r cos(W - phi) e[k-1]) + 2 r cos(W) u[k-1] - r^2 u[k-2]``.

The phase lead ``phi`` is given by the scenario (``resonant_phase_deg``), not computed from
the model: it compensates the loop's phase at ``f0`` (drive lag, sensor low-pass, dead time).
The resonator runs whether or not the override is clamped (``r < 1`` keeps it bounded).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from acc.engine.element import jit


@dataclass(frozen=True)
class ResonantOptions:
    """``[controller]`` options of the resonant term of the PI-based kinds.

    Attributes
    ----------
    resonant_frequency_hz : float
        Resonance ``f0`` [Hz], >= 0 and below half the control rate; 0: no resonant term.
    resonant_gain_per_N_s : float
        ``k_r`` [override per N per s], >= 0.
    resonant_phase_deg : float
        Phase lead ``phi`` of the resonator at ``f0`` [deg], in [-180, 180].
    resonant_damping : float
        Damping ``zeta`` of the resonator's poles [-], in [0, 1).
    """

    resonant_frequency_hz: float = 0.0
    resonant_gain_per_N_s: float = 0.0
    resonant_phase_deg: float = 0.0
    resonant_damping: float = 0.01

    def __post_init__(self) -> None:
        if not self.resonant_frequency_hz >= 0:
            raise ValueError("resonant_frequency_hz must be >= 0")
        if not self.resonant_gain_per_N_s >= 0:
            raise ValueError("resonant_gain_per_N_s must be >= 0")
        if not -180.0 <= self.resonant_phase_deg <= 180.0:
            raise ValueError("resonant_phase_deg must be in [-180, 180]")
        if not 0.0 <= self.resonant_damping < 1.0:
            raise ValueError("resonant_damping must be in [0, 1)")

    @property
    def enabled(self) -> bool:
        """True if the resonant term is on (``f0 > 0``)."""
        return self.resonant_frequency_hz > 0

    def coefficients(self, control_period_s: float) -> tuple[float, float, float, float]:
        """``(b0, b1, a1, a2)`` of ``R(z) = (b0 z^2 + b1 z) / (z^2 + a1 z + a2)``.

        Parameters
        ----------
        control_period_s : float
            ``T_c`` [s]; ``f0 T_c`` must be below 1/2 (ValueError naming the key).
        """
        w = 2.0 * math.pi * self.resonant_frequency_hz * control_period_s
        if not w < math.pi:
            raise ValueError("resonant_frequency_hz must be below half the control rate")
        r = math.exp(-self.resonant_damping * w)
        phi = math.radians(self.resonant_phase_deg)
        g = self.resonant_gain_per_N_s * control_period_s
        return g * math.cos(phi), -g * r * math.cos(w - phi), -2.0 * r * math.cos(w), r * r


def refuse_resonant(params: object) -> None:
    """ValueError naming the key if a run's ``[controller]`` has the resonant term on: the
    linear loop of ``acc analyze`` and ``acc tune`` does not model it."""
    if params.group(ResonantOptions).enabled:  # type: ignore[attr-defined]
        raise ValueError(
            "controller.resonant_frequency_hz: the linear analysis does not model the "
            "resonant term; set it to 0 to analyse the loop"
        )


#: Per-run parameters of the resonant term (a nested field of the PI-based controllers'
#: params records): on flag and ``R(z) = (b0 z^2 + b1 z) / (z^2 + a1 z + a2)``.
RESONATOR_PARAMS = np.dtype(
    [("on", "b1"), ("b0", "f8"), ("b1", "f8"), ("a1", "f8"), ("a2", "f8")], align=True
)
#: Its state: ``e[k-1]`` [N], ``u[k-1]``, ``u[k-2]`` [-].
RESONATOR_STATE = np.dtype(
    [("last_error_N", "f8"), ("last_out", "f8"), ("second_last_out", "f8")], align=True
)


def resonator_records(options: list[ResonantOptions], control_period_s: float) -> np.ndarray:
    """Per-run :data:`RESONATOR_PARAMS`, shape (runs,) (``on`` False and zeros without it)."""
    out = np.zeros(len(options), dtype=RESONATOR_PARAMS)
    for i, o in enumerate(options):
        if o.enabled:
            out["on"][i] = True
            out["b0"][i], out["b1"][i], out["a1"][i], out["a2"][i] = o.coefficients(
                control_period_s
            )
    return out


@jit
def resonator_reset(rs) -> None:  # noqa: ANN001
    """The resonator at rest."""
    rs.last_error_N = 0.0
    rs.last_out = 0.0
    rs.second_last_out = 0.0


@jit
def resonator_update(rp, rs, error_N: float) -> float:  # noqa: ANN001
    """``u[k]`` from ``e[k]`` and the state (module docstring); advances the state."""
    u = rp.b0 * error_N + rp.b1 * rs.last_error_N - rp.a1 * rs.last_out - rp.a2 * rs.second_last_out
    rs.last_error_N = error_N
    rs.second_last_out = rs.last_out
    rs.last_out = u
    return u


__all__ = [
    "RESONATOR_PARAMS",
    "RESONATOR_STATE",
    "ResonantOptions",
    "refuse_resonant",
    "resonator_records",
    "resonator_reset",
    "resonator_update",
]
