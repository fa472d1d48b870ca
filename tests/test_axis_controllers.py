"""Axis controllers against independent references: LinuxCNC's ``calc_pid`` transcribed
here from ``src/hal/components/pid.c`` (LinuxCNC master, 2026), the acceleration observer's
error dynamics measured on an exactly simulated model, and the quantisation noise of double
differentiation (Briquez, seed 004, A4-3)."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from scipy.linalg import expm

from controllers.axis import acceleration_observer as obs_mod
from controllers.axis import pid as pid_mod
from controllers.axis import state_control as sc_mod
from controllers.axis.acceleration_observer import AccelerationObserverParams, observer_records
from controllers.axis.pid import AxisPIDParams, pid_records
from controllers.axis.state_control import StateControlParams, state_control_records


# --- LinuxCNC pid ----------------------------------------------------------------------
class HalPid:
    """``calc_pid`` of LinuxCNC's pid.c, line for line (no auto-tuner, index-enable low,
    command-deriv and feedback-deriv pins unconnected: their numeric derivatives)."""

    def __init__(self, **pins: float) -> None:
        self.pin = {
            "Pgain": 1.0, "Igain": 0.0, "Dgain": 0.0, "bias": 0.0, "FF0": 0.0, "FF1": 0.0,
            "FF2": 0.0, "FF3": 0.0, "deadband": 0.0, "maxerror": 0.0, "maxerrorI": 0.0,
            "maxerrorD": 0.0, "maxcmdD": 0.0, "maxcmdDD": 0.0, "maxcmdDDD": 0.0,
            "maxoutput": 0.0, "enable": 1, "error-previous-target": 0,
        }
        self.pin.update(pins)
        self.error_i = self.error_d = self.prev_cmd = self.prev_fb = 0.0
        self.cmd_d = self.cmd_dd = self.cmd_ddd = self.limit_state = 0.0

    @staticmethod
    def _clip(x: float, lim: float) -> float:
        if lim != 0.0:
            if x > lim:
                return lim
            if x < -lim:
                return -lim
        return x

    def calc(self, command: float, feedback: float, period: float) -> float:
        p = self.pin
        periodrecip = 1.0 / period
        tmp1 = self.prev_cmd - feedback if p["error-previous-target"] else command - feedback
        tmp1 = self._clip(tmp1, p["maxerror"])
        if tmp1 > p["deadband"]:
            tmp1 -= p["deadband"]
        elif tmp1 < -p["deadband"]:
            tmp1 += p["deadband"]
        else:
            tmp1 = 0.0
        if p["enable"]:
            if tmp1 * self.limit_state <= 0.0:
                self.error_i += tmp1 * period
            self.error_i = self._clip(self.error_i, p["maxerrorI"])
        else:
            self.error_i = 0.0
        commandv = (command - self.prev_cmd) * periodrecip
        feedbackv = (feedback - self.prev_fb) * periodrecip
        self.error_d = self._clip(commandv - feedbackv, p["maxerrorD"])
        tmp2 = self.cmd_d
        self.cmd_d = commandv
        self.prev_cmd, self.prev_fb = command, feedback
        self.cmd_d = self._clip(self.cmd_d, p["maxcmdD"])
        tmp3 = self.cmd_dd
        self.cmd_dd = self._clip((self.cmd_d - tmp2) * periodrecip, p["maxcmdDD"])
        self.cmd_ddd = self._clip((self.cmd_dd - tmp3) * periodrecip, p["maxcmdDDD"])
        if p["enable"]:
            out = (p["bias"] + p["Pgain"] * tmp1 + p["Igain"] * self.error_i
                   + p["Dgain"] * self.error_d)
            out += (command * p["FF0"] + self.cmd_d * p["FF1"] + self.cmd_dd * p["FF2"]
                    + self.cmd_ddd * p["FF3"])
            if p["maxoutput"] != 0.0:
                if out > p["maxoutput"]:
                    out, self.limit_state = p["maxoutput"], 1.0
                elif out < -p["maxoutput"]:
                    out, self.limit_state = -p["maxoutput"], -1.0
                else:
                    self.limit_state = 0.0
        else:
            out, self.limit_state = 0.0, 0.0
        return out


@numba.njit
def _drive_pid(p, s, commands, feedbacks, out):  # noqa: ANN001, ANN202
    for i in range(commands.shape[0]):
        out[i] = pid_mod.calc_pid(p[0], s[0], commands[i], feedbacks[i], 0.0, 0.0)


PIN_OF = {
    "p_gain_per_mm": "Pgain", "i_gain_per_mm_s": "Igain", "d_gain_s_per_mm": "Dgain",
    "bias": "bias", "ff0_per_mm": "FF0", "ff1_s_per_mm": "FF1", "ff2_s2_per_mm": "FF2",
    "ff3_s3_per_mm": "FF3", "deadband_mm": "deadband", "max_error_mm": "maxerror",
    "max_error_i_mm_s": "maxerrorI", "max_error_d_mm_s": "maxerrorD",
    "max_cmd_d_mm_s": "maxcmdD", "max_cmd_dd_mm_s2": "maxcmdDD",
    "max_cmd_ddd_mm_s3": "maxcmdDDD", "max_output": "maxoutput",
}


@pytest.mark.parametrize("seed", range(6))
def test_pid_equals_linuxcnc_calc_pid_sample_by_sample(seed):
    rng = np.random.default_rng(seed)
    period = 0.001
    values = {
        "p_gain_per_mm": rng.uniform(0, 50), "i_gain_per_mm_s": rng.uniform(0, 500),
        "d_gain_s_per_mm": rng.uniform(0, 0.5), "bias": rng.uniform(-1, 1),
        "ff0_per_mm": rng.uniform(0, 1), "ff1_s_per_mm": rng.uniform(0, 1),
        "ff2_s2_per_mm": rng.uniform(0, 1e-3), "ff3_s3_per_mm": rng.uniform(0, 1e-6),
        "deadband_mm": rng.choice([0.0, 0.005]), "max_error_mm": rng.choice([0.0, 0.5]),
        "max_error_i_mm_s": rng.choice([0.0, 0.02]), "max_error_d_mm_s": rng.choice([0.0, 50]),
        "max_cmd_d_mm_s": rng.choice([0.0, 40.0]), "max_cmd_dd_mm_s2": rng.choice([0.0, 1e4]),
        "max_cmd_ddd_mm_s3": rng.choice([0.0, 1e7]), "max_output": rng.choice([0.0, 5.0]),
    }
    previous_target = bool(seed % 2)
    n = 2000
    commands = np.cumsum(rng.normal(0.0, 0.05, n))
    feedbacks = commands + rng.normal(0.0, 0.1, n)
    params, state = pid_records(
        AxisPIDParams(**values, error_previous_target=previous_target), period
    )
    out = np.zeros(n)
    _drive_pid(params, state, commands, feedbacks, out)
    hal = HalPid(**{PIN_OF[k]: v for k, v in values.items()},
                 **{"error-previous-target": int(previous_target)})
    expected = np.array([hal.calc(c, f, period) for c, f in zip(commands, feedbacks, strict=True)])
    np.testing.assert_allclose(out, expected, rtol=1e-12, atol=1e-12)
    if values["max_output"]:
        assert np.any(np.abs(expected) == values["max_output"])  # the limit acted


# --- acceleration observer ---------------------------------------------------------------
@numba.njit
def _drive_observer(p, s, measurements, inputs, estimates):  # noqa: ANN001, ANN202
    for k in range(measurements.shape[0]):
        v, a = obs_mod.step(p[0], s[0], measurements[k], inputs[k])
        estimates[k, 0] = v
        estimates[k, 1] = a


def test_observer_error_decays_with_the_placed_poles():
    o = AccelerationObserverParams(measurement="velocity")
    period = 0.001
    w0, z = 2 * math.pi * o.model_frequency_Hz, o.model_damping
    A = np.array([[0.0, 1.0], [-w0 * w0, -2 * z * w0]])  # Briquez Eq. 1 in (v, a)
    b = np.array([0.0, w0 * w0])
    M = expm(np.block([[A, b[:, None]], [np.zeros((1, 3))]]) * period)
    phi, gam = M[:2, :2], M[:2, 2]
    n = 60
    rng = np.random.default_rng(3)
    u = rng.normal(0.0, 20.0, n)
    x = np.zeros((n, 2))
    x[0] = [5.0, -300.0]  # the observer starts at rest: a large initial error
    for k in range(1, n):
        x[k] = phi @ x[k - 1] + gam * u[k - 1]
    params, state = observer_records(o, period)
    est = np.zeros((n, 2))
    _drive_observer(params, state, x[:, 0].copy(), u, est)
    err = x[1:] - est[1:]  # from k = 1 the estimate follows (Phi - H c) e(k-1)
    transition = np.linalg.lstsq(err[:-1], err[1:], rcond=None)[0].T
    got = np.sort_complex(np.linalg.eigvals(transition))
    poles = np.sort_complex(np.exp(o.speed_factor * np.linalg.eigvals(A) * period))
    np.testing.assert_allclose(got, poles, rtol=0, atol=1e-8)
    assert np.abs(err[-1]).max() < 1e-3 * np.abs(err[0]).max()


# --- double differentiation of a quantised position --------------------------------------
@numba.njit
def _drive_state_control(p, s, positions, out):  # noqa: ANN001, ANN202
    for k in range(positions.shape[0]):
        out[k] = sc_mod.step(p[0], s[0], k, 0.0, 0.0, 0.0, positions[k], 0.0, 0.0)


def test_double_differentiation_noise_is_q_over_sqrt2_T_squared():
    q, period = 1e-4, 0.002  # 0.1 um scale, 2 ms position-controller period
    # a speed-form law with K_v = 0 and K_3 = 1 s outputs -a_hat, undelayed
    law = StateControlParams(
        position_gain_1_s=0.0, source="double_differentiation", injection="speed_command",
        acceleration_gain_s=1.0, acceleration_delay_samples=0,
    )
    rng = np.random.default_rng(11)
    n = 40_000
    x = np.cumsum(rng.normal(0.0, 37 * q, n))  # moves many counts per period
    xq = q * np.floor(x / q)
    params, state = state_control_records(law, period, initial_position_mm=xq[0])
    out = np.zeros(n)
    _drive_state_control(params, state, xq, out)
    true_dd = (x[2:] - 2 * x[1:-1] + x[:-2]) / period**2
    noise = -out[2:] - true_dd
    assert np.std(noise) == pytest.approx(q / (math.sqrt(2) * period**2), rel=0.03)
