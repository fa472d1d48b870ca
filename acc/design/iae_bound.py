"""A lower bound on the IAE any causal controller can reach on a run: what the dead time fixes.

The command reaches the process ``L`` (the drive's dead time) after it is issued, through the
drive's lag and the process (``x = a K2 / ((s + a)(s - p2)) u``, ``K2`` times the material's
multiplier; the force ``f = m x + d`` with the hardness multiplier ``m`` and an additive force
``d``).  The plant from command to ``x`` has a positive impulse response, so ``x`` is monotone
in the command, and every command lies in ``[u_min, u_max]`` (the override limits times the
programmed feed).  Hence, for an event at ``t_e`` (the cut's entry, a force step, a feed step,
the start or end of a hardness zone) whose first effect on the force a controller can see at
``t_e + L_s`` (``L_s = 0``, or ``L`` for a feed step, which enters before the drive's delay):

* until ``t_e + L_s + L`` the commands that reach the process were issued before anything of
  the event could be seen, so they are those of the undisturbed loop: the pre-event command
  ``u_s`` (the cut's entry: the drive at rest; an event: the loop settled at the reference,
  ``u_s = r |p2| / (K2 m)``, clipped to the limits).  The force is fixed by the plant alone;
* after it, ``x`` lies between the responses to ``u_min`` and ``u_max`` from then on, so
  ``|f - r| >= max(0, m x_lo + d - r, r - m x_hi - d)``.

Summed at the plant step over each event's window (until the next event or
:data:`WINDOW_S`), this is a lower bound on the run's IAE for every controller without preview
of the events that has settled before each of them (the entry's part holds for every
controller).  Disturbances of other kinds or shapes (ramps, sinusoids, random walks, sensor
faults) add nothing: zero is a valid bound on their share.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from acc.scenarios.force import Scenario

#: Longest window counted after an event [s] (the bound is 0 long before, once the limits
#: can restore the force).
WINDOW_S = 5.0


@dataclass(frozen=True)
class Event:
    """One event of a run, for :func:`event_iae_bound`.

    Attributes
    ----------
    multiplier_before, multiplier_after : float
        Hardness multiplier ``m`` of the force before and after [-].
    force_before_N, force_after_N : float
        Additive force ``d`` before and after [N].
    feed_step_mm_min : float
        Step of the feed disturbance at the drive's input [mm/min] (0: none).
    at_rest : bool
        True for the cut's entry: the drive and the force start at rest (no command before).
    """

    multiplier_before: float = 1.0
    multiplier_after: float = 1.0
    force_before_N: float = 0.0
    force_after_N: float = 0.0
    feed_step_mm_min: float = 0.0
    at_rest: bool = False


def unit_step_response(
    bandwidth_rad_s: float, k2_N_min_per_mm_s: float, p2_rad_s: float, step_s: float,
    steps: int,
) -> NDArray[np.float64]:
    """Force ``x`` [N] of the drive and process from rest for a unit command step (1 mm/min) at
    ``t = 0`` (no dead time), at ``t_k = k step_s``, shape ``(steps,)``: the drive and process
    discretised exactly (zero-order hold, matrix exponential) and stepped."""
    return _step_response(float(bandwidth_rad_s), float(k2_N_min_per_mm_s), float(p2_rad_s),
                          float(step_s), int(steps)).copy()


@functools.lru_cache(maxsize=256)
def _step_response(a: float, k2: float, p2: float, dt: float, steps: int) -> NDArray:
    A = np.array([[-a, 0.0], [k2, p2]])  # drive velocity v, force x; x' = K2 v + p2 x
    M = np.zeros((3, 3))
    M[:2, :2], M[0, 2] = A, a
    E = expm(M * dt)
    Ad, Bd = E[:2, :2], E[:2, 2]
    out = np.empty(steps)
    x = np.zeros(2)
    for k in range(steps):
        out[k] = x[1]
        x = Ad @ x + Bd
    return out


def _shifted(g: NDArray, delay_s: float, step_s: float) -> NDArray:
    """``g(t - delay)`` on the same grid (0 before the delay), the delay in whole steps."""
    n = int(round(delay_s / step_s))
    out = np.zeros_like(g)
    if n < len(g):
        out[n:] = g[: len(g) - n]
    return out


def event_iae_bound(
    event: Event,
    reference_force_N: float,
    bandwidth_rad_s: float,
    k2_N_min_per_mm_s: float,
    p2_rad_s: float,
    dead_time_s: float,
    command_range_mm_min: tuple[float, float],
    step_s: float,
    window_s: float = WINDOW_S,
) -> float:
    """Lower bound [N s] on ``sum |f - r| dt`` over ``[t_e, t_e + window_s)`` (module docstring).

    Parameters
    ----------
    event : Event
    reference_force_N : float
    bandwidth_rad_s, k2_N_min_per_mm_s, p2_rad_s : float
        Drive ``a`` [rad/s], process gain ``K2`` (material included) and pole ``p2 < 0``.
    dead_time_s : float
        ``L`` [s].
    command_range_mm_min : (float, float)
        ``(u_min, u_max)`` [mm/min].
    step_s : float
        Plant step ``dt`` [s] of the sum.
    window_s : float
        Window after the event [s].
    """
    if not p2_rad_s < 0:
        raise ValueError(f"p2_rad_s must be < 0 (a stable process), got {p2_rad_s}")
    r = reference_force_N
    u_min, u_max = command_range_mm_min
    steps = int(math.ceil(window_s / step_s - 1e-9))
    gain = k2_N_min_per_mm_s / -p2_rad_s  # steady x per mm/min
    if event.at_rest:
        u_s, x_s = 0.0, 0.0
    else:
        u_s = float(np.clip((r - event.force_before_N) / (event.multiplier_before * gain),
                            u_min, u_max))
        x_s = u_s * gain
    # first command issued after the event's first visible effect reaches the process (from
    # rest, the first command itself)
    seen = dead_time_s if event.feed_step_mm_min != 0 and not event.at_rest else 0.0
    act = seen + dead_time_s

    g = _step_response(float(bandwidth_rad_s), float(k2_N_min_per_mm_s), float(p2_rad_s),
                       float(step_s), steps)
    fixed = x_s + event.feed_step_mm_min * _shifted(g, dead_time_s, step_s)
    after = _shifted(g, act, step_s)
    x_lo = fixed + (u_min - u_s) * after
    x_hi = fixed + (u_max - u_s) * after
    m, d = event.multiplier_after, event.force_after_N
    low = np.maximum(0.0, np.maximum(m * x_lo + d - r, r - m * x_hi - d))
    return float(np.sum(low) * step_s)


def events_of(scenario: Scenario) -> list[tuple[float, Event]]:
    """The run's events as ``(position [mm], Event)``: the entry, then the steps of force and
    feed disturbances and the ends of hardness zones, in path order.

    Raises
    ------
    ValueError
        A part of more than one depth, a disturbance with a time window or an axial-depth
        profile (the bound covers path-triggered events of a one-depth part).
    """
    depths = list(scenario.workpiece.radial_depth_mm)
    if len(set(depths)) != 1 or depths[0] <= 0:
        raise ValueError("workpiece.radial_depth_mm: the bound covers parts of one depth, "
                         f"got {depths}")
    marks: dict[float, list] = {}
    for dist in scenario.disturbances:
        if dist.start_s != 0 or dist.end_s is not None:
            raise ValueError(f"disturbance.{dist.name}: the bound covers path-triggered events "
                             "(start_mm, end_mm), not time windows")
        if dist.kind == "axial_depth":
            raise ValueError(f"disturbance.{dist.name}: the bound does not cover axial-depth "
                             "profiles")
        if dist.kind in ("force", "feed") and dist.shape == "step":
            value: tuple[str, float] = (
                (dist.kind, dist.amplitude_N) if dist.kind == "force"
                else (dist.kind, dist.amplitude_mm_min)
            )
        elif dist.kind == "hardness":
            value = ("hardness", math.log(dist.gain_multiplier))
        else:
            continue  # ramps, sinusoids, random walks, sensor faults: zero is a bound
        marks.setdefault(max(dist.start_mm, 0.0), []).append(value)
        if dist.end_mm is not None:
            marks.setdefault(dist.end_mm, []).append((value[0], -value[1]))
    m_log, force, feed = 0.0, 0.0, 0.0
    for kind, value in marks.pop(0.0, []):
        m_log, force, feed = _apply(kind, value, m_log, force, feed)
    events = [(0.0, Event(1.0, math.exp(m_log), 0.0, force, feed, at_rest=True))]
    for pos in sorted(marks):
        before_m, before_f, feed = math.exp(m_log), force, 0.0
        for kind, value in marks[pos]:
            m_log, force, feed = _apply(kind, value, m_log, force, feed)
        events.append((pos, Event(before_m, math.exp(m_log), before_f, force, feed)))
    return events


def _apply(kind: str, value: float, m_log: float, force: float, feed: float
           ) -> tuple[float, float, float]:
    if kind == "force":
        return m_log, force + value, feed
    if kind == "feed":
        return m_log, force, feed + value
    return m_log + value, force, feed


def iae_lower_bound(scenario: Scenario) -> float:
    """Lower bound [N s] on the run's IAE for any causal controller (module docstring).

    Each event's window ends at the next event (at the programmed feed's pace at the most
    restrictive, i.e. the shortest of :data:`WINDOW_S` and the time the fastest feed takes).
    """
    events = events_of(scenario)
    sc = scenario
    depth = sc.workpiece.radial_depth_mm[0]
    k2a, p2a = sc.force_process.parameters([depth])
    axial = sc.workpiece.axial_depth_mm[0] / sc.force_process.reference_axial_depth_mm
    k2 = float(k2a[0]) * axial
    p2 = float(p2a[0])
    c = sc.controller
    u_range = (c.override_min * c.programmed_feed_mm_min, c.override_max * c.programmed_feed_mm_min)
    fastest_mm_s = u_range[1] / 60.0
    total = 0.0
    length = float(sum(sc.workpiece.segment_length_mm))
    for i, (pos, event) in enumerate(events):
        # the last event's window ends with the part (at the fastest feed at the latest)
        gap_mm = (events[i + 1][0] if i + 1 < len(events) else length) - pos
        window = min(WINDOW_S, gap_mm / fastest_mm_s)
        total += event_iae_bound(
            event, c.reference_force_N, sc.feed_drive.bandwidth_rad_s, k2, p2,
            sc.feed_drive.dead_time_s, u_range, sc.simulation.plant_step_s, window,
        )
    return total


def held_force_floor(scenario: Scenario) -> float:
    """IAE floor [N s] of a run for a controller that holds the mean *measured* force at the
    reference (every design with integral action does, in steady state): evidence, not a
    bound for every controller (a controller could cut faster or slower and trade the
    mean force for time).

    * a sensor bias ``b`` from ``start_mm``: the true force sits at ``r - b`` while the tool
      cuts the rest of the part at the feed that gives it, ``u = (r - b) |p2| / (K2 m)``:
      ``|b|`` times that time;
    * a force sinusoid of amplitude ``A`` at ``w``: the command can give the force at ``w`` a
      fundamental of at most ``(4 / pi) |P(jw)| min(u_r - u_min, u_max - u_r)`` (a square
      wave within the limits around the mean feed ``u_r``); what is left, ``c``, keeps the mean
      of ``|e|`` at ``c / 2`` or more, for the time the part takes at ``u_r`` (less the
      entry's window :data:`WINDOW_S` if it acts from the entry, so that the floor adds to
      :func:`iae_lower_bound` without counting a time twice).

    * a stretch between events (:func:`events_of`) on which the override's limits cannot
      bring the force to the reference (a plant or hardness zone so stiff that ``u_min``
      gives more than ``r``, or so soft that ``u_max`` gives less): the force held at the
      limit, ``|m G u + d - r|``, for the time the stretch takes at that limit, less the
      event's window (which the bound counts).  A controller that raced through faster
      would trade it for a larger force.

    Other disturbances add nothing.  Same assumptions on the part as :func:`events_of`.
    """
    events = events_of(scenario)  # checks the part and the disturbances
    sc = scenario
    depth = sc.workpiece.radial_depth_mm[0]
    k2a, p2a = sc.force_process.parameters([depth])
    k2 = float(k2a[0]) * sc.workpiece.axial_depth_mm[0] / sc.force_process.reference_axial_depth_mm
    b_pole = -float(p2a[0])
    c = sc.controller
    r = c.reference_force_N
    u_min = c.override_min * c.programmed_feed_mm_min
    u_max = c.override_max * c.programmed_feed_mm_min
    length = float(sum(sc.workpiece.segment_length_mm))
    u_r = r * b_pole / k2
    total = 0.0
    for d in sc.disturbances:
        if d.kind == "measurement" and d.bias_rate_N_per_s == 0 and d.gain_error == 0:
            end = length if d.end_mm is None else min(d.end_mm, length)
            u_b = max(r - d.bias_N, 0.0) * b_pole / k2
            if u_b > 0:
                total += abs(d.bias_N) * (end - d.start_mm) / (u_b / 60.0)
        elif d.kind == "force" and d.shape == "sinusoid":
            w = d.frequency_rad_s(sc.geometry.spindle_speed_rpm, sc.geometry.teeth)
            a = sc.feed_drive.bandwidth_rad_s
            gain = a * k2 / abs((1j * w + a) * (1j * w + b_pole))
            reach = 4.0 / math.pi * gain * max(0.0, min(u_r - u_min, u_max - u_r))
            left = max(0.0, d.amplitude_N - reach)
            end = length if d.end_mm is None else min(d.end_mm, length)
            seconds = (end - d.start_mm) / (u_r / 60.0)
            if d.start_mm <= 0:  # not over the entry's window, which the bound counts
                seconds -= WINDOW_S
            total += left / 2.0 * max(0.0, seconds)
    if not any(d.kind == "feed" for d in sc.disturbances):  # a feed offset moves the limits
        gain = k2 / b_pole
        for i, (pos, event) in enumerate(events):
            end = events[i + 1][0] if i + 1 < len(events) else length
            m, d = event.multiplier_after, event.force_after_N
            window = min(WINDOW_S, (end - pos) / (u_max / 60.0))
            for u, excess in ((u_min, m * gain * u_min + d - r), (u_max, r - m * gain * u_max - d)):
                if excess > 0 and u > 0:
                    total += excess * max(0.0, (end - pos) / (u / 60.0) - window)
    return total


#: Controller kinds without integral action: they do not hold the mean measured force at the
#: reference, so :func:`held_force_floor` is no floor of theirs.
INTEGRAL_FREE_KINDS = frozenset({"constant"})


def bound_coverage(scenario: Scenario) -> str | None:
    """Why :func:`iae_lower_bound` does not cover a run (None: it does).

    The bound models the drive of Eq. 6 (``feed_drive.kind = "fopdt"``) and the force
    process of Eq. 7 (not the geometric force model), a part of one depth and path-triggered
    disturbances (:func:`events_of`).
    """
    if scenario.geometry.enabled:
        return "geometry: the bound models Eq. 7's force process, not the geometric model"
    if scenario.feed_drive.kind != "fopdt":
        return f"feed_drive.kind: the bound models Eq. 6's drive, not {scenario.feed_drive.kind!r}"
    try:
        events_of(scenario)
    except ValueError as exc:
        return str(exc)
    return None


def unavoidable_iae_N_s(scenario: Scenario) -> float:
    """IAE [N s] of a run that no controller of its kind could remove: the causal bound
    :func:`iae_lower_bound`, plus :func:`held_force_floor` for a kind with integral action
    (every kind but :data:`INTEGRAL_FREE_KINDS`); NaN where :func:`bound_coverage` says the
    bound does not cover the run.

    Cached per distinct set of the values it reads (runs that differ in their seed or
    sensor noise share one computation): about 10 ms for a new plant, 0.2 ms otherwise.
    """
    sc = scenario
    key = (
        sc.workpiece, sc.force_process, sc.feed_drive, sc.controller,
        sc.simulation.plant_step_s, sc.disturbances, sc.geometry,
    )
    value = _UNAVOIDABLE.get(key)
    if value is None:
        if bound_coverage(sc) is not None:
            value = math.nan
        else:
            value = iae_lower_bound(sc)
            if sc.controller.kind not in INTEGRAL_FREE_KINDS:
                value += held_force_floor(sc)
        if len(_UNAVOIDABLE) >= _CACHE_SIZE:
            _UNAVOIDABLE.clear()
        _UNAVOIDABLE[key] = float(value)
    return float(value)


#: Cache of :func:`unavoidable_iae_N_s` (cleared when it holds this many values).
_CACHE_SIZE = 4096
_UNAVOIDABLE: dict[tuple, float] = {}


__all__ = [
    "Event",
    "INTEGRAL_FREE_KINDS",
    "bound_coverage",
    "unavoidable_iae_N_s",
    "held_force_floor",
    "WINDOW_S",
    "event_iae_bound",
    "events_of",
    "iae_lower_bound",
    "unit_step_response",
]
