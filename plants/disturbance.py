"""Disturbances of the cutting-force loop: what the observer exists to reject.

A scenario lists any number of disturbances (``[[disturbance]]``), each of one kind, acting
inside a time window and a path interval (both default to always):

================  ==========================================================================
kind              what it does, and its keys
================  ==========================================================================
``force``         an additive cutting force [N] on the regulated force (and on the feed force
                  that loads the screw): tool wear drift, runout, a hard inclusion.  Shape
                  ``step`` (``amplitude_N``), ``ramp`` (``rate_N_per_s`` from the window's
                  start), ``sinusoid`` (``amplitude_N`` at ``frequency_hz``, or at a
                  ``harmonic`` of the ``spindle`` or ``tooth`` frequency, ``phase_deg``), or
                  ``random_walk`` (``random_walk_N_per_sqrt_s``)
``feed``          an additive feed [mm/min] at the feed drive's input, where Kim & Chung's
                  observer places its disturbance (Eq. 10): a friction change, an axis
                  error.  Same shapes, with ``amplitude_mm_min``, ``rate_mm_min_per_s``,
                  ``random_walk_mm_min_per_sqrt_s``
``measurement``   the force the controller sees is ``(1 + gain_error) y + bias_N`` (+
                  ``bias_rate_N_per_s`` times the time in the window): a sensor offset or
                  drift, a miscalibrated force estimate from currents
``hardness``      the process gain times ``gain_multiplier`` over the window (a harder or
                  softer zone of the material); the pole is unchanged
``axial_depth``   the axial depth of cut follows ``axial_depth_mm`` (piecewise linear in the
                  tool position at ``positions_mm``) where the part is cut; the force scales
                  with the axial depth as the tooth-period average does exactly (Eq. 2)
================  ==========================================================================

Randomness comes from the run's disturbance stream (:data:`acc.engine.rng.STREAM_DISTURBANCE`),
so runs that share a noise key share their random walks (common random numbers).

Compiled: :func:`step` returns, at plant step ``k`` and tool position ``p``, the force
multiplier and additive force, the additive feed, and the measurement gain and bias, the
sums over the active disturbances.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import init_states, jit, record, register_element, ring_size
from acc.engine.rng import NORMAL_STREAM, STREAM_DISTURBANCE, normal, seed_stream

KINDS = ("force", "feed", "measurement", "hardness", "axial_depth")
SHAPES = ("step", "ramp", "sinusoid", "random_walk")
HARMONIC_OF = ("none", "spindle", "tooth")

_CHANNEL = {"force": 0, "feed": 1, "measurement": 2, "hardness": 3, "axial_depth": 4}
_SHAPE = {"step": 0, "ramp": 1, "sinusoid": 2, "random_walk": 3}
#: Most breakpoints of an axial-depth profile.
MAX_PROFILE_POINTS = 64


@dataclass(frozen=True)
class Disturbance:
    """One ``[[disturbance]]`` entry (module docstring).

    Attributes
    ----------
    name : str
        Its name, unique in the scenario (campaign keys address it as
        ``disturbance.<name>.<key>``); empty: ``d<index>``.
    kind : {"force", "feed", "measurement", "hardness", "axial_depth"}
    shape : {"step", "ramp", "sinusoid", "random_walk"}
        Time course of a ``force`` or ``feed`` disturbance.
    amplitude_N, rate_N_per_s, random_walk_N_per_sqrt_s : float
        ``force``: step height or sinusoid amplitude [N], ramp slope [N/s], random-walk
        intensity [N/sqrt(s)].
    amplitude_mm_min, rate_mm_min_per_s, random_walk_mm_min_per_sqrt_s : float
        ``feed``: the same in feed units [mm/min], [mm/min/s], [mm/min/sqrt(s)].
    frequency_hz : float
        Sinusoid frequency [Hz] when ``harmonic_of`` is ``"none"``, >= 0.
    harmonic_of : {"none", "spindle", "tooth"}
        Sinusoid at ``harmonic`` times the spindle or tooth-passing frequency (from
        ``[geometry] spindle_speed_rpm`` and ``teeth``): runout.
    harmonic : int
        Multiple of that frequency, >= 1.
    phase_deg : float
        Sinusoid phase at the window's start [deg].
    bias_N, bias_rate_N_per_s, gain_error : float
        ``measurement``: offset [N], drift [N/s] and gain error [-] (> -1).
    gain_multiplier : float
        ``hardness``: factor on the process gain [-], > 0.
    positions_mm, axial_depth_mm : tuple of float
        ``axial_depth``: profile breakpoints along the path [mm] (increasing) and the axial
        depth there [mm] (>= 0); constant beyond the ends.
    start_s, end_s : float, float or None
        Time window [s]; ``end_s`` None: no end.
    start_mm, end_mm : float, float or None
        Path interval of the tool position [mm]; ``end_mm`` None: no end.
    """

    name: str = ""
    kind: str = "force"
    shape: str = "step"
    amplitude_N: float = 0.0
    rate_N_per_s: float = 0.0
    random_walk_N_per_sqrt_s: float = 0.0
    amplitude_mm_min: float = 0.0
    rate_mm_min_per_s: float = 0.0
    random_walk_mm_min_per_sqrt_s: float = 0.0
    frequency_hz: float = 0.0
    harmonic_of: str = "none"
    harmonic: int = 1
    phase_deg: float = 0.0
    bias_N: float = 0.0
    bias_rate_N_per_s: float = 0.0
    gain_error: float = 0.0
    gain_multiplier: float = 1.0
    positions_mm: tuple[float, ...] = ()
    axial_depth_mm: tuple[float, ...] = ()
    start_s: float = 0.0
    end_s: float | None = None
    start_mm: float = 0.0
    end_mm: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if self.shape not in SHAPES:
            raise ValueError(f"shape must be one of {SHAPES}, got {self.shape!r}")
        if self.harmonic_of not in HARMONIC_OF:
            raise ValueError(f"harmonic_of must be one of {HARMONIC_OF}, got {self.harmonic_of!r}")
        if self.harmonic < 1:
            raise ValueError(f"harmonic must be >= 1, got {self.harmonic}")
        if not self.frequency_hz >= 0:
            raise ValueError(f"frequency_hz must be >= 0, got {self.frequency_hz}")
        for key in ("random_walk_N_per_sqrt_s", "random_walk_mm_min_per_sqrt_s"):
            if not getattr(self, key) >= 0:
                raise ValueError(f"{key} must be >= 0, got {getattr(self, key)}")
        if not self.gain_error > -1:
            raise ValueError(f"gain_error must be > -1, got {self.gain_error}")
        if not self.gain_multiplier > 0:
            raise ValueError(f"gain_multiplier must be > 0, got {self.gain_multiplier}")
        if not 0 <= self.start_s <= (math.inf if self.end_s is None else self.end_s):
            raise ValueError(f"start_s/end_s must satisfy 0 <= start <= end, got "
                             f"{self.start_s}, {self.end_s}")
        if not 0 <= self.start_mm <= (math.inf if self.end_mm is None else self.end_mm):
            raise ValueError(f"start_mm/end_mm must satisfy 0 <= start <= end, got "
                             f"{self.start_mm}, {self.end_mm}")
        if self.kind == "axial_depth":
            n = len(self.positions_mm)
            if n == 0 or n != len(self.axial_depth_mm):
                raise ValueError(
                    "positions_mm and axial_depth_mm: an axial-depth profile needs the same "
                    f"number (>= 1) of each, got {n} and {len(self.axial_depth_mm)}"
                )
            if n > MAX_PROFILE_POINTS:
                raise ValueError(f"positions_mm: at most {MAX_PROFILE_POINTS} points, got {n}")
            pos = self.positions_mm
            if any(b <= a for a, b in zip(pos, pos[1:], strict=False)):
                raise ValueError("positions_mm must be strictly increasing")
            if any(not d >= 0 for d in self.axial_depth_mm):
                raise ValueError("axial_depth_mm must be >= 0")

    def frequency_rad_s(self, spindle_speed_rpm: float, teeth: int) -> float:
        """Angular frequency of a sinusoid [rad/s]."""
        if self.harmonic_of == "none":
            return 2.0 * math.pi * self.frequency_hz
        rev_hz = spindle_speed_rpm / 60.0 * (teeth if self.harmonic_of == "tooth" else 1)
        return 2.0 * math.pi * rev_hz * self.harmonic


# --- the compiled element -----------------------------------------------------------------
def _dtypes(entries: int = 8, points: int = 8) -> tuple[np.dtype, np.dtype]:
    params = record(
        "disturbance.set",
        [
            ("count", "i8"),
            ("plant_step_s", "f8"),
            ("channel", "i8", (entries,)),
            ("shape", "i8", (entries,)),
            ("amplitude", "f8", (entries,)),  # [N | mm/min]; measurement: bias [N]
            ("rate_per_s", "f8", (entries,)),  # ramp slope; measurement: bias drift
            ("walk_per_sqrt_s", "f8", (entries,)),
            ("omega_rad_s", "f8", (entries,)),
            ("phase_rad", "f8", (entries,)),
            ("factor", "f8", (entries,)),  # hardness multiplier; measurement gain error
            ("start_step", "i8", (entries,)),
            ("end_step", "i8", (entries,)),  # exclusive; huge for inf
            ("start_mm", "f8", (entries,)),
            ("end_mm", "f8", (entries,)),
            ("points", "i8", (entries,)),
            ("positions_mm", "f8", (entries, points)),
            ("axial_depth_mm", "f8", (entries, points)),
            ("seed", "u8"),
            ("noise_id", "u8"),
        ],
    )
    state = record(
        "disturbance.set", [("walk", "f8", (entries,)), ("noise", NORMAL_STREAM)]
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """Random walks at zero; the disturbance noise stream at its start."""
    for i in range(s.walk.shape[0]):
        s.walk[i] = 0.0
    seed_stream(s.noise, p.seed, p.noise_id, STREAM_DISTURBANCE)


@jit
def _profile(p, i: int, position_mm: float) -> float:  # noqa: ANN001
    """Entry ``i``'s axial depth at a position: piecewise linear, constant beyond the ends."""
    n = p.points[i]
    xs = p.positions_mm[i]
    ys = p.axial_depth_mm[i]
    if position_mm <= xs[0]:
        return ys[0]
    if position_mm >= xs[n - 1]:
        return ys[n - 1]
    j = 1
    while xs[j] < position_mm:
        j += 1
    w = (position_mm - xs[j - 1]) / (xs[j] - xs[j - 1])
    return ys[j - 1] + w * (ys[j] - ys[j - 1])


@jit
def step(p, s, k: int, position_mm: float, axial_depth_mm: float) -> tuple:  # noqa: ANN001
    """The disturbances at plant step ``k`` and tool position [mm], where the part's own
    axial depth is ``axial_depth_mm`` (for an axial-depth profile).

    Returns ``(force_multiplier, force_N, feed_mm_min, measurement_gain, measurement_bias_N)``:
    the true force is ``multiplier f + force_N``, the drive's input ``u + feed_mm_min``, and
    the force the controller sees ``measurement_gain y + measurement_bias_N``.  Random walks
    advance every step, active or not (their numbers do not depend on the window).
    """
    if p.count == 0:  # small enough to be inlined into the loop: no call per plant step
        return 1.0, 0.0, 0.0, 1.0, 0.0
    return _active(p, s, k, position_mm, axial_depth_mm)


@jit
def _active(p, s, k: int, position_mm: float, axial_depth_mm: float) -> tuple:  # noqa: ANN001
    """:func:`step` for a set of at least one disturbance."""
    mult = 1.0
    force = 0.0
    feed = 0.0
    gain = 1.0
    bias = 0.0
    dt = p.plant_step_s
    sqrt_dt = math.sqrt(dt)
    for i in range(p.count):
        if p.shape[i] == 3:
            s.walk[i] += p.walk_per_sqrt_s[i] * sqrt_dt * normal(s.noise)
        if k < p.start_step[i] or k >= p.end_step[i]:
            continue
        if position_mm < p.start_mm[i] or position_mm >= p.end_mm[i]:
            continue
        ch = p.channel[i]
        elapsed = (k - p.start_step[i]) * dt
        if ch == 3:
            mult *= p.factor[i]
            continue
        if ch == 4:
            if axial_depth_mm > 0:
                mult *= _profile(p, i, position_mm) / axial_depth_mm
            continue
        if ch == 2:
            gain *= 1.0 + p.factor[i]
            bias += p.amplitude[i] + p.rate_per_s[i] * elapsed
            continue
        sh = p.shape[i]
        if sh == 0:
            value = p.amplitude[i]
        elif sh == 1:
            value = p.rate_per_s[i] * elapsed
        elif sh == 2:
            value = p.amplitude[i] * math.sin(p.omega_rad_s[i] * elapsed + p.phase_rad[i])
        else:
            value = s.walk[i]
        if ch == 0:
            force += value
        else:
            feed += value
    return mult, force, feed, gain, bias


DISTURBANCES = register_element(
    "disturbance.set",
    _dtypes,
    init,
    step,
    "disturbances: additive force and feed, measurement bias and gain, hardness, axial depth",
)


def _step_index(t: float, plant_step_s: float) -> int:
    if math.isinf(t):
        return np.iinfo(np.int64).max
    return int(math.ceil(t / plant_step_s - 1e-9))


def disturbance_records(
    disturbances: Sequence[Sequence[Disturbance]],
    plant_step_s: float,
    spindle_speed_rpm: Sequence[float],
    teeth: Sequence[int],
    seeds: Sequence[int],
    noise_ids: Sequence[int],
) -> tuple[NDArray, NDArray]:
    """Params and initial state of the disturbances of a batch of runs.

    Parameters
    ----------
    disturbances : sequence (length runs) of sequences of Disturbance
        Each run's disturbance list (may be empty).
    plant_step_s : float
    spindle_speed_rpm, teeth : sequence, length runs
        Spindle speed [rev/min] and teeth of each run's tool (harmonic sinusoids).
    seeds, noise_ids : sequence of int, length runs
        Noise keys (random walks).

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs = len(disturbances)
    most = max((len(d) for d in disturbances), default=0)
    points = max(
        (len(x.positions_mm) for d in disturbances for x in d if x.kind == "axial_depth"),
        default=1,
    )
    params, state = DISTURBANCES.records(runs, entries=ring_size(most), points=ring_size(points))
    params["plant_step_s"] = plant_step_s
    params["seed"] = np.asarray(seeds)
    params["noise_id"] = np.asarray(noise_ids)
    for r, entries in enumerate(disturbances):
        row = params[r]
        row["count"] = len(entries)
        for i, d in enumerate(entries):
            row["channel"][i] = _CHANNEL[d.kind]
            row["shape"][i] = _SHAPE[d.shape]
            if d.kind == "force":
                row["amplitude"][i] = d.amplitude_N
                row["rate_per_s"][i] = d.rate_N_per_s
                row["walk_per_sqrt_s"][i] = d.random_walk_N_per_sqrt_s
            elif d.kind == "feed":
                row["amplitude"][i] = d.amplitude_mm_min
                row["rate_per_s"][i] = d.rate_mm_min_per_s
                row["walk_per_sqrt_s"][i] = d.random_walk_mm_min_per_sqrt_s
            elif d.kind == "measurement":
                row["amplitude"][i] = d.bias_N
                row["rate_per_s"][i] = d.bias_rate_N_per_s
                row["factor"][i] = d.gain_error
            elif d.kind == "hardness":
                row["factor"][i] = d.gain_multiplier
            if d.kind in ("measurement", "hardness", "axial_depth"):
                row["shape"][i] = _SHAPE["step"]
            row["omega_rad_s"][i] = d.frequency_rad_s(spindle_speed_rpm[r], teeth[r])
            row["phase_rad"][i] = math.radians(d.phase_deg)
            row["start_step"][i] = _step_index(d.start_s, plant_step_s)
            row["end_step"][i] = _step_index(
                math.inf if d.end_s is None else d.end_s, plant_step_s
            )
            row["start_mm"][i] = d.start_mm
            row["end_mm"][i] = math.inf if d.end_mm is None else d.end_mm
            n = len(d.positions_mm)
            row["points"][i] = n
            row["positions_mm"][i, :n] = d.positions_mm
            row["axial_depth_mm"][i, :n] = d.axial_depth_mm
    return params, init_states(params, state)


__all__ = [
    "DISTURBANCES",
    "Disturbance",
    "HARMONIC_OF",
    "KINDS",
    "MAX_PROFILE_POINTS",
    "SHAPES",
    "disturbance_records",
]
