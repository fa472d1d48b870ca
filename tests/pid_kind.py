"""A controller kind added from outside the project's packages: a PID on the override.

This module is the worked example of ``docs/adding_a_controller.md``.  Importing it registers
the compiled element ``controller.pid_test`` and the kind ``"pid_test"`` (its keys
``pid_kd_s_per_N`` and ``pid_derivative_filter_s`` become valid in ``[controller]``).

Law, at control instant ``k`` with ``e[k] = r - y[k]``:

``D[k] = (T_f D[k-1] + kd (e[k] - e[k-1])) / (T_f + T_c)`` (backward Euler of
``kd s / (T_f s + 1)``), then the override PI of :func:`controllers.adaptive_pi.pi_law` with
``D[k]`` added inside the clamp, so ``C(z) = kp + ki T_c / (z - 1) + kd (z - 1) / ((T_f + T_c)
z - T_f)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acc.engine.element import init_states, jit, record, register_element
from controllers.adaptive_pi import clamping, pi_law
from controllers.linear_loop import LoopSpec
from controllers.pi_design import PIDesignOptions
from controllers.registry import (
    ControllerKind,
    pi_arguments,
    register_controller,
    resolved_gains,
)


@dataclass(frozen=True)
class PIDOptions:
    """``[controller]`` keys of the ``"pid_test"`` kind.

    Attributes
    ----------
    pid_kd_s_per_N : float
        Derivative gain [override s / N], >= 0.
    pid_derivative_filter_s : float
        Time constant of the derivative's low-pass [s], > 0.
    """

    pid_kd_s_per_N: float = 0.0
    pid_derivative_filter_s: float = 0.02

    def __post_init__(self) -> None:
        if not self.pid_kd_s_per_N >= 0:
            raise ValueError(f"pid_kd_s_per_N must be >= 0, got {self.pid_kd_s_per_N}")
        if not self.pid_derivative_filter_s > 0:
            raise ValueError(
                f"pid_derivative_filter_s must be > 0, got {self.pid_derivative_filter_s}"
            )


# --- the compiled element: records, init, step -------------------------------------------
def _dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "controller.pid_test",
        [
            ("reference_force_N", "f8"),
            ("kp_per_N", "f8"),
            ("ki_per_N_s", "f8"),
            ("kd_s_per_N", "f8"),
            ("derivative_filter_s", "f8"),
            ("override_min", "f8"),
            ("override_max", "f8"),
            ("initial_override", "f8"),
            ("control_period_s", "f8"),
            ("clamping", "b1"),
        ],
    )
    state = record(
        "controller.pid_test", [("integral", "f8"), ("error_N", "f8"), ("derivative", "f8")]
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At rest: integrator at the initial override, zero past error and derivative."""
    s.integral = p.initial_override
    s.error_N = 0.0
    s.derivative = 0.0


@jit
def step(p, s, measured_force_N: float, diagnostics: np.ndarray) -> float:  # noqa: ANN001
    """One control period: measured force [N] in, clamped override [-] out."""
    e = p.reference_force_N - measured_force_N
    tf = p.derivative_filter_s
    s.derivative = (tf * s.derivative + p.kd_s_per_N * (e - s.error_N)) / (
        tf + p.control_period_s
    )
    s.error_N = e
    s.integral, override = pi_law(
        s.integral, e, p.kp_per_N, p.ki_per_N_s, p.control_period_s, s.derivative,
        p.override_min, p.override_max, p.clamping,
    )
    return override


PID_ELEMENT = register_element("controller.pid_test", _dtypes, init, step, "override PID")


# --- the kind: records for a batch, and its linear model ----------------------------------
def records(params, nominal, control_period_s, safe_override):  # noqa: ANN001, ANN201
    """Records of a batch of runs of this kind (the registry's records builder)."""
    common = pi_arguments(params, nominal, control_period_s)
    out, state = PID_ELEMENT.records(len(params))
    for name, value in common.items():
        out[name] = value
    opts = [p.group(PIDOptions) for p in params]
    out["kd_s_per_N"] = [o.pid_kd_s_per_N for o in opts]
    out["derivative_filter_s"] = [o.pid_derivative_filter_s for o in opts]
    out["control_period_s"] = control_period_s
    out["clamping"] = clamping([p.anti_windup for p in params], len(params))
    return out, init_states(out, state)


def linear_loop(spec: LoopSpec, params, nominal) -> LoopSpec:  # noqa: ANN001
    """The PID as continuous and discrete transfer functions [(mm/min)/N]."""
    g = resolved_gains(params, nominal, spec.control_period_s)
    o = params.group(PIDOptions)
    F, Tc = spec.programmed_feed_mm_min, spec.control_period_s
    tf, kd = o.pid_derivative_filter_s, o.pid_kd_s_per_N
    # C(s) = F (kp + ki / s + kd s / (tf s + 1)) over s (tf s + 1)
    num_s = F * np.polyadd(np.polymul([g.kp_per_N, g.ki_per_N_s], [tf, 1.0]), [kd, 0.0, 0.0])
    den_s = np.polymul([1.0, 0.0], [tf, 1.0])
    # C(z) = F (kp + ki Tc / (z - 1) + kd (z - 1) / ((tf + Tc) z - tf))
    dz = [tf + Tc, -tf]
    num_z = F * np.polyadd(
        np.polyadd(np.polymul([g.kp_per_N], np.polymul([1.0, -1.0], dz)),
                   np.polymul([g.ki_per_N_s * Tc], dz)),
        np.polymul([kd], np.polymul([1.0, -1.0], [1.0, -1.0])),
    )
    den_z = np.polymul([1.0, -1.0], dz)
    return spec.replace(
        kp_per_N=g.kp_per_N,
        ki_per_N_s=g.ki_per_N_s,
        continuous_controller=(tuple(num_s), tuple(den_s)),
        discrete_controller=(tuple(num_z), tuple(den_z)),
    )


KIND = register_controller(
    ControllerKind(
        name="pid_test",
        doc="override PID with a filtered derivative (example of an added kind)",
        options=(PIDesignOptions, PIDOptions),
        records=records,
        linear_loop=linear_loop,
        tunables=("kp_per_N", "ki_per_N_s", "pid_kd_s_per_N"),
    )
)
