"""PID with feed-forward, equal term for term to LinuxCNC's ``pid`` HAL component.

Transcribed from ``calc_pid`` in ``src/hal/components/pid.c`` of LinuxCNC (master, 2026;
spec §6.1), without the auto-tuner and the index-enable handling (``index-enable`` held
false).  Per call, period ``T`` (the control period)::

    error = command - feedback        (or prev_command - feedback: error_previous_target)
    limit error to +-maxerror; then the deadband: |e| <= deadband -> 0, else e -+ deadband
    if enabled: errorI += e T unless e * limit_state > 0 (the output was saturated in the
                same direction at the previous call); limit errorI to +-maxerrorI
    else:       errorI = 0
    commandD  = (command - prev_command)/T    (or the command-deriv input, if used)
    feedbackD = (feedback - prev_feedback)/T  (or the feedback-deriv input, if used)
    errorD    = commandD - feedbackD, limited to +-maxerrorD      (the *raw* error's rate)
    cmd_d = commandD limited to +-maxcmdD;  cmd_dd = (cmd_d - previous cmd_d)/T limited to
    +-maxcmdDD;  cmd_ddd = (cmd_dd - previous cmd_dd)/T limited to +-maxcmdDDD
    output = bias + Pgain e + Igain errorI + Dgain errorD
             + FF0 command + FF1 cmd_d + FF2 cmd_dd + FF3 cmd_ddd
    limit output to +-maxoutput, setting limit_state to +-1 (or 0 inside); disabled: 0

A limit of 0 means "no limit", as in LinuxCNC (and ``limit_state`` is then left as it
was).  ``prev_command``, ``prev_feedback`` and the derivative states start at 0, as
``hal_malloc``'s zeroed memory does.

Units: command and feedback are positions [mm]; the output is in the plant's command unit
("OU": V for :mod:`plants.axis.servo_axis`, mm/s for :mod:`plants.axis.oscillating_axis`),
so ``p_gain_per_mm`` is OU/mm, ``ff1_s_per_mm`` OU s/mm and so on.  LinuxCNC's default
``Pgain`` is 1; the other gains and limits default to 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import init_states, jit, record, register_element


@dataclass(frozen=True)
class AxisPIDParams:
    """LinuxCNC ``pid`` parameters (pin names in brackets), units in names (OU: output unit).

    Attributes
    ----------
    p_gain_per_mm : float
        [Pgain] OU/mm (1).
    i_gain_per_mm_s : float
        [Igain] OU/(mm s).
    d_gain_s_per_mm : float
        [Dgain] OU s/mm.
    bias : float
        [bias] OU.
    ff0_per_mm, ff1_s_per_mm, ff2_s2_per_mm, ff3_s3_per_mm : float
        [FF0..FF3] OU/mm, OU s/mm, OU s^2/mm, OU s^3/mm.
    deadband_mm : float
        [deadband] mm, >= 0.
    max_error_mm, max_error_i_mm_s, max_error_d_mm_s : float
        [maxerror, maxerrorI, maxerrorD]; 0 = no limit.
    max_cmd_d_mm_s, max_cmd_dd_mm_s2, max_cmd_ddd_mm_s3 : float
        [maxcmdD, maxcmdDD, maxcmdDDD]; 0 = no limit.
    max_output : float
        [maxoutput] OU; 0 = no limit.
    enable : bool
        [enable]; False resets the integrator and forces the output to 0.
    error_previous_target : bool
        [error-previous-target]: error against the previous command.
    use_reference_derivative : bool
        Connect [command-deriv] to the reference velocity instead of differencing.
    use_measured_derivative : bool
        Connect [feedback-deriv] to the measured velocity instead of differencing.
    """

    p_gain_per_mm: float = 1.0
    i_gain_per_mm_s: float = 0.0
    d_gain_s_per_mm: float = 0.0
    bias: float = 0.0
    ff0_per_mm: float = 0.0
    ff1_s_per_mm: float = 0.0
    ff2_s2_per_mm: float = 0.0
    ff3_s3_per_mm: float = 0.0
    deadband_mm: float = 0.0
    max_error_mm: float = 0.0
    max_error_i_mm_s: float = 0.0
    max_error_d_mm_s: float = 0.0
    max_cmd_d_mm_s: float = 0.0
    max_cmd_dd_mm_s2: float = 0.0
    max_cmd_ddd_mm_s3: float = 0.0
    max_output: float = 0.0
    enable: bool = True
    error_previous_target: bool = False
    use_reference_derivative: bool = False
    use_measured_derivative: bool = False

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.type == "bool" or isinstance(f.default, bool):
                if not isinstance(v, (bool, np.bool_)):
                    raise ValueError(f"{f.name} must be true or false, got {v!r}")
                continue
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
                raise ValueError(f"{f.name} must be a finite number, got {v!r}")
            if (f.name.startswith("max_") or f.name == "deadband_mm") and v < 0:
                raise ValueError(f"{f.name} must be >= 0 (0 = no limit), got {v!r}")


_FLOAT_FIELDS = tuple(f.name for f in fields(AxisPIDParams) if not isinstance(f.default, bool))
_BOOL_FIELDS = tuple(f.name for f in fields(AxisPIDParams) if isinstance(f.default, bool))
#: The state record's fields (every ``f8``), zeroed by :func:`init`; the cross-coupled
#: controller's PID on the contour error carries the same state.
_STATE_FIELDS = ("error_i_mm_s", "prev_command_mm", "prev_feedback_mm", "cmd_d_mm_s",
                 "cmd_dd_mm_s2", "cmd_ddd_mm_s3", "limit_state", "error_d_mm_s")


def _dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "position_controller.pid",
        [*((n, "f8") for n in _FLOAT_FIELDS), *((n, "b1") for n in _BOOL_FIELDS),
         ("period_s", "f8")],
    )
    state = record("position_controller.pid", [(n, "f8") for n in _STATE_FIELDS])
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """Zeroed, as LinuxCNC's freshly allocated component."""
    s.error_i_mm_s = 0.0
    s.prev_command_mm = 0.0
    s.prev_feedback_mm = 0.0
    s.cmd_d_mm_s = 0.0
    s.cmd_dd_mm_s2 = 0.0
    s.cmd_ddd_mm_s3 = 0.0
    s.limit_state = 0.0
    s.error_d_mm_s = 0.0


@jit
def _limit(x: float, lim: float) -> float:
    if lim != 0.0:
        if x > lim:
            return lim
        if x < -lim:
            return -lim
    return x


@jit
def calc_pid(p, s, command: float, feedback: float, command_deriv: float,  # noqa: ANN001
             feedback_deriv: float) -> float:
    """One call of LinuxCNC's ``calc_pid`` (module docstring); the derivative inputs are
    used only when ``use_reference_derivative`` / ``use_measured_derivative`` are set."""
    period = p.period_s
    if p.error_previous_target:
        e = s.prev_command_mm - feedback
    else:
        e = command - feedback
    e = _limit(e, p.max_error_mm)
    if e > p.deadband_mm:
        e -= p.deadband_mm
    elif e < -p.deadband_mm:
        e += p.deadband_mm
    else:
        e = 0.0
    if p.enable:
        if e * s.limit_state <= 0.0:
            s.error_i_mm_s += e * period
        s.error_i_mm_s = _limit(s.error_i_mm_s, p.max_error_i_mm_s)
    else:
        s.error_i_mm_s = 0.0
    cmd_v = command_deriv if p.use_reference_derivative else (command - s.prev_command_mm) / period
    fb_v = feedback_deriv if p.use_measured_derivative else (feedback - s.prev_feedback_mm) / period
    s.error_d_mm_s = _limit(cmd_v - fb_v, p.max_error_d_mm_s)
    previous_d = s.cmd_d_mm_s
    s.prev_command_mm = command
    s.prev_feedback_mm = feedback
    s.cmd_d_mm_s = _limit(cmd_v, p.max_cmd_d_mm_s)
    previous_dd = s.cmd_dd_mm_s2
    s.cmd_dd_mm_s2 = _limit((s.cmd_d_mm_s - previous_d) / period, p.max_cmd_dd_mm_s2)
    s.cmd_ddd_mm_s3 = _limit((s.cmd_dd_mm_s2 - previous_dd) / period, p.max_cmd_ddd_mm_s3)
    if p.enable:
        out = (
            p.bias + p.p_gain_per_mm * e + p.i_gain_per_mm_s * s.error_i_mm_s
            + p.d_gain_s_per_mm * s.error_d_mm_s
        )
        out += (
            command * p.ff0_per_mm + s.cmd_d_mm_s * p.ff1_s_per_mm
            + s.cmd_dd_mm_s2 * p.ff2_s2_per_mm + s.cmd_ddd_mm_s3 * p.ff3_s3_per_mm
        )
        if p.max_output != 0.0:
            if out > p.max_output:
                out = p.max_output
                s.limit_state = 1.0
            elif out < -p.max_output:
                out = -p.max_output
                s.limit_state = -1.0
            else:
                s.limit_state = 0.0
    else:
        out = 0.0
        s.limit_state = 0.0
    return out


@jit
def step(p, s, k, reference_mm, reference_velocity_mm_s, reference_acceleration_mm_s2,  # noqa: ANN001
         measured_position_mm, measured_velocity_mm_s, measured_acceleration_mm_s2) -> float:
    """Controller slot: command = reference, feedback = measured position; output in the
    plant's command unit."""
    return calc_pid(p, s, reference_mm, measured_position_mm, reference_velocity_mm_s,
                    measured_velocity_mm_s)


PID = register_element(
    "position_controller.pid",
    _dtypes,
    init,
    step,
    "LinuxCNC pid component (calc_pid) term for term: PID, FF0-FF3, deadband, limits",
)


def pid_records(
    controllers: AxisPIDParams | Sequence[AxisPIDParams],
    control_period_s: float,
    *,
    runs: int | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of PIDs.

    Parameters
    ----------
    controllers : AxisPIDParams or sequence of them, length runs
    control_period_s : float
        ``period`` of ``calc_pid`` [s], > 0.
    runs : int, optional
        Batch size when ``controllers`` is one parameter set.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    if not control_period_s > 0:
        raise ValueError(f"control_period_s must be > 0, got {control_period_s}")
    if isinstance(controllers, AxisPIDParams):
        controllers = [controllers] * (1 if runs is None else int(runs))
    ctrls = list(controllers)
    params, state = PID.records(len(ctrls))
    set_pid_fields(params, ctrls, control_period_s)
    return params, init_states(params, state)


def set_pid_fields(params: NDArray, pids: Sequence[AxisPIDParams],
                   control_period_s: float) -> None:
    """Fill the ``calc_pid`` fields and ``period_s`` of a params records array, one PID per run
    (also used by records that embed the PID's fields, e.g. the cross-coupled controller)."""
    for r, c in enumerate(pids):
        for name in _FLOAT_FIELDS + _BOOL_FIELDS:
            params[name][r] = getattr(c, name)
    params["period_s"] = control_period_s


__all__ = ["PID", "AxisPIDParams", "calc_pid", "pid_records", "set_pid_fields"]
