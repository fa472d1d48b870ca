"""Fixed-gain feedrate-override PI on the force error, with anti-windup; the constant feed.

At each control instant ``k`` (period ``T_c``) with measured force ``y[k]`` [N]:

``e[k] = r - y[k]``, ``w[k] = kp e[k] + i[k]``, ``override[k] = clip(w[k], o_min, o_max)``,
``i[k+1] = i[k] + ki T_c e[k]``  (so ``C(z) = kp + ki T_c / (z - 1)``).

Anti-windup ``"clamping"`` (conditional integration): the integrator is held whenever the
unclamped output is beyond a limit and the error pushes it further out.  The integrator
then stays at the value it had when the clamp was reached, however long the clamp lasts,
so leaving the clamp is as prompt after one second as after a minute.  ``"none"`` keeps
integrating (for comparison).  The CNC applies ``feed = override x programmed feed``.

The law is :func:`controllers.adaptive_pi.pi_law` with no offset, or (``resonant_frequency_hz``
> 0) with the resonant term of :mod:`controllers.resonator` on the force error as offset.
The constant kind is the conventional baseline: a fixed override, whatever the force.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, per_run, record, register_element
from controllers.adaptive_pi import ANTI_WINDUP_KINDS, clamping, pi_law
from controllers.linear_loop import LoopSpec
from controllers.pi_design import PIDesignOptions
from controllers.registry import (
    ControllerKind,
    pi_arguments,
    register_controller,
    resolved_gains,
)
from controllers.resonator import (
    RESONATOR_PARAMS,
    RESONATOR_STATE,
    ResonantOptions,
    refuse_resonant,
    resonator_records,
    resonator_reset,
    resonator_update,
)


def _pi_dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "controller.pi",
        [
            ("reference_force_N", "f8"),
            ("kp_per_N", "f8"),
            ("ki_per_N_s", "f8"),
            ("override_min", "f8"),
            ("override_max", "f8"),
            ("initial_override", "f8"),
            ("control_period_s", "f8"),
            ("clamping", "b1"),
            ("resonator", RESONATOR_PARAMS),
        ],
    )
    state = record(
        "controller.pi",
        [
            ("integral", "f8"),
            ("resonator", RESONATOR_STATE),
        ],
    )
    return params, state


@jit
def pi_init(p, s) -> None:  # noqa: ANN001
    """Integrator at the initial override, resonator at rest."""
    s.integral = p.initial_override
    resonator_reset(s.resonator)


@jit
def pi_step(p, s, measured_force_N: float, diagnostics: np.ndarray) -> float:  # noqa: ANN001
    """One control period: measured force [N] in, clamped override [-] out."""
    offset = 0.0
    if p.resonator.on:
        offset = resonator_update(p.resonator, s.resonator,
                                  p.reference_force_N - measured_force_N)
    s.integral, override = pi_law(
        s.integral,
        p.reference_force_N - measured_force_N,
        p.kp_per_N,
        p.ki_per_N_s,
        p.control_period_s,
        offset,
        p.override_min,
        p.override_max,
        p.clamping,
    )
    return override


PI = register_element(
    "controller.pi", _pi_dtypes, pi_init, pi_step, "feedrate-override PI with clamping anti-windup"
)


def pi_records(
    reference_force_N: ArrayLike,
    kp_per_N: ArrayLike,
    ki_per_N_s: ArrayLike,
    override_min: ArrayLike,
    override_max: ArrayLike,
    initial_override: ArrayLike,
    control_period_s: float,
    anti_windup: str | Sequence[str] = "clamping",
    resonator: NDArray | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of PI controllers (arguments per run or scalar).

    Parameters
    ----------
    reference_force_N : array_like, shape (runs,) or scalar
        Force reference ``r`` [N].
    kp_per_N, ki_per_N_s : array_like, shape (runs,) or scalar
        Gains [1/N], [1/(N s)].
    override_min, override_max : array_like, shape (runs,) or scalar
        Override limits [-].
    initial_override : array_like, shape (runs,) or scalar
        Integrator at start [-].
    control_period_s : float
        ``T_c`` [s].
    anti_windup : {"clamping", "none"} or sequence of them, length runs
    resonator : ndarray of RESONATOR_PARAMS, shape (runs,), or None
        :func:`controllers.resonator.resonator_records`; None: no resonant term.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs, (r, kp, ki, lo, hi, i0) = per_run(
        reference_force_N, kp_per_N, ki_per_N_s, override_min, override_max, initial_override
    )
    if np.any(lo > hi):
        raise ValueError("override_min must be <= override_max")
    params, state = PI.records(runs)
    params["reference_force_N"] = r
    params["kp_per_N"] = kp
    params["ki_per_N_s"] = ki
    params["override_min"] = lo
    params["override_max"] = hi
    params["initial_override"] = i0
    params["control_period_s"] = control_period_s
    params["clamping"] = clamping(anti_windup, runs)
    if resonator is not None:
        params["resonator"] = resonator
    return params, init_states(params, state)


def _constant_dtypes() -> tuple[np.dtype, np.dtype]:
    return (
        record("controller.constant", [("override", "f8")]),
        record("controller.constant", []),
    )


@jit
def constant_init(p, s) -> None:  # noqa: ANN001
    """No state."""


@jit
def constant_step(p, s, measured_force_N: float, diagnostics: np.ndarray) -> float:  # noqa: ANN001
    """The fixed override [-], whatever the force."""
    return p.override


CONSTANT = register_element(
    "controller.constant",
    _constant_dtypes,
    constant_init,
    constant_step,
    "conventional constant feed: a fixed override",
)


def constant_records(override: ArrayLike) -> tuple[NDArray, NDArray]:
    """Params and state of a batch of constant overrides, shape (runs,) each."""
    ov = np.atleast_1d(np.asarray(override, dtype=float))
    params, state = CONSTANT.records(ov.size)
    params["override"] = ov
    return params, init_states(params, state)


@dataclass(frozen=True)
class ConstantOptions:
    """``[controller]`` options of the ``"constant"`` kind.

    Attributes
    ----------
    constant_override : float or None
        Override [-], >= 0; None = the safe feed (the largest constant feed whose steady
        force is at most the reference on every depth of the part).
    """

    constant_override: float | None = None

    def __post_init__(self) -> None:
        if self.constant_override is not None and not self.constant_override >= 0:
            raise ValueError("constant_override must be >= 0")


def _pi_kind_records(params, nominal, control_period_s, safe_override):  # noqa: ANN001, ANN202
    return pi_records(
        **pi_arguments(params, nominal, control_period_s),
        control_period_s=control_period_s,
        anti_windup=[p.anti_windup for p in params],
        resonator=resonator_records([p.group(ResonantOptions) for p in params], control_period_s),
    )


def _pi_loop(spec: LoopSpec, params, nominal) -> LoopSpec:  # noqa: ANN001
    refuse_resonant(params)
    gains = resolved_gains(params, nominal, spec.control_period_s)
    return spec.replace(kp_per_N=gains.kp_per_N, ki_per_N_s=gains.ki_per_N_s)


def _constant_kind_records(params, nominal, control_period_s, safe_override):  # noqa: ANN001, ANN202
    override = [
        s if p.constant_override is None else p.constant_override
        for p, s in zip(params, safe_override, strict=True)
    ]
    return constant_records(np.array(override, dtype=float))


register_controller(
    ControllerKind(
        name="pi",
        doc="fixed-gain feedrate-override PI designed on the nominal plant",
        options=(PIDesignOptions, ResonantOptions),
        records=_pi_kind_records,
        linear_loop=_pi_loop,
        tunables=("kp_per_N", "ki_per_N_s"),
    )
)
register_controller(
    ControllerKind(
        name="constant",
        doc="the conventional constant feed (the safe feed by default)",
        options=(ConstantOptions,),
        records=_constant_kind_records,
        uses_safe_feed=lambda params: params.constant_override is None,
    )
)


__all__ = [
    "ANTI_WINDUP_KINDS",
    "CONSTANT",
    "PI",
    "ConstantOptions",
    "constant_records",
    "pi_records",
]
