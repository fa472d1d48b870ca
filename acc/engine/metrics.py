"""Per-run metrics of a cutting-force loop, accumulated online (no trace needed).

The accumulation is a compiled element (:data:`FORCE_TRACKING`) stepped by the force loop;
:func:`metrics_result` turns its state records into the metric columns.

Definitions (``e = f - r`` on the true force ``f`` [N], reference ``r`` [N], plant step ``dt``):

* Window: the plant steps at which the tool is in the material (radial depth > 0 and the
  part not yet finished).  ``cutting_time_s`` is its length.
* ``iae_N_s = sum |e| dt``, ``ise_N2_s = sum e^2 dt``, ``rms_error_N = sqrt(ise / cutting_time)``.
* Per cutting segment ``j`` (the depth the tool meets after each depth step, the first
  engagement included): ``peak_force_N_seg{j}``, ``overshoot_pct_seg{j} = 100 (peak - r) / r``
  and ``settling_time_s_seg{j}``: time from entering the segment to the last sample in the
  segment outside ``r (1 +- band/100)``, plus one step; NaN if the segment ends outside the
  band (never settled) or was never reached.
* ``machining_time_s``: time at which the tool position reaches the end of the part; NaN if
  the time limit came first.
* ``conventional_time_s``: machining time of the same part at the safe constant feed
  (:func:`safe_feed_mm_min`), from the closed-form travel of the feed drive started at rest;
  ``productivity_gain_pct = 100 (conventional_time / machining_time - 1)``, NaN for a run
  that oscillates or overloads (no credit).
* ``peak_force_ratio = peak_force_N / r`` and ``entry_peak_ratio_seg{j} =
  peak_force_N_seg{j} / r`` [-]: the largest true force over the reference, of the run and of
  segment ``j`` (where the entry transient peaks).
* Judged stretches: each cutting segment, cut again from its start after every *known
  event* inside it (a disturbance's window edge, ``start_mm``/``end_mm``/``start_s``/
  ``end_s``; :func:`event_marks`).  The first window of ``oscillation_window_s`` of cutting
  of a stretch is its transient and is not judged.  Where the run has a spindle-periodic
  force (the geometric force model, or a force or feed sinusoid at a harmonic of the spindle
  or tooth frequency, :func:`spindle_periodic`) the force error is first averaged over one
  spindle revolution (its ripple is not a loop oscillation); otherwise not at all.
* ``oscillating``, ``limit_cycle_amplitude_N``: :func:`judge_oscillation`.
* ``held_overload``, ``held_force_ratio``: the force error averaged over a whole window of
  ``oscillation_window_s`` of a judged stretch (sliding by a quarter window), at its largest,
  over ``r``: ``held_force_ratio = 1 + max mean(e) / r`` (NaN: no window judged).  A run with
  ``held_force_ratio > 1 + overload_tolerance_pct / 100`` held the force above the reference
  beyond the tolerance for a window: ``held_overload``.
* ``overload``: the force exceeded ``force_limit_N`` at some step (``overload_time_s`` is
  the time above it) *or* ``held_overload``: either way the force was too high, never
  productivity.
* ``iae_spindle_averaged_N_s = sum |e_avg| dt``: the IAE of the error averaged over the last
  spindle revolution where the force is spindle-periodic (geometry on, or a disturbance at a
  spindle or tooth harmonic; the average restarts with each judged stretch), which removes
  the runout and tooth-passing ripple no override can follow; elsewhere equal to ``iae_N_s``.
* ``excess_iae_N_s`` (only with ``[metrics] excess_iae = true``; :func:`excess_iae_N_s`):
  ``iae_N_s - floor``, the IAE above what no causal controller could remove: ``floor`` is the
  causal bound :func:`acc.design.iae_bound.iae_lower_bound` (every controller), plus, for a
  controller with integral action (every feedback kind; not ``constant``), the held-force
  floor :func:`acc.design.iae_bound.held_force_floor` (which adds to the bound without
  counting a time twice).  NaN where the bound does not cover the run (a part of several
  depths, the geometric force model, the servo-axis feed drive, time-windowed or
  axial-depth disturbances).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from acc.engine.element import delay_size, init_states, jit, record, register_element, ring_size
from plants.workpiece import segment_size

if TYPE_CHECKING:  # the scenario imports the engine's current-sensing section
    from acc.scenarios.force import Scenario


#: Resolution of the overshoot metrics [%]: finer digits are the rounding of a peak that equals
#: the reference, not an overshoot.
OVERSHOOT_RESOLUTION_DECIMALS = 9


def percent_over(value: NDArray[np.float64], reference: NDArray[np.float64]
                 ) -> NDArray[np.float64]:
    """``100 (value - r) / r`` [%], rounded to 1e-9 %: a peak that equals the reference up to
    float rounding reads 0, not -1.9e-12 %.

    Parameters
    ----------
    value, reference : ndarray, shape (runs,)
        Peak force and reference force [N].

    Returns
    -------
    ndarray, shape (runs,)
        Overshoot [%] (negative: the peak stayed below the reference); NaN where ``value`` is.
    """
    pct = 100.0 * (value - reference) / reference
    return np.round(pct, OVERSHOOT_RESOLUTION_DECIMALS) + 0.0  # + 0.0: no "-0"


def safe_feed_mm_min(reference_force_N: float, static_gains_N_per_mm_min: NDArray) -> float:
    """Largest constant feed whose steady force is at most the reference on every depth.

    With the force process realised as ``f = G x`` and ``x`` a monotone first-order response
    to the feed, a constant feed ``F`` started at rest never gives more force than ``G F``;
    so ``F_safe = r / max G`` over the cutting segments [mm/min].
    """
    g = np.asarray(static_gains_N_per_mm_min, dtype=float)
    g = g[g > 0]
    return reference_force_N / float(g.max())


def safe_feeds_mm_min(
    reference_force_N: NDArray[np.float64], static_gains_N_per_mm_min: NDArray[np.float64]
) -> NDArray[np.float64]:
    """:func:`safe_feed_mm_min` of every run of a batch at once (the same doubles).

    Parameters
    ----------
    reference_force_N : ndarray, shape (runs,)
        Reference force of each run [N].
    static_gains_N_per_mm_min : ndarray, shape (runs, segments)
        Static gain of each segment [N/(mm/min)]; 0 (or less) in air.

    Returns
    -------
    ndarray, shape (runs,)
        Safe constant feed of each run [mm/min].

    Raises
    ------
    ValueError
        For a run without a cutting segment, as :func:`safe_feed_mm_min` raises it.
    """
    gains = np.where(static_gains_N_per_mm_min > 0, static_gains_N_per_mm_min, -np.inf)
    largest = gains.max(axis=1)
    for i in np.flatnonzero(~(largest > 0)):
        safe_feed_mm_min(reference_force_N[i], static_gains_N_per_mm_min[i])
    return reference_force_N / largest


def constant_feed_time_s(
    length_mm: float, feed_mm_min: float, bandwidth_rad_s: float, dead_time_s: float
) -> float:
    """Time for the feed drive (Eq. 6), started at rest, to travel a length at a constant command.

    Travel ``s(t) = F/60 (t - L - (1 - exp(-a (t - L))) / a)`` for ``t >= L``; solved for
    ``s = length`` [s].  With ``x = a (t - L)`` the travel is ``F/60 g(x) / a``,
    ``g(x) = x - 1 + exp(-x)``, evaluated by its series for small ``x`` (no cancellation), and
    ``g(x) = c = a length / v`` is solved by Newton's method from ``x = sqrt(3 c)`` if that is
    at most 1, else ``c + 1``: right of the root either way (``g(x) >= x^2 / 3`` for ``x <=
    1``; ``g(c + 1) >= c``), and ``g`` is increasing and convex, so the iterates fall
    monotonically to it (one or two steps for a part of more than a few drive time
    constants: 0.7 us against 4.3 for the bracketing search it replaced).

    Raises
    ------
    ValueError
        Unless length, feed and bandwidth are finite and > 0.
    """
    if not feed_mm_min > 0:
        return math.inf
    v = feed_mm_min / 60.0
    a, L = bandwidth_rad_s, dead_time_s
    for name, value in (("length_mm", length_mm), ("feed", v), ("bandwidth_rad_s", a)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be finite and > 0, got {value}")
    if not math.isfinite(2.0 * (length_mm / v + 1.0 / a)):
        raise ValueError(f"travel time overflows (length {length_mm} mm at {v} mm/s)")
    c = a * length_mm / v
    if not c > 0.0:  # a length below the smallest double in drive units: no travel at all
        return L
    x = math.sqrt(3.0 * c) if 3.0 * c <= 1.0 else c + 1.0
    previous = math.inf
    for _ in range(NEWTON_STEPS_MAX):
        if x < 1e-3:
            excess = x * x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x / 120.0))) - c
        else:
            excess = x + math.expm1(-x) - c
        step = excess / -math.expm1(-x)
        # at the root to rounding: the excess changes sign, or the steps stop shrinking
        # (converging, each is far below half the one before; at g's rounding they are alike)
        if not (step > 0.0 and step < 0.5 * previous):
            return L + x / a
        x -= step
        previous = step
    raise RuntimeError(f"no travel time found for {length_mm} mm at {v} mm/s (a = {a}/s)")


#: Newton steps :func:`constant_feed_time_s` takes at most (it takes a few: the start is
#: within a factor sqrt(3/2) of the root for short parts and next to it for long ones).
NEWTON_STEPS_MAX = 100


#: Blocks kept for the oscillation test: the last window (4 blocks) and the one before.
OSCILLATION_RING = 8
#: Blocks per oscillation window.
WINDOW_BLOCKS = 4


#: Padding of the event lists (no event).
NO_EVENT_STEP = np.iinfo(np.int64).max


def _dtypes(
    segments: int = 8, revolution: int = 8, events: int = 8
) -> tuple[np.dtype, np.dtype]:
    params = record(
        "metrics.force_tracking",
        [
            ("reference_force_N", "f8"),
            ("band_N", "f8"),  # settling band, r * settling_band_pct / 100
            ("divergence_N", "f8"),  # |f| beyond this (or non-finite) fails the run
            ("plant_step_s", "f8"),
            ("block_steps", "i8"),  # cutting steps per oscillation block (window / 4)
            ("entry_steps", "i8"),  # a segment's entry transient: a window and a revolution
            ("oscillation_threshold_N", "f8"),  # AC amplitude above which a run oscillates
            ("last_step", "i8"),  # the time limit's last plant step
            ("average_steps", "i8"),  # plant steps of one spindle revolution (the average)
            ("force_limit_N", "f8"),  # overload above this (inf: none)
            ("decay_ratio", "f8"),  # last / before window amplitude below this: decaying
            ("held_tolerance_N", "f8"),  # window-mean error above this: held overload
            ("cutting", "u1", (segments,)),  # 1 = cut
            ("event_mm", "f8", (events,)),  # known events' tool positions, ascending (inf pad)
            ("event_step", "i8", (events,)),  # and plant steps, ascending (NO_EVENT_STEP pad)
        ],
    )
    state = record(
        "metrics.force_tracking",
        [
            ("iae_N_s", "f8"),
            ("iae_averaged_N_s", "f8"),  # of the error averaged over a spindle revolution
            ("ise_N2_s", "f8"),
            ("cut_steps", "i8"),
            ("finish_step", "i8"),  # -1: not finished
            ("stop_step", "i8"),  # last plant step simulated
            ("failed", "b1"),
            ("peak_N", "f8", (segments,)),
            ("enter_step", "i8", (segments,)),  # -1: never reached
            ("last_out_step", "i8", (segments,)),  # last step outside the band; -1: never
            ("last_in_step", "i8", (segments,)),  # last step in the segment
            ("overload_steps", "i8"),
            ("block_sum_N", "f8"),  # force error of the current oscillation block
            ("block_sumsq_N2", "f8"),
            ("block_n", "i8"),
            ("blocks", "i8"),  # completed blocks (of the segment the tool is in)
            ("segment_cut_steps", "i8"),  # cutting steps in that segment so far
            ("judged_segment", "i8"),  # the segment the blocks belong to (-1: none yet)
            ("oscillating", "b1"),
            ("average_ring_N", "f8", (revolution,)),  # force errors of the last revolution
            ("average_sum_N", "f8"),
            ("average_head", "i8"),
            ("oscillation_amplitude_N", "f8"),  # largest judged amplitude (NaN: none judged)
            ("ring_sum_N", "f8", (OSCILLATION_RING,)),  # the last completed blocks
            ("ring_sumsq_N2", "f8", (OSCILLATION_RING,)),
            ("ring_n", "i8", (OSCILLATION_RING,)),
            ("next_event_mm", "i8"),  # index of the next event position to pass
            ("next_event_step", "i8"),
            ("next_event_at_mm", "f8"),  # that event's position (inf: none left)
            ("next_event_at_step", "i8"),  # and plant step (NO_EVENT_STEP: none left)
            ("held_overload", "b1"),
            ("held_excess_N", "f8"),  # largest window-mean error (NaN: no window)
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """Nothing accumulated yet."""
    s.iae_N_s = 0.0
    s.iae_averaged_N_s = 0.0
    s.ise_N2_s = 0.0
    s.cut_steps = 0
    s.finish_step = -1
    s.stop_step = -1
    s.failed = False
    for j in range(s.peak_N.shape[0]):
        s.peak_N[j] = -np.inf
        s.enter_step[j] = -1
        s.last_out_step[j] = -1
        s.last_in_step[j] = -1
    s.overload_steps = 0
    s.block_sum_N = 0.0
    s.block_sumsq_N2 = 0.0
    s.block_n = 0
    s.blocks = 0
    s.segment_cut_steps = 0
    s.judged_segment = -1
    s.average_sum_N = 0.0
    s.average_head = 0
    for j in range(s.average_ring_N.shape[0]):
        s.average_ring_N[j] = 0.0
    s.oscillating = False
    s.oscillation_amplitude_N = np.nan
    for j in range(OSCILLATION_RING):
        s.ring_sum_N[j] = 0.0
        s.ring_sumsq_N2[j] = 0.0
        s.ring_n[j] = 0
    s.next_event_mm = 0
    s.next_event_step = 0
    _next_events(p, s)
    s.held_overload = False
    s.held_excess_N = np.nan


@jit
def _window_sums(s, newest: int) -> tuple[float, float, int]:  # noqa: ANN001
    """Sum, sum of squares and count of the force error over the WINDOW_BLOCKS completed
    blocks ending with block ``newest``."""
    s1 = 0.0
    s2 = 0.0
    n = 0
    for b in range(WINDOW_BLOCKS):
        slot = (newest - b) % OSCILLATION_RING
        s1 += s.ring_sum_N[slot]
        s2 += s.ring_sumsq_N2[slot]
        n += s.ring_n[slot]
    return s1, s2, n


@jit
def _window_amplitude(s, newest: int) -> float:  # noqa: ANN001
    """AC amplitude sqrt(2 var) of the force error over the WINDOW_BLOCKS completed blocks
    ending with block ``newest`` (about the window's own mean) [N]."""
    s1, s2, n = _window_sums(s, newest)
    mean = s1 / n
    return math.sqrt(2.0 * max(s2 / n - mean * mean, 0.0))


@jit
def _window_mean(s, newest: int) -> float:  # noqa: ANN001
    """Mean force error over the WINDOW_BLOCKS completed blocks ending with ``newest`` [N]."""
    s1, _, n = _window_sums(s, newest)
    return s1 / n


@jit
def judge_oscillation(p, s) -> None:  # noqa: ANN001
    """Judge the stretch the blocks belong to (a segment, or its part after a known event),
    then clear them for the next one.

    After the stretch's transient (its first window ``W``), the force error's AC amplitude
    ``A = sqrt(2 var)`` is taken over the stretch's last two windows, ``A_before`` then
    ``A_last``.  The stretch oscillates iff

    * ``A_last > threshold`` and ``A_before > threshold`` (an oscillation, not noise), and
    * ``A_last >= rho A_before`` with ``rho`` = ``oscillation_decay_ratio``: the amplitude is
      sustained (a limit cycle's stays, a growing one's rises), not decaying.

    Boundary: for a damped sinusoid ``e = A0 exp(-sigma t) sin(w t)`` with many periods in a
    window (``w W >> 1``) the windows' variances are ``A0^2 / (2 W) int exp(-2 sigma t) dt``
    over each window, so ``A_last / A_before = exp(-sigma W)`` exactly when ``w W`` is a
    multiple of ``pi`` (and to ``O(1 / (w W))`` otherwise): it is flagged iff
    ``sigma <= ln(1 / rho) / W`` (0.347 1/s for ``rho = 1/2``, ``W = 2 s``: an envelope time
    constant of at least 2.9 s) and ``A_last`` is above the threshold.  A step transient of a
    well-damped loop decays by far more than ``rho`` within a window; and a transient started
    by a known event is not judged at all (the event restarts the stretch).  A stretch cut for
    less than three windows is not judged.  The amplitude reported is the smaller of the two
    windows' (the sustained one).
    """
    if s.blocks >= 2 * WINDOW_BLOCKS:
        last = _window_amplitude(s, s.blocks - 1)
        before = _window_amplitude(s, s.blocks - 1 - WINDOW_BLOCKS)
        sustained = last >= p.decay_ratio * before
        if last > p.oscillation_threshold_N and before > p.oscillation_threshold_N and sustained:
            s.oscillating = True
        amplitude = min(last, before)
        if math.isnan(s.oscillation_amplitude_N) or amplitude > s.oscillation_amplitude_N:
            s.oscillation_amplitude_N = amplitude
    s.blocks = 0
    s.block_n = 0
    s.block_sum_N = 0.0
    s.block_sumsq_N2 = 0.0
    s.segment_cut_steps = 0
    s.average_sum_N = 0.0
    s.average_head = 0
    for j in range(s.average_ring_N.shape[0]):
        s.average_ring_N[j] = 0.0


@jit
def _next_events(p, s) -> None:  # noqa: ANN001
    """Cache the position [mm] and plant step of the next events to pass (inf and
    :data:`NO_EVENT_STEP` once none is left), which :func:`step` compares with."""
    i = s.next_event_mm
    s.next_event_at_mm = p.event_mm[i] if i < p.event_mm.shape[0] else np.inf
    j = s.next_event_step
    s.next_event_at_step = p.event_step[j] if j < p.event_step.shape[0] else NO_EVENT_STEP


@jit
def _pass_events(p, s, k: int, position_mm: float) -> bool:  # noqa: ANN001
    """Pass the events at or before plant step ``k`` and position ``position_mm``; True if
    any was passed."""
    event = False
    while s.next_event_mm < p.event_mm.shape[0] and position_mm >= p.event_mm[s.next_event_mm]:
        s.next_event_mm += 1
        event = True
    while s.next_event_step < p.event_step.shape[0] and k >= p.event_step[s.next_event_step]:
        s.next_event_step += 1
        event = True
    _next_events(p, s)
    return event


@jit
def step(  # noqa: ANN001
    p, s, k: int, force_N: float, segment: int, finished: bool, position_mm: float = math.nan
) -> bool:
    """Account for plant step ``k`` (force at ``t_k`` [N], segment over the step, tool
    position [mm]; NaN: no path events are seen).

    Returns True when the run stops here: the part is finished, or the force left
    ``[-D r, D r]`` or became non-finite (the run failed).
    """
    if not (abs(force_N) <= p.divergence_N):
        s.failed = True
        if math.isnan(force_N):  # its segment's peak is NaN from here on
            s.peak_N[segment] = math.nan
    event = False
    # one comparison each a step, against the next event's position and step
    if position_mm >= s.next_event_at_mm or k >= s.next_event_at_step:
        event = _pass_events(p, s, k, position_mm)
    e = force_N - p.reference_force_N
    if p.cutting[segment]:
        s.iae_N_s += abs(e) * p.plant_step_s
        s.ise_N2_s += e * e * p.plant_step_s
        s.cut_steps += 1
        if segment != s.judged_segment or event:
            # the stretch just left (a segment, or its part before a known event) is judged,
            # then the blocks start afresh: a transient an event starts is not judged
            judge_oscillation(p, s)
            s.judged_segment = segment
        s.segment_cut_steps += 1
        # the error averaged over the last spindle revolution: the force ripple of runout and
        # tooth passing (periodic in a revolution) is not an oscillation of the loop; a run
        # without a spindle-periodic force averages over one step, the error itself
        if p.average_steps == 1:
            ea = e
        else:
            head = s.average_head
            s.average_sum_N += e - s.average_ring_N[head]
            s.average_ring_N[head] = e
            s.average_head = head + 1 if head + 1 < p.average_steps else 0
            ea = s.average_sum_N / p.average_steps
        s.iae_averaged_N_s += abs(ea) * p.plant_step_s
        # the first window after entering a segment is its entry transient: not counted
        if s.segment_cut_steps > p.entry_steps:
            s.block_sum_N += ea
            s.block_sumsq_N2 += ea * ea
            s.block_n += 1
            if s.block_n == p.block_steps:
                slot = s.blocks % OSCILLATION_RING
                s.ring_sum_N[slot] = s.block_sum_N
                s.ring_sumsq_N2[slot] = s.block_sumsq_N2
                s.ring_n[slot] = s.block_n
                s.blocks += 1
                if s.blocks >= WINDOW_BLOCKS:  # the force held over a whole window
                    held = _window_mean(s, s.blocks - 1)
                    if math.isnan(s.held_excess_N) or held > s.held_excess_N:
                        s.held_excess_N = held
                    if held > p.held_tolerance_N:
                        s.held_overload = True
                s.block_sum_N = 0.0
                s.block_sumsq_N2 = 0.0
                s.block_n = 0
    if force_N > p.force_limit_N:
        s.overload_steps += 1
    # (a NaN force set the peak NaN above; a NaN peak stays NaN: no force compares greater)
    if force_N > s.peak_N[segment]:
        s.peak_N[segment] = force_N
    if s.enter_step[segment] < 0:
        s.enter_step[segment] = k
    s.last_in_step[segment] = k
    if abs(e) > p.band_N:
        s.last_out_step[segment] = k
    if finished and s.finish_step < 0:
        s.finish_step = k
    s.stop_step = k
    stop = finished or s.failed
    if stop or k == p.last_step:
        judge_oscillation(p, s)
    return stop


FORCE_TRACKING = register_element(
    "metrics.force_tracking",
    _dtypes,
    init,
    step,
    "online force-tracking metrics: IAE, ISE, peaks, settling per segment, finish, failure",
)


def metrics_records(
    reference_force_N: NDArray,
    cutting: NDArray[np.bool_],
    settling_band_pct: NDArray,
    divergence_factor: NDArray,
    plant_step_s: float,
    oscillation_window_s: NDArray | float = 2.0,
    force_limit_N: NDArray | float = np.inf,
    oscillation_threshold_N: NDArray | float = np.inf,
    n_steps: int = -1,
    revolution_steps: NDArray | int = 1,
    decay_ratio: NDArray | float = 0.5,
    overload_tolerance_pct: NDArray | float = np.inf,
    events: Sequence[tuple[Sequence[float], Sequence[int]]] | None = None,
) -> tuple[NDArray, NDArray]:
    """Params and initial state of the metrics of a batch.

    Parameters
    ----------
    reference_force_N : ndarray, shape (runs,)
    cutting : ndarray of bool, shape (runs, segments + 1)
        Whether each segment (with the trailing "left the part" column) is a cut.
    settling_band_pct, divergence_factor : ndarray, shape (runs,)
    plant_step_s : float
    oscillation_window_s : ndarray, shape (runs,), or float
        Trailing window of cutting time the oscillation test looks at [s].
    force_limit_N : ndarray, shape (runs,), or float
        Overload limit [N] (inf: none).
    oscillation_threshold_N : ndarray, shape (runs,), or float
        AC amplitude of the force error above which a segment oscillates [N].
    n_steps : int
        Plant steps up to the time limit (the last segment is judged at the last one).
    revolution_steps : ndarray of int, shape (runs,), or int
        Plant steps of one spindle revolution: the oscillation test averages the force error
        over it (1: no average; :func:`revolution_steps`).
    decay_ratio : ndarray, shape (runs,), or float
        ``rho`` of :func:`judge_oscillation` [-], in (0, 1].
    overload_tolerance_pct : ndarray, shape (runs,), or float
        A window-mean force above ``r (1 + tol / 100)`` is a held overload [%] (inf: never).
    events : sequence of (positions [mm], plant steps), length runs, or None
        Each run's known events (:func:`event_marks`); None: none.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    runs, ncol = cutting.shape
    revolution = np.maximum(np.broadcast_to(np.asarray(revolution_steps, np.int64), (runs,)), 1)
    marks = [((), ())] * runs if events is None else list(events)
    if len(marks) != runs:
        raise ValueError(f"events: expected {runs} runs, got {len(marks)}")
    most = max((max(len(mm), len(st)) for mm, st in marks), default=0)
    params, state = FORCE_TRACKING.records(
        runs, segments=segment_size(ncol - 1), revolution=delay_size(int(revolution.max())),
        events=ring_size(most),
    )
    params["event_mm"] = np.inf
    params["event_step"] = NO_EVENT_STEP
    for r, (mm, st) in enumerate(marks):
        if len(mm):  # (most runs have none: 5 us a run saved)
            params["event_mm"][r, : len(mm)] = np.sort(np.asarray(mm, dtype=float))
        if len(st):
            params["event_step"][r, : len(st)] = np.sort(np.asarray(st, dtype=np.int64))
    params["decay_ratio"] = decay_ratio
    params["held_tolerance_N"] = (
        reference_force_N * np.asarray(overload_tolerance_pct, dtype=float) / 100.0
    )
    params["average_steps"] = revolution
    params["reference_force_N"] = reference_force_N
    params["band_N"] = reference_force_N * np.asarray(settling_band_pct, dtype=float) / 100.0
    params["divergence_N"] = reference_force_N * np.asarray(divergence_factor, dtype=float)
    params["plant_step_s"] = plant_step_s
    window_steps = np.asarray(oscillation_window_s, dtype=float) / plant_step_s
    params["block_steps"] = np.maximum(np.round(window_steps / WINDOW_BLOCKS), 1)
    params["entry_steps"] = WINDOW_BLOCKS * params["block_steps"] + params["average_steps"]
    params["force_limit_N"] = force_limit_N
    params["oscillation_threshold_N"] = oscillation_threshold_N
    params["last_step"] = n_steps - 1
    params["cutting"][:, :ncol] = cutting
    return params, init_states(params, state)


def metrics_result(params: NDArray, state: NDArray, segments: int) -> dict[str, NDArray]:
    """Metrics per run, each of shape (runs,), from the accumulated state records.

    Per-segment keys for ``segments`` segments; a segment a run never reached gives NaN.
    The metrics of a failed run are NaN (its ``failed`` flag is separate).  Also
    ``oscillating`` and ``limit_cycle_amplitude_N`` (:func:`judge_oscillation`, the largest
    judged amplitude), ``held_overload`` and ``held_force_ratio``, ``overload`` (the force
    exceeded the limit at some step, or a held overload) and ``overload_time_s`` (the time
    above the limit); see the module docstring.
    """
    dt = params["plant_step_s"]
    reference = params["reference_force_N"]
    cut_time = state["cut_steps"] * dt
    failed = state["failed"]
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.sqrt(state["ise_N2_s"] / cut_time)
        finish = state["finish_step"]
        out: dict[str, NDArray[np.float64]] = {
            "iae_N_s": state["iae_N_s"].copy(),
            "iae_spindle_averaged_N_s": state["iae_averaged_N_s"].copy(),
            "ise_N2_s": state["ise_N2_s"].copy(),
            "rms_error_N": rms,
            "cutting_time_s": cut_time.astype(float),
            "machining_time_s": np.where(finish >= 0, finish * dt, np.nan),
        }
        peaks = []
        for j in range(segments):
            enter = state["enter_step"][:, j]
            last_out = state["last_out_step"][:, j]
            reached = enter >= 0
            is_cut = params["cutting"][:, j]
            peak = np.where(reached & is_cut, state["peak_N"][:, j], np.nan)
            peaks.append(peak)
            settled = reached & (last_out < state["last_in_step"][:, j])
            settle = np.where(last_out < 0, 0.0, (last_out - enter + 1) * dt)
            out[f"peak_force_N_seg{j + 1}"] = peak
            out[f"entry_peak_ratio_seg{j + 1}"] = peak / reference
            out[f"overshoot_pct_seg{j + 1}"] = percent_over(peak, reference)
            out[f"settling_time_s_seg{j + 1}"] = np.where(settled & is_cut, settle, np.nan)
        stacked = np.vstack(peaks) if peaks else np.full((1, len(reference)), np.nan)
        all_nan = np.all(np.isnan(stacked), axis=0)
        peak_all = np.where(
            all_nan, np.nan, np.nanmax(np.where(np.isnan(stacked), -np.inf, stacked), axis=0)
        )
        out["peak_force_N"] = peak_all
        out["peak_force_ratio"] = peak_all / reference
        out["held_force_ratio"] = 1.0 + state["held_excess_N"] / reference
        out["max_overshoot_pct"] = percent_over(peak_all, reference)
        out["overload_time_s"] = state["overload_steps"] * dt
    out = {k: np.where(failed, np.nan, v) for k, v in out.items()}
    out["held_overload"] = state["held_overload"] & ~failed
    out["overload"] = ((state["overload_steps"] > 0) | state["held_overload"]) & ~failed
    out["oscillating"] = state["oscillating"] & ~failed
    out["limit_cycle_amplitude_N"] = np.where(failed, np.nan, state["oscillation_amplitude_N"])
    return out


def spindle_periodic(scenario: Scenario) -> bool:
    """Whether the run's force has a part periodic in a spindle revolution: the geometric
    force model (tooth passing, runout), or a ``force`` or ``feed`` sinusoid at a harmonic of
    the spindle or tooth frequency."""
    if scenario.geometry.enabled:
        return True
    return any(
        d.kind in ("force", "feed") and d.shape == "sinusoid" and d.harmonic_of != "none"
        for d in scenario.disturbances
    )


def revolution_steps(scenario: Scenario) -> int:
    """Plant steps the oscillation test averages the force error over: one spindle
    revolution, ``round(60 / (n dt))`` for ``n = geometry.spindle_speed_rpm``, where the run
    has a spindle-periodic force (:func:`spindle_periodic`); 1 (no average) otherwise, so
    the verdict never depends on the keys of a disabled section."""
    if not spindle_periodic(scenario):
        return 1
    dt = scenario.simulation.plant_step_s
    return max(int(round(60.0 / (scenario.geometry.spindle_speed_rpm * dt))), 1)


def event_marks(scenario: Scenario) -> tuple[list[float], list[int]]:
    """The run's known events: tool positions [mm] and plant steps at which a disturbance's
    window opens or closes (``start_mm > 0``, ``end_mm``, ``start_s > 0``, ``end_s``, the
    steps as the disturbance element counts them), each list ascending."""
    dt = scenario.simulation.plant_step_s
    positions: set[float] = set()
    steps: set[int] = set()
    for d in scenario.disturbances:
        if d.start_mm > 0:
            positions.add(float(d.start_mm))
        if d.end_mm is not None:
            positions.add(float(d.end_mm))
        for t in (d.start_s if d.start_s > 0 else None, d.end_s):
            if t is not None:
                steps.add(int(math.ceil(t / dt - 1e-9)))
    return sorted(positions), sorted(steps)


def excess_iae_N_s(scenarios: Sequence[Scenario], iae_N_s: NDArray) -> NDArray[np.float64]:
    """IAE above what no causal controller of the run's kind could remove [N s], shape
    (runs,): ``iae_N_s - unavoidable`` with
    :func:`acc.design.iae_bound.unavoidable_iae_N_s` (the causal bound, plus the held-force
    floor for a kind with integral action); NaN where the bound does not cover the run.

    Cost: about 10 ms per distinct plant and disturbance set, 0.2 ms per run otherwise
    (cached), hence only computed with ``[metrics] excess_iae = true``.
    """
    from acc.design.iae_bound import unavoidable_iae_N_s  # analysis of the scenario alone

    floor = np.array([unavoidable_iae_N_s(sc) for sc in scenarios], dtype=float)
    return np.asarray(iae_N_s, dtype=float) - floor


__all__ = [
    "FORCE_TRACKING",
    "constant_feed_time_s",
    "event_marks",
    "excess_iae_N_s",
    "revolution_steps",
    "spindle_periodic",
    "metrics_records",
    "metrics_result",
    "safe_feed_mm_min",
    "safe_feeds_mm_min",
]
