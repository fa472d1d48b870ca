"""An axis with one lightly damped mechanical oscillator behind its speed loop (Briquez).

Briquez, Sandoz & Zaquini (seed 004): with the position loop open, the axis from speed
reference to slide speed behaves as ``T(s) = w_0^2 / (s^2 + 2 zeta w_0 s + w_0^2)`` (Eq. 1);
the speed loop (bandwidth ``f_3dBSC``) sits in front of it (Fig. 3; spec M4-1, [RECON]).

Model (slide position in mm, states ``[v_m, d, v, x]``)::

    v_m' = w_s (u - v_m)                       speed loop, first order, w_s = 2 pi f_3dBSC
    d'   = v_m - v                             deflection of the drive train [mm]
    v'   = w_0^2 d - 2 zeta w_0 v - F / m      slide [mm/s^2], F the load [N] (x 1000 / m)
    x'   = v

``u`` is the speed command [mm/s].  The transmission (stiffness ``m w_0^2``) drives the
slide, and the damping ``2 zeta w_0 m`` acts between slide and frame (the guideways, whose
low damping is the paper's subject).  With an ideal speed loop (``v_m = u``) the speed
response is exactly Eq. (1), with DC gain 1.  The slide acceleration *relative to the
frame* is ``a = v'`` (the frame is rigid here); it is what restricted state control feeds
back (L94).

Held over a plant step: the optional Coulomb force on the slide (stick rule of
:mod:`plants.axis.friction`; the paper's guides give about 14 N preload friction per
carriage, L17) and the scale quantisation.  The linear part is an exact ZOH.

Measurement: the linear scale gives ``q round(x / q)`` (resolution ``q``, 0.2 um on the
Huron, L207); the NC forms the mean speed from these increments itself (see
:mod:`controllers.axis.state_control`).

[ASSUMED] ``slide_mass_kg`` (500 kg) only scales the load force; the paper gives no mass.
Only the first-order speed loop is modelled (the spec's ``"pi"`` speed loop needs motor
and slide inertias the paper does not give).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, record, register_element
from plants.axis.discretisation import zoh_matrices
from plants.axis.friction import coulomb_hold
from plants.axis.velocity_loop import check_positive

#: Speed-loop models.
SPEED_LOOPS = ("first_order",)


@dataclass(frozen=True)
class OscillatingAxisParams:
    """Speed loop plus one mechanical oscillator (defaults: the Huron KX10 X axis, L188-L213).

    Attributes
    ----------
    oscillator_frequency_Hz : float
        ``f_0Me`` [Hz] (42).
    oscillator_damping : float
        ``zeta`` [-] (0.2).
    speed_loop : {"first_order"}
        Speed-loop model.
    speed_loop_bandwidth_Hz : float
        ``f_3dBSC`` [Hz] (400).
    scale_resolution_um : float
        Linear-scale resolution ``q`` [um] (0.2); 0 = no quantisation.
    slide_mass_kg : float
        [ASSUMED] slide mass [kg] (500), scales the load force only.
    coulomb_friction_N : float
        Coulomb force on the slide [N] (0; the paper's guides: about 14 N per carriage).
    coulomb_smoothing_mm_s : float
        ``v_eps`` of the tanh option [mm/s]; 0 = stick rule.
    """

    oscillator_frequency_Hz: float = 42.0
    oscillator_damping: float = 0.2
    speed_loop: str = "first_order"
    speed_loop_bandwidth_Hz: float = 400.0
    scale_resolution_um: float = 0.2
    slide_mass_kg: float = 500.0
    coulomb_friction_N: float = 0.0
    coulomb_smoothing_mm_s: float = 0.0

    def __post_init__(self) -> None:
        check_positive(
            self, ("oscillator_frequency_Hz", "speed_loop_bandwidth_Hz", "slide_mass_kg")
        )
        check_positive(
            self,
            ("oscillator_damping", "scale_resolution_um", "coulomb_friction_N",
             "coulomb_smoothing_mm_s"),
            strict=False,
        )
        if self.speed_loop not in SPEED_LOOPS:
            raise ValueError(
                f"speed_loop must be one of {', '.join(SPEED_LOOPS)}, got {self.speed_loop!r}"
            )

    @property
    def oscillator_rad_s(self) -> float:
        """``w_0 = 2 pi f_0Me`` [rad/s]."""
        return 2.0 * math.pi * self.oscillator_frequency_Hz

    @property
    def speed_loop_rad_s(self) -> float:
        """``w_s = 2 pi f_3dBSC`` [rad/s]."""
        return 2.0 * math.pi * self.speed_loop_bandwidth_Hz

    @property
    def scale_resolution_mm(self) -> float:
        """``q`` [mm]."""
        return self.scale_resolution_um * 1e-3

    def state_matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(A, B)``: states ``[v_m, d, v, x]`` [mm/s, mm, mm/s, mm], inputs ``[u (mm/s),
        F (N)]``.

        Returns
        -------
        A : ndarray, shape (4, 4)
        B : ndarray, shape (4, 2)
        """
        w0, ws, z = self.oscillator_rad_s, self.speed_loop_rad_s, self.oscillator_damping
        A = np.array(
            [
                [-ws, 0.0, 0.0, 0.0],
                [1.0, 0.0, -1.0, 0.0],
                [0.0, w0 * w0, -2.0 * z * w0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ]
        )
        B = np.array([[ws, 0.0], [0.0, 0.0], [0.0, -1e3 / self.slide_mass_kg], [0.0, 0.0]])
        return A, B

    def discretise(self, step_s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Exact ZOH ``(Phi, Gamma)`` at ``step_s`` [s]."""
        return zoh_matrices(*self.state_matrices(), step_s)

    def state_space(self) -> Any:
        """python-control ``StateSpace``: inputs ``speed_command_mm_s``, ``load_force_N``;
        outputs ``position_mm``, ``velocity_mm_s``, ``acceleration_mm_s2``."""
        import control

        A, B = self.state_matrices()
        C = np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 0.0], A[2]])
        D = np.array([[0.0, 0.0], [0.0, 0.0], B[2]])
        return control.ss(
            A, B, C, D, inputs=["speed_command_mm_s", "load_force_N"],
            outputs=["position_mm", "velocity_mm_s", "acceleration_mm_s2"],
            states=["motor_speed_mm_s", "deflection_mm", "velocity_mm_s", "position_mm"],
            name="oscillating_axis",
        )

    def oscillator_tf(self) -> Any:
        """Eq. (1), ``w_0^2 / (s^2 + 2 zeta w_0 s + w_0^2)``, motor speed to slide speed."""
        import control

        w0, z = self.oscillator_rad_s, self.oscillator_damping
        return control.tf(
            [w0 * w0], [1.0, 2.0 * z * w0, w0 * w0], inputs=["motor_speed_mm_s"],
            outputs=["velocity_mm_s"], name="oscillator",
        )


def huron_kx10() -> OscillatingAxisParams:
    """Huron KX10 X axis with a SIEMENS 840D (L188-L213): f_0Me 42 Hz, zeta 0.2, f_3dBSC 400
    Hz, scale 0.2 um.  Slide mass [ASSUMED] as the class default."""
    return OscillatingAxisParams()


def boko_vh4_12() -> OscillatingAxisParams:
    """Bokoe VH4/12 X axis (L144): f_0 21 Hz, D_0 0.1.  [ASSUMED]: speed-loop bandwidth
    400 Hz and scale 0.2 um (as the Huron; the paper gives neither)."""
    return OscillatingAxisParams(oscillator_frequency_Hz=21.0, oscillator_damping=0.1)


# --- compiled element ------------------------------------------------------------------
def _dtypes() -> tuple[np.dtype, np.dtype]:
    params = record(
        "axis.oscillating",
        [
            ("phi", "f8", (4, 4)),
            ("gamma", "f8", (4, 2)),  # columns: speed command [mm/s], load force [N]
            ("stiffness_1_s2", "f8"),  # w_0^2
            ("damping_1_s", "f8"),  # 2 zeta w_0
            ("accel_per_N", "f8"),  # 1e3 / m [mm/s^2 per N]
            ("resolution_mm", "f8"),
            ("coulomb_friction_N", "f8"),
            ("coulomb_smoothing_mm_s", "f8"),
            ("initial_position_mm", "f8"),
        ],
    )
    state = record(
        "axis.oscillating",
        [
            ("motor_speed_mm_s", "f8"),
            ("deflection_mm", "f8"),
            ("velocity_mm_s", "f8"),
            ("position_mm", "f8"),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """At rest at the initial position."""
    s.motor_speed_mm_s = 0.0
    s.deflection_mm = 0.0
    s.velocity_mm_s = 0.0
    s.position_mm = p.initial_position_mm


@jit
def _load(p, s, load_force_N: float) -> tuple:  # noqa: ANN001
    """Load held over the step (cutting plus Coulomb) [N], stick flag, acceleration
    [mm/s^2] at the start of the step."""
    spring = p.stiffness_1_s2 * s.deflection_mm / p.accel_per_N  # [N]
    friction, stuck = coulomb_hold(
        p.coulomb_friction_N, p.coulomb_smoothing_mm_s, s.velocity_mm_s, spring - load_force_N
    )
    force = load_force_N + friction
    accel = (
        p.stiffness_1_s2 * s.deflection_mm - p.damping_1_s * s.velocity_mm_s
        - p.accel_per_N * force
    )
    return force, stuck, accel


@jit
def output(p, s, load_force_N: float) -> tuple[float, float, float]:  # noqa: ANN001
    """Sensors at the start of the step: scale position [mm] (quantised), slide velocity
    [mm/s], relative acceleration [mm/s^2]."""
    x = s.position_mm
    q = p.resolution_mm
    if q > 0.0:
        x = q * math.floor(x / q + 0.5)
    _, _, accel = _load(p, s, load_force_N)
    return x, s.velocity_mm_s, accel


@jit
def step(p, s, command_mm_s: float, load_force_N: float) -> tuple:  # noqa: ANN001
    """One plant step, speed command [mm/s] and load [N] held.  Returns position [mm],
    velocity [mm/s], acceleration [mm/s^2], current (NaN: not modelled) and the command
    applied [mm/s], at the start of the step."""
    force, stuck, accel = _load(p, s, load_force_N)
    x0 = s.motor_speed_mm_s
    x1 = s.deflection_mm
    x2 = s.velocity_mm_s
    x3 = s.position_mm
    u = command_mm_s
    n0 = (p.phi[0, 0] * x0 + p.phi[0, 1] * x1 + p.phi[0, 2] * x2 + p.phi[0, 3] * x3
          + p.gamma[0, 0] * u + p.gamma[0, 1] * force)
    n1 = (p.phi[1, 0] * x0 + p.phi[1, 1] * x1 + p.phi[1, 2] * x2 + p.phi[1, 3] * x3
          + p.gamma[1, 0] * u + p.gamma[1, 1] * force)
    n2 = (p.phi[2, 0] * x0 + p.phi[2, 1] * x1 + p.phi[2, 2] * x2 + p.phi[2, 3] * x3
          + p.gamma[2, 0] * u + p.gamma[2, 1] * force)
    n3 = (p.phi[3, 0] * x0 + p.phi[3, 1] * x1 + p.phi[3, 2] * x2 + p.phi[3, 3] * x3
          + p.gamma[3, 0] * u + p.gamma[3, 1] * force)
    if stuck:
        n2 = 0.0
        n3 = x3
    elif p.coulomb_friction_N > 0.0 and p.coulomb_smoothing_mm_s == 0.0 and x2 * n2 < 0.0:
        n2 = 0.0
    s.motor_speed_mm_s = n0
    s.deflection_mm = n1
    s.velocity_mm_s = n2
    s.position_mm = n3
    return x3, x2, accel, math.nan, command_mm_s


OSCILLATING = register_element(
    "axis.oscillating",
    _dtypes,
    init,
    step,
    "Briquez axis: first-order speed loop + mechanical oscillator, quantised scale (exact ZOH)",
    output,
)


def oscillating_axis_records(
    axes: OscillatingAxisParams | Sequence[OscillatingAxisParams],
    plant_step_s: float,
    *,
    runs: int | None = None,
    initial_position_mm: ArrayLike = 0.0,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of a batch of oscillating axes (exact ZOH at ``dt``).

    Parameters
    ----------
    axes : OscillatingAxisParams or sequence of them, length runs
    plant_step_s : float
        ``dt`` [s].
    runs : int, optional
        Batch size when ``axes`` is a single parameter set.
    initial_position_mm : array_like, shape (runs,) or scalar

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    if isinstance(axes, OscillatingAxisParams):
        axes = [axes] * (1 if runs is None else int(runs))
    axes = list(axes)
    n = len(axes)
    if n == 0:
        raise ValueError("oscillating_axis_records needs at least one axis")
    params, state = OSCILLATING.records(n)
    cache: dict[OscillatingAxisParams, tuple[NDArray, NDArray]] = {}
    for r, axis in enumerate(axes):
        if axis not in cache:
            cache[axis] = axis.discretise(plant_step_s)
        phi, gamma = cache[axis]
        row = params[r]
        row["phi"] = phi
        row["gamma"] = gamma
        row["stiffness_1_s2"] = axis.oscillator_rad_s**2
        row["damping_1_s"] = 2.0 * axis.oscillator_damping * axis.oscillator_rad_s
        row["accel_per_N"] = 1e3 / axis.slide_mass_kg
        row["resolution_mm"] = axis.scale_resolution_mm
        row["coulomb_friction_N"] = axis.coulomb_friction_N
        row["coulomb_smoothing_mm_s"] = axis.coulomb_smoothing_mm_s
    params["initial_position_mm"] = np.broadcast_to(np.asarray(initial_position_mm, float), (n,))
    return params, init_states(params, state)


__all__ = [
    "OSCILLATING",
    "SPEED_LOOPS",
    "OscillatingAxisParams",
    "boko_vh4_12",
    "huron_kx10",
    "oscillating_axis_records",
]
