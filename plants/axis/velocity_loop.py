"""Velocity loop of a DC feed drive: PWM amplifier, DC motor and tachogenerator.

Peng (UBC MASc thesis 1989, seed 000), Sec. 2.3.1, Eqs. (2.1)-(2.14), (2.32), (2.33)::

    V_a = R_a I_a + L_a dI_a/dt + K_b W                           (2.1) armature
    K_t I_a = J_e dW/dt + B W + T_c                               (2.2), (2.3) shaft
    V_a = K_v [K_I (S_g V_c - T_g H_g W) - K_a I_a]               (2.4) amplifier

so, with states ``x_v = [I_a (A), W (rad/s)]`` and inputs ``u_v = [V_c (V), T_c (N m)]``
(``T_c`` the cutting torque reflected to the motor, a load: positive opposes positive
speed)::

    A_v = [[-(K_v K_a + R_a)/L_a, -(K_b + K_v K_I T_g H_g)/L_a],
           [K_t/J_e,              -B/J_e                     ]]
    B_v = [[K_v K_I S_g / L_a, 0], [0, -1/J_e]]                   (2.7)

and ``W/V_c = K_1/(s^2 + K_2 s + K_3)`` (2.14) with ``omega_n = sqrt(K_3)`` and
``xi = K_2 / (2 sqrt(K_3))`` (2.32).  The OCR's ``J_c`` in (2.7) is ``J_e`` (spec O-1);
(2.10) integrates ``e^{A_v t}``, not ``e^{A_v T}`` (O-2).

Defaults are Peng's Appendix A (seed L1761-L1775).  ``K_v`` is printed as "V/V"; in (2.4)
it multiplies a current error, so it is stored as ``pwm_gain_V_A``.  ``K_a`` is printed in
A/A and ``K_I`` in A/V; with (2.4) as printed the products are dimensionally consistent
only up to the amplifier's internal scaling, which the thesis does not detail; the values
are used as printed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from plants.axis.discretisation import zoh_matrices


def check_positive(obj: Any, names: tuple[str, ...], *, strict: bool = True) -> None:
    """Raise ValueError naming the first field of ``obj`` that is not > 0 (or >= 0)."""
    for name in names:
        value = getattr(obj, name)
        ok = value > 0 if strict else value >= 0
        if not (isinstance(value, (int, float)) and math.isfinite(value) and ok):
            bound = "> 0" if strict else ">= 0"
            raise ValueError(f"{name} must be a finite number {bound}, got {value!r}")


@dataclass(frozen=True)
class VelocityLoopParams:
    """PWM amplifier, DC motor and tacho of one feed axis (Peng App. A defaults).

    Attributes
    ----------
    torque_constant_Nm_A : float
        ``K_t`` [N m/A] (App. A: 0.3).
    armature_resistance_ohm : float
        ``R_a`` [ohm] (0.4).
    armature_inductance_H : float
        ``L_a`` [H] (2 mH).
    back_emf_V_s_rad : float
        ``K_b`` [V s/rad] (0.3).
    inertia_kg_m2 : float
        ``J_e``: motor, screw and table at the motor shaft [kg m^2] (0.0036).
    viscous_friction_Nm_s_rad : float
        ``B``: linearised viscous friction [N m s/rad] (0.09, the average of Fig. 2.5).
    tacho_constant_V_s_rad : float
        ``H_g`` [V s/rad] (0.08872).
    tacho_gain : float
        ``T_g`` [V/V] (0.13183).
    command_gain : float
        ``S_g``: pre-amplifier gain of the velocity command [V/V] (0.0648).
    current_amp_gain_A_V : float
        ``K_I`` [A/V] (25.5).
    current_feedback_gain : float
        ``K_a`` [A/A] (0.0643).
    pwm_gain_V_A : float
        ``K_v``: PWM stage, current error to armature voltage [V/A] (21.934; printed "V/V").
    """

    torque_constant_Nm_A: float = 0.3
    armature_resistance_ohm: float = 0.4
    armature_inductance_H: float = 0.002
    back_emf_V_s_rad: float = 0.3
    inertia_kg_m2: float = 0.0036
    viscous_friction_Nm_s_rad: float = 0.09
    tacho_constant_V_s_rad: float = 0.08872
    tacho_gain: float = 0.13183
    command_gain: float = 0.0648
    current_amp_gain_A_V: float = 25.5
    current_feedback_gain: float = 0.0643
    pwm_gain_V_A: float = 21.934

    def __post_init__(self) -> None:
        nonneg = ("viscous_friction_Nm_s_rad", "back_emf_V_s_rad", "current_feedback_gain",
                  "tacho_constant_V_s_rad", "tacho_gain")
        own = tuple(f.name for f in fields(VelocityLoopParams))
        check_positive(self, tuple(n for n in own if n not in nonneg))
        check_positive(self, nonneg, strict=False)

    # --- derived constants -------------------------------------------------------------
    @property
    def loop_resistance_ohm(self) -> float:
        """``R' = R_a + K_v K_a`` [ohm]: armature resistance plus the current feedback."""
        return self.armature_resistance_ohm + self.pwm_gain_V_A * self.current_feedback_gain

    @property
    def loop_back_emf_V_s_rad(self) -> float:
        """``K_b' = K_b + K_v K_I T_g H_g`` [V s/rad]: back-EMF plus the tacho feedback."""
        return self.back_emf_V_s_rad + (
            self.pwm_gain_V_A * self.current_amp_gain_A_V * self.tacho_gain
            * self.tacho_constant_V_s_rad
        )

    @property
    def command_to_voltage_V_V(self) -> float:
        """``K_v K_I S_g`` [V/V]: armature voltage per volt of velocity command."""
        return self.pwm_gain_V_A * self.current_amp_gain_A_V * self.command_gain

    @property
    def k1_rad_s3_V(self) -> float:
        """``K_1 = K_t S_g K_I K_v / (L_a J_e)`` [rad/(s^3 V)] (2.14)."""
        return self.torque_constant_Nm_A * self.command_to_voltage_V_V / (
            self.armature_inductance_H * self.inertia_kg_m2
        )

    @property
    def k2_1_s(self) -> float:
        """``K_2 = B/J_e + (R_a + K_v K_a)/L_a`` [1/s] (2.14)."""
        return (
            self.viscous_friction_Nm_s_rad / self.inertia_kg_m2
            + self.loop_resistance_ohm / self.armature_inductance_H
        )

    @property
    def k3_1_s2(self) -> float:
        """``K_3 = [B (R_a + K_v K_a) + K_t (K_b + H_g T_g K_v K_I)] / (J_e L_a)`` [1/s^2]."""
        return (
            self.viscous_friction_Nm_s_rad * self.loop_resistance_ohm
            + self.torque_constant_Nm_A * self.loop_back_emf_V_s_rad
        ) / (self.inertia_kg_m2 * self.armature_inductance_H)

    @property
    def k123(self) -> tuple[float, float, float]:
        """``(K_1, K_2, K_3)`` of (2.14)."""
        return self.k1_rad_s3_V, self.k2_1_s, self.k3_1_s2

    @property
    def natural_frequency_rad_s(self) -> float:
        """``omega_n = sqrt(K_3)`` [rad/s] (2.32)."""
        return math.sqrt(self.k3_1_s2)

    @property
    def damping(self) -> float:
        """``xi = K_2 / (2 sqrt(K_3))`` [-] (2.32)."""
        return self.k2_1_s / (2.0 * math.sqrt(self.k3_1_s2))

    @property
    def dc_gain_rad_s_V(self) -> float:
        """Steady speed per volt of command, ``K_1/K_3`` [rad/(s V)]."""
        return self.k1_rad_s3_V / self.k3_1_s2

    @property
    def electrical_time_constant_s(self) -> float:
        """``tau_e = L_a / R_a`` [s] (2.11), open-loop motor (informative)."""
        return self.armature_inductance_H / self.armature_resistance_ohm

    # --- models ------------------------------------------------------------------------
    def state_matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(A_v, B_v)`` of (2.7): states ``[I_a, W]``, inputs ``[V_c, T_c]``.

        Returns
        -------
        A_v : ndarray, shape (2, 2)
        B_v : ndarray, shape (2, 2)
        """
        la, je = self.armature_inductance_H, self.inertia_kg_m2
        A = np.array(
            [
                [-self.loop_resistance_ohm / la, -self.loop_back_emf_V_s_rad / la],
                [self.torque_constant_Nm_A / je, -self.viscous_friction_Nm_s_rad / je],
            ]
        )
        B = np.array([[self.command_to_voltage_V_V / la, 0.0], [0.0, -1.0 / je]])
        return A, B

    def discretise(self, step_s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(Phi_v, H_v)`` of (2.8)-(2.10): exact ZOH at ``step_s`` [s]."""
        return zoh_matrices(*self.state_matrices(), step_s)

    def state_space(self) -> Any:
        """python-control ``StateSpace`` of (2.7): inputs ``command_V``, ``load_torque_Nm``;
        outputs (= states) ``current_A``, ``speed_rad_s``."""
        import control

        A, B = self.state_matrices()
        return control.ss(
            A, B, np.eye(2), np.zeros((2, 2)),
            inputs=["command_V", "load_torque_Nm"],
            outputs=["current_A", "speed_rad_s"],
            states=["current_A", "speed_rad_s"],
            name="velocity_loop",
        )

    def transfer_function(self) -> Any:
        """``W/V_c = K_1/(s^2 + K_2 s + K_3)`` (2.14) as a python-control
        ``TransferFunction`` from ``command_V`` to ``speed_rad_s``."""
        import control

        k1, k2, k3 = self.k123
        return control.tf(
            [k1], [1.0, k2, k3], inputs=["command_V"], outputs=["speed_rad_s"],
            name="velocity_loop_W_Vc",
        )


__all__ = ["VelocityLoopParams", "check_positive"]
