"""Peng's servo feed axis: velocity loop, ball screw, encoder, force to torque, friction.

Continuous block (seed 000, Sec. 2.3.2-2.3.3, Eqs. 2.15-2.25) with the table position in
mm (the workbench's unit) instead of counts::

    x_c = [I_a (A), W (rad/s), x (mm)],   u_c = [V_c (V), T_c (N m)]
    A_c = [[A_v, 0], [0, p/(2 pi), 0]],   B_c = [[B_v], [0, 0]]

``p/(2 pi)`` [mm/rad] is the screw lead per radian; in counts the row is ``K_e = 4000/(2 pi)``
(2.15-2.16, 1 count = p/4000 mm).  Counts appear only at the boundary: the encoder
(optionally quantised to whole counts) and the D/A gain of the controller [V/count].

Discretisation: exact ZOH of ``(A_c, B_c)`` at the plant step (augmented-matrix
exponential, :mod:`plants.axis.discretisation`), built once per parameter set.  Held over a
plant step (approximations, only when enabled):

* the Coulomb torque and the stick rule of :mod:`plants.axis.friction`
  (``friction_model = "coulomb_viscous"``);
* the current limit: the command is clipped so that the current at the end of the step is
  within ``+-current_limit_A`` (one-step prediction with the exact ZOH; off by default, as
  in the thesis; the amplifier gives 15 A continuous, 30 A peak);
* encoder quantisation of the measured position (off by default: the thesis treats the
  counter as continuous).

Load: the feed force on the table ``F`` [N] (positive opposes positive motion) reflects to
the motor as ``T_c = k F`` (3.34), with ``k`` measured on the machine, 9.45e-4 m (3.37;
default) or from the nut model ``k = p/(2 pi nu)``, ``nu = 1/(1 + 0.02 d_p/p)`` = 0.899
with ``d_p`` = 28.6 mm (L680); the thesis rounds nu to 0.89.

The compiled element ``axis.servo`` follows the contract of the axis slot
(:mod:`acc.engine.axis_loop`): ``output(p, s, load_force_N)`` gives what the sensors show at
the start of a step (encoder position [mm], tacho speed [mm/s], slide acceleration
[mm/s^2]); ``step(p, s, command, load_force_N)`` advances one plant step with both held and
returns the position, velocity, acceleration and current at its start and the command
actually applied.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, record, register_element
from plants.axis.discretisation import zoh_matrices
from plants.axis.friction import FrictionParams, coulomb_hold
from plants.axis.velocity_loop import VelocityLoopParams, check_positive

#: How the feed force becomes a motor torque.
FORCE_TO_TORQUE_MODELS = ("measured", "nut_model")
#: Peak current of Peng's PWM amplifier [A] (App. A, seed 000 L1779-L1780: 15 A continuous,
#: 30 A peak); simulated only through ``current_limit_A``.
AMPLIFIER_PEAK_CURRENT_A = 30.0


@dataclass(frozen=True)
class ServoAxisParams(VelocityLoopParams):
    """One servo feed axis (velocity loop fields inherited, Peng App. A defaults).

    Attributes
    ----------
    encoder_counts_per_rev : int
        Counts per motor (screw) turn: 1000 slots, x4 quadrature = 4000 (L432-L438).
    screw_pitch_mm : float
        Lead ``p`` [mm] (5.08).
    screw_diameter_mm : float
        ``d_p`` [mm] (28.6, L680), for the nut-efficiency model.
    force_to_torque_model : {"measured", "nut_model"}
        ``"measured"``: ``T_c = measured_force_to_torque_m F`` (3.37); ``"nut_model"``:
        ``p / (2 pi nu)`` (3.34).
    measured_force_to_torque_m : float
        Measured ``T_c / F_c`` [N m/N] (9.45e-4).
    friction_model : {"linear", "coulomb_viscous", "speed_dependent_linear"}
        See :mod:`plants.axis.friction`; ``viscous_friction_Nm_s_rad`` is ``B``.
    coulomb_friction_Nm : float
        ``T_C`` [N m] for ``"coulomb_viscous"`` (0; measured tare 0.75).
    coulomb_smoothing_rad_s : float
        ``w_eps`` of the tanh option [rad/s]; 0 = stick rule.
    speed_dependent_constant_Nm_count_rad : float
        ``K_c`` of ``B = K_c/f_c`` (450).
    current_limit_A : float
        Amplifier current limit [A]; 0 = none (thesis).
    encoder_quantisation : bool
        Measured position rounded to whole counts (False: continuous, as the thesis).
    """

    encoder_counts_per_rev: int = 4000
    screw_pitch_mm: float = 5.08
    screw_diameter_mm: float = 28.6
    force_to_torque_model: str = "measured"
    measured_force_to_torque_m: float = 9.45e-4
    friction_model: str = "linear"
    coulomb_friction_Nm: float = 0.0
    coulomb_smoothing_rad_s: float = 0.0
    speed_dependent_constant_Nm_count_rad: float = 450.0
    current_limit_A: float = 0.0
    encoder_quantisation: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (
            isinstance(self.encoder_counts_per_rev, (int, np.integer))
            and self.encoder_counts_per_rev > 0
        ):
            raise ValueError(
                f"encoder_counts_per_rev must be a whole number > 0, got "
                f"{self.encoder_counts_per_rev!r}"
            )
        check_positive(self, ("screw_pitch_mm", "screw_diameter_mm", "measured_force_to_torque_m"))
        check_positive(self, ("current_limit_A",), strict=False)
        if self.force_to_torque_model not in FORCE_TO_TORQUE_MODELS:
            raise ValueError(
                f"force_to_torque_model must be one of {', '.join(FORCE_TO_TORQUE_MODELS)}, "
                f"got {self.force_to_torque_model!r}"
            )
        if not isinstance(self.encoder_quantisation, (bool, np.bool_)):
            raise ValueError(
                f"encoder_quantisation must be true or false, got {self.encoder_quantisation!r}"
            )
        self.friction  # noqa: B018  (validates the friction fields)

    # --- conversions -------------------------------------------------------------------
    @property
    def velocity_loop(self) -> VelocityLoopParams:
        """The velocity-loop part (amplifier, motor, tacho) alone."""
        names = VelocityLoopParams.__dataclass_fields__
        return VelocityLoopParams(**{n: getattr(self, n) for n in names})

    @property
    def friction(self) -> FrictionParams:
        """The friction fields as :class:`~plants.axis.friction.FrictionParams`."""
        return FrictionParams(
            self.friction_model, self.coulomb_friction_Nm, self.coulomb_smoothing_rad_s,
            self.speed_dependent_constant_Nm_count_rad,
        )

    @property
    def count_mm(self) -> float:
        """Length of one count ``p / counts_per_rev`` [mm] (0.00127 mm for Peng)."""
        return self.screw_pitch_mm / self.encoder_counts_per_rev

    @property
    def counts_per_mm(self) -> float:
        """Counts per mm of table travel [1/mm]."""
        return self.encoder_counts_per_rev / self.screw_pitch_mm

    @property
    def encoder_counts_per_rad(self) -> float:
        """``K_e = counts_per_rev / (2 pi)`` [counts/rad] (2.15; App. A prints 636.62 with the
        unit "counts/(rad/sec)", spec O-16)."""
        return self.encoder_counts_per_rev / (2.0 * math.pi)

    @property
    def mm_per_rad(self) -> float:
        """Table travel per motor radian ``p / (2 pi)`` [mm/rad]."""
        return self.screw_pitch_mm / (2.0 * math.pi)

    @property
    def nut_efficiency(self) -> float:
        """``nu = 1 / (1 + 0.02 d_p / p)`` [-] (3.34; 0.899 for App. A)."""
        return 1.0 / (1.0 + 0.02 * self.screw_diameter_mm / self.screw_pitch_mm)

    @property
    def nut_model_force_to_torque_m(self) -> float:
        """``p / (2 pi nu)`` [N m/N] (3.34)."""
        return self.screw_pitch_mm * 1e-3 / (2.0 * math.pi * self.nut_efficiency)

    @property
    def force_to_torque_m(self) -> float:
        """Motor torque per newton of feed force [N m/N], by ``force_to_torque_model``."""
        if self.force_to_torque_model == "nut_model":
            return self.nut_model_force_to_torque_m
        return self.measured_force_to_torque_m

    def feed_counts_s(self, feed_mm_s: float) -> float:
        """A feed [mm/s] in counts/s (20 mm/s = 15748 counts/s)."""
        return feed_mm_s * self.counts_per_mm

    def with_effective_friction(self, commanded_feed_mm_s: float | None = None) -> ServoAxisParams:
        """This axis with ``B`` replaced by the linear part's coefficient for a run (only
        ``"speed_dependent_linear"`` changes it: ``K_c / |f_c|``)."""
        f = None if commanded_feed_mm_s is None else self.feed_counts_s(commanded_feed_mm_s)
        b = self.friction.viscous_coefficient(self.viscous_friction_Nm_s_rad, f)
        return self if b == self.viscous_friction_Nm_s_rad else replace(
            self, viscous_friction_Nm_s_rad=b
        )

    # --- models ------------------------------------------------------------------------
    def continuous_matrices(
        self, position_unit: str = "mm"
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(A_c, B_c)`` of (2.24): states ``[I_a, W, x]``, inputs ``[V_c, T_c]``.

        Parameters
        ----------
        position_unit : {"mm", "counts"}
            Unit of the position state (counts: Peng's ``X_a``, row ``[0, K_e, 0]``).

        Returns
        -------
        A_c : ndarray, shape (3, 3)
        B_c : ndarray, shape (3, 2)
        """
        scale = {"mm": self.mm_per_rad, "counts": self.encoder_counts_per_rad}.get(position_unit)
        if scale is None:
            raise ValueError(f"position_unit must be 'mm' or 'counts', got {position_unit!r}")
        av, bv = self.state_matrices()
        A = np.zeros((3, 3))
        A[:2, :2] = av
        A[2, 1] = scale
        B = np.zeros((3, 2))
        B[:2] = bv
        return A, B

    def discretise_block(
        self, step_s: float, position_unit: str = "mm"
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(Phi, H)`` of (2.25): exact ZOH of the continuous block at ``step_s`` [s]."""
        return zoh_matrices(*self.continuous_matrices(position_unit), step_s)

    def block_state_space(self, position_unit: str = "mm") -> Any:
        """Continuous block (2.24) as python-control ``StateSpace``: inputs ``command_V``,
        ``load_torque_Nm``; outputs ``current_A``, ``speed_rad_s``, ``position_mm`` (or
        ``position_counts``)."""
        import control

        A, B = self.continuous_matrices(position_unit)
        names = ["current_A", "speed_rad_s", f"position_{position_unit}"]
        return control.ss(
            A, B, np.eye(3), np.zeros((3, 2)), inputs=["command_V", "load_torque_Nm"],
            outputs=names, states=names, name="servo_axis",
        )


# --- compiled element ------------------------------------------------------------------
def _dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "axis.servo",
        [
            ("phi", "f8", (3, 3)),
            ("gamma", "f8", (3, 2)),  # columns: command [V], load torque [N m]
            ("torque_constant_Nm_A", "f8"),
            ("inertia_kg_m2", "f8"),
            ("viscous_friction_Nm_s_rad", "f8"),
            ("mm_per_rad", "f8"),
            ("force_to_torque_m", "f8"),
            ("coulomb_friction_Nm", "f8"),
            ("coulomb_smoothing_rad_s", "f8"),
            ("current_limit_A", "f8"),
            ("counts_per_mm", "f8"),
            ("quantise", "b1"),
            ("initial_current_A", "f8"),
            ("initial_speed_rad_s", "f8"),
            ("initial_position_mm", "f8"),
        ],
    )
    state = record(
        "axis.servo", [("current_A", "f8"), ("speed_rad_s", "f8"), ("position_mm", "f8")]
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At the initial current, speed and position."""
    s.current_A = p.initial_current_A
    s.speed_rad_s = p.initial_speed_rad_s
    s.position_mm = p.initial_position_mm


@jit
def _load_torque(p, s, load_force_N: float) -> tuple:  # noqa: ANN001
    """Load torque held over the step (cutting load plus Coulomb friction) [N m], whether
    the shaft sticks, and the shaft's angular acceleration at the start of the step."""
    cutting = p.force_to_torque_m * load_force_N
    drive = p.torque_constant_Nm_A * s.current_A - cutting
    friction, stuck = coulomb_hold(
        p.coulomb_friction_Nm, p.coulomb_smoothing_rad_s, s.speed_rad_s, drive
    )
    torque = cutting + friction
    alpha = (
        p.torque_constant_Nm_A * s.current_A - p.viscous_friction_Nm_s_rad * s.speed_rad_s - torque
    ) / p.inertia_kg_m2
    return torque, stuck, alpha


@jit
def output(p, s, load_force_N: float) -> tuple[float, float, float]:  # noqa: ANN001
    """Sensors at the start of the step: encoder position [mm] (whole counts when
    quantised), tacho speed [mm/s] and table acceleration [mm/s^2]."""
    x = s.position_mm
    if p.quantise:
        x = math.floor(x * p.counts_per_mm + 0.5) / p.counts_per_mm
    _, _, alpha = _load_torque(p, s, load_force_N)
    return x, s.speed_rad_s * p.mm_per_rad, alpha * p.mm_per_rad


@jit
def step(p, s, command_V: float, load_force_N: float) -> tuple:  # noqa: ANN001
    """One plant step with the command [V] and the feed force [N] held over it.

    Returns position [mm], velocity [mm/s], acceleration [mm/s^2] and current [A] at the
    start of the step, and the command applied [V] (clipped by the current limit).
    """
    i = s.current_A
    w = s.speed_rad_s
    x = s.position_mm
    torque, stuck, alpha = _load_torque(p, s, load_force_N)
    v = command_V
    if p.current_limit_A > 0.0:
        base = p.phi[0, 0] * i + p.phi[0, 1] * w + p.phi[0, 2] * x + p.gamma[0, 1] * torque
        hi = (p.current_limit_A - base) / p.gamma[0, 0]
        lo = (-p.current_limit_A - base) / p.gamma[0, 0]
        if v > hi:
            v = hi
        elif v < lo:
            v = lo
    i_new = p.phi[0, 0] * i + p.phi[0, 1] * w + p.phi[0, 2] * x + p.gamma[0, 0] * v
    w_new = p.phi[1, 0] * i + p.phi[1, 1] * w + p.phi[1, 2] * x + p.gamma[1, 0] * v
    x_new = p.phi[2, 0] * i + p.phi[2, 1] * w + p.phi[2, 2] * x + p.gamma[2, 0] * v
    i_new += p.gamma[0, 1] * torque
    w_new += p.gamma[1, 1] * torque
    x_new += p.gamma[2, 1] * torque
    if stuck:
        w_new = 0.0
        x_new = x
    elif p.coulomb_friction_Nm > 0.0 and p.coulomb_smoothing_rad_s == 0.0 and w * w_new < 0.0:
        w_new = 0.0  # stopped within the step: at rest, the stick test decides next step
    s.current_A = i_new
    s.speed_rad_s = w_new
    s.position_mm = x_new
    return x, w * p.mm_per_rad, alpha * p.mm_per_rad, i, v


SERVO = register_element(
    "axis.servo",
    _dtypes,
    init,
    step,
    "Peng's DC servo feed axis (2.24)-(2.25): exact ZOH, Coulomb/current limit held",
    output,
)


def servo_axis_records(
    axes: ServoAxisParams | Sequence[ServoAxisParams],
    plant_step_s: float,
    *,
    runs: int | None = None,
    commanded_feed_mm_s: ArrayLike | None = None,
    initial_position_mm: ArrayLike = 0.0,
    initial_speed_rad_s: ArrayLike = 0.0,
    initial_current_A: ArrayLike = 0.0,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of servo axes, exact ZOH at the plant step.

    Parameters
    ----------
    axes : ServoAxisParams or sequence of them, length runs
        Each run's axis (per-run mismatch, e.g. ``B`` per axis); equal parameter sets are
        discretised once.
    plant_step_s : float
        ``dt`` [s], > 0.
    runs : int, optional
        Batch size when ``axes`` is a single parameter set.
    commanded_feed_mm_s : array_like, shape (runs,) or scalar, optional
        The run's commanded feed [mm/s]; needed by ``"speed_dependent_linear"`` friction.
    initial_position_mm, initial_speed_rad_s, initial_current_A : array_like
        Initial state per run (or scalar).

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    if isinstance(axes, ServoAxisParams):
        axes = [axes] * (1 if runs is None else int(runs))
    axes = list(axes)
    n = len(axes)
    if n == 0:
        raise ValueError("servo_axis_records needs at least one axis")
    feeds = (
        [None] * n
        if commanded_feed_mm_s is None
        else list(np.broadcast_to(np.asarray(commanded_feed_mm_s, float), (n,)))
    )
    effective = [a.with_effective_friction(f) for a, f in zip(axes, feeds, strict=True)]
    params, state = SERVO.records(n)
    cache: dict[ServoAxisParams, tuple[NDArray, NDArray]] = {}
    for r, axis in enumerate(effective):
        if axis not in cache:
            cache[axis] = axis.discretise_block(plant_step_s, "mm")
        phi, gamma = cache[axis]
        row = params[r]
        row["phi"] = phi
        row["gamma"] = gamma
        row["torque_constant_Nm_A"] = axis.torque_constant_Nm_A
        row["inertia_kg_m2"] = axis.inertia_kg_m2
        row["viscous_friction_Nm_s_rad"] = axis.viscous_friction_Nm_s_rad
        row["mm_per_rad"] = axis.mm_per_rad
        row["force_to_torque_m"] = axis.force_to_torque_m
        row["coulomb_friction_Nm"] = axis.friction.held_coulomb_Nm
        row["coulomb_smoothing_rad_s"] = axis.coulomb_smoothing_rad_s
        row["current_limit_A"] = axis.current_limit_A
        row["counts_per_mm"] = axis.counts_per_mm
        row["quantise"] = bool(axis.encoder_quantisation)
    params["initial_position_mm"] = np.broadcast_to(np.asarray(initial_position_mm, float), (n,))
    params["initial_speed_rad_s"] = np.broadcast_to(np.asarray(initial_speed_rad_s, float), (n,))
    params["initial_current_A"] = np.broadcast_to(np.asarray(initial_current_A, float), (n,))
    return params, init_states(params, state)


__all__ = ["FORCE_TO_TORQUE_MODELS", "SERVO", "ServoAxisParams", "servo_axis_records"]
