"""Tool-breakage detection from tooth-period averages of the feed current (or force).

Peng, seed 000, Sec. 3.5 (L975-L999), with the cited literature (spec A0-4, Sec. 6.4):

1. Tooth-period averaging synchronised to the spindle: sample ``k`` belongs to tooth period
   ``n = floor(q_k)``, where ``q = (spindle angle - entry angle) / pitch`` is the *tooth
   position* (period ``n`` starts when a tooth reaches the entry angle).  Bin edges are
   therefore sample-accurate for any, also fractional, number of samples per tooth period.
   ``I_av(n)`` is the mean of the samples in period ``n``.  The first period counts only
   if its first sample is exactly at its start; a period is closed (and decided on) at the
   first sample of the next one.
2. First difference ``dI(n) = I_av(n) - I_av(n-1)`` (3.68), normalised
   ``d'I(n) = dI(n) / ref(n)`` (3.69), with ``ref(n) = I_av(n-1)`` (Peng) or the mean of
   the ``N`` previous tooth averages, one revolution (policy
   ``"relative_to_revolution_mean"``, Tlusty & Tarng).  ``x/0`` is ``+-inf`` (``0/0 = 0``).
3. Decision once per period: ``d'I(n) > threshold`` (signed, as the thesis; optional
   ``use_absolute``).  The alarm latches; the first alarm period is reported.
4. Rule ``"first_and_second"`` (Altintas, Yellowley & Tlusty 1988): a first-difference
   exceedance at ``n`` is only a candidate.  A broken tooth makes a *pulse* in the tooth
   averages (the follower removes the missing chip, the next tooth is normal again), a
   change of cutting conditions a *step*.  The second difference
   ``d2I(n+1) = dI(n+1) - dI(n)`` confirms breakage at ``n + 1`` when it reverses by more
   than the jump, ``-sign(dI(n)) d2I(n+1) > kappa |dI(n)|``: ``kappa = 1`` for a step
   (``dI(n+1) = 0``), 1.5 for the pattern ``[1, 1, 0, 2, 1]``; default ``kappa = 1.25``.

Thresholds (the thesis compares with a "predicted run-out threshold" and gives no number):

=================================  ==========================================================
``"fixed"``                        ``threshold`` as given; :func:`predicted_runout_threshold`
                                   predicts it from the geometric force model for the cut's
                                   immersion and runout (thresholds depend strongly on the
                                   immersion, Altintas & Yellowley 1989)
``"learned"`` [ASSUMED]            ``max(threshold, k_sigma * max |d'I|)`` over the
                                   ``learn_periods`` periods after ``settle_periods``; no
                                   decision while learning
``"relative_to_revolution_mean"``  ``threshold`` on ``dI`` normalised by the revolution mean
=================================  ==========================================================

The streaming form is the compiled element ``monitor.tool_breakage`` (one sample per step);
:func:`detect_breakage` is the batch form for a recorded signal (vectorised over periods, an
independent implementation) and gives the same periods, averages, differences, thresholds
and alarm, sample for sample.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.engine.element import init_states, jit, record, register_element, ring_size

#: Threshold policies and their codes in compiled records.
THRESHOLD_POLICIES = {"fixed": 0, "learned": 1, "relative_to_revolution_mean": 2}
#: Decision rules and their codes.
RULES = {"first": 0, "first_and_second": 1}


@dataclass(frozen=True)
class ToolBreakageParams:
    """Settings of the tool-breakage detector.

    Attributes
    ----------
    teeth : int
        Number of teeth ``N`` of the cutter (>= 1).
    threshold : float
        Threshold on the normalised first difference [-] (policy ``"fixed"`` and
        ``"relative_to_revolution_mean"``); the lower bound of a learned one.
    threshold_policy : {"fixed", "learned", "relative_to_revolution_mean"}
    k_sigma : float
        Learned threshold factor [-] (3).
    learn_periods : int
        Periods of the learning window (50).
    settle_periods : int
        Periods without decision at the start (cut entry, current transient) (0).
    rule : {"first", "first_and_second"}
    confirm_ratio : float
        ``kappa`` of the second-difference confirmation [-], > 1 (1.25).
    use_absolute : bool
        Compare ``|d'I|`` instead of ``d'I`` (False: as the thesis).
    """

    teeth: int = 4
    threshold: float = 0.5
    threshold_policy: str = "fixed"
    k_sigma: float = 3.0
    learn_periods: int = 50
    settle_periods: int = 0
    rule: str = "first"
    confirm_ratio: float = 1.25
    use_absolute: bool = False

    def __post_init__(self) -> None:
        for name in ("teeth", "learn_periods", "settle_periods"):
            v = getattr(self, name)
            lo = 1 if name != "settle_periods" else 0
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"{name} must be a whole number >= {lo}, got {v!r}")
        if self.threshold_policy not in THRESHOLD_POLICIES:
            raise ValueError(
                f"threshold_policy must be one of {', '.join(THRESHOLD_POLICIES)}, "
                f"got {self.threshold_policy!r}"
            )
        if self.rule not in RULES:
            raise ValueError(f"rule must be one of {', '.join(RULES)}, got {self.rule!r}")
        if not (math.isfinite(self.threshold) and self.threshold >= 0):
            raise ValueError(f"threshold must be finite and >= 0, got {self.threshold!r}")
        if not (math.isfinite(self.k_sigma) and self.k_sigma > 0):
            raise ValueError(f"k_sigma must be > 0, got {self.k_sigma!r}")
        if not (math.isfinite(self.confirm_ratio) and self.confirm_ratio > 1):
            raise ValueError(f"confirm_ratio must be > 1, got {self.confirm_ratio!r}")

    @property
    def decision_start_period(self) -> int:
        """Index (among closed periods) of the first period with a decision."""
        learned = self.threshold_policy == "learned"
        return self.settle_periods + (self.learn_periods if learned else 0)


def tooth_positions(
    time_s: ArrayLike, spindle_speed_rpm: float, teeth: int, start_angle_rad: float = 0.0,
    entry_angle_rad: float = 0.0,
) -> NDArray[np.float64]:
    """Tooth position ``q = (phi - phi_entry) / (2 pi / N)`` at each sample [tooth periods].

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Sample times ``k dt`` [s].
    spindle_speed_rpm : float
        Spindle speed [rev/min].
    teeth : int
        ``N``.
    start_angle_rad : float
        Spindle angle of tooth 0 at ``t = 0`` [rad].
    entry_angle_rad : float
        Immersion angle where a tooth enters the cut [rad]; period ``n`` starts there.

    Returns
    -------
    ndarray, shape (n,)
        In the geometric model's numbering, period ``n`` is cut by tooth ``(-n) mod N``
        when tooth 0 is at the entry angle at ``q = 0`` (:func:`period_tooth`).
    """
    t = np.asarray(time_s, dtype=float)
    phi = start_angle_rad + 2.0 * math.pi * spindle_speed_rpm / 60.0 * t
    return (phi - entry_angle_rad) / (2.0 * math.pi / teeth)


def period_tooth(period: ArrayLike, teeth: int) -> NDArray[np.int64]:
    """Tooth that cuts in tooth period ``n``: ``(-n) mod N`` (teeth reach the entry angle in
    the order 0, N-1, ..., 1; see :mod:`plants.cutter_faults`)."""
    return np.mod(-np.asarray(period, dtype=np.int64), teeth)


def tooth_period_average_fractional(
    signal: ArrayLike, tooth_position: ArrayLike
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
    """Averages over whole tooth periods with sample-accurate (fractional) bin edges.

    Parameters
    ----------
    signal : array_like, shape (n,)
        Samples (current [A] or force [N]).
    tooth_position : array_like, shape (n,)
        Non-decreasing tooth position of each sample [tooth periods].

    Returns
    -------
    period : ndarray of int, shape (p,)
        Absolute index of each complete period (consecutive).
    average : ndarray, shape (p,)
        Mean of the samples in each period.
    closing_sample : ndarray of int, shape (p,)
        Index of the first sample of the next period (when the period is closed).

    Raises
    ------
    ValueError
        If the positions decrease or a period between the first and last has no sample.
    """
    x = np.asarray(signal, dtype=float)
    q = np.asarray(tooth_position, dtype=float)
    if x.shape != q.shape or x.ndim != 1:
        raise ValueError("signal and tooth_position must be 1-D of equal length")
    if x.size == 0:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64)
    if np.any(np.diff(q) < 0) or not np.all(np.isfinite(q)):
        raise ValueError("tooth_position must be finite and non-decreasing")
    n = np.floor(q).astype(np.int64)
    first = n[0] if q[0] == n[0] else n[0] + 1
    last = n[-1] - 1  # the period in progress at the end is never closed
    if last < first:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64)
    keep = (n >= first) & (n <= last)
    idx = n[keep] - first
    counts = np.bincount(idx, minlength=last - first + 1)
    if np.any(counts == 0):
        raise ValueError("a tooth period has no sample: sample faster than the tooth period")
    total = np.zeros(last - first + 1)
    np.add.at(total, idx, x[keep])  # unbuffered, in sample order: the streaming form's sums
    starts = np.searchsorted(n, np.arange(first + 1, last + 2), side="left")
    return np.arange(first, last + 1), total / counts, starts


def _ratio(d: NDArray[np.float64], ref: NDArray[np.float64]) -> NDArray[np.float64]:
    """``d / ref`` with ``x/0 = +-inf``, ``0/0 = 0`` and NaN where either is NaN."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = d / ref
    zero = ref == 0
    with np.errstate(invalid="ignore"):
        out = np.where(zero, np.sign(d) * np.inf, out)
    out = np.where(zero & (d == 0), 0.0, out)
    return np.where(np.isnan(d) | np.isnan(ref), np.nan, out)


@dataclass(frozen=True, eq=False)
class BreakageDetection:
    """Result of :func:`detect_breakage` (one signal).

    Attributes
    ----------
    period : ndarray of int, shape (p,)
        Absolute tooth-period index.
    closing_sample : ndarray of int, shape (p,)
        Sample at which each period is closed and decided.
    average : ndarray, shape (p,)
        Tooth averages ``I_av`` [signal unit].
    difference : ndarray, shape (p,)
        ``dI`` (NaN for the first).
    normalised_difference : ndarray, shape (p,)
        ``d'I`` [-].
    second_difference : ndarray, shape (p,)
        ``d2I = dI(n) - dI(n-1)`` [signal unit].
    threshold : ndarray, shape (p,)
        Threshold in force at each period [-] (NaN: no decision).
    alarm_period : int
        First alarm period (absolute), -1 if none.
    suspect_period : int
        Period whose average jumped (the tooth after the broken one), -1 if none.
    teeth : int
    """

    period: NDArray[np.int64]
    closing_sample: NDArray[np.int64]
    average: NDArray[np.float64]
    difference: NDArray[np.float64]
    normalised_difference: NDArray[np.float64]
    second_difference: NDArray[np.float64]
    threshold: NDArray[np.float64]
    alarm_period: int
    suspect_period: int
    teeth: int

    @property
    def alarm(self) -> bool:
        """Whether the detector alarmed."""
        return self.alarm_period >= 0

    @property
    def suspect_tooth(self) -> int:
        """Tooth (geometric-model numbering) whose period jumped, -1 if none; the broken
        tooth is the one before it, ``suspect_tooth + 1 (mod N)``."""
        return -1 if self.suspect_period < 0 else int(period_tooth(self.suspect_period,
                                                                   self.teeth))


def detect_breakage(
    signal: ArrayLike, tooth_position: ArrayLike, params: ToolBreakageParams
) -> BreakageDetection:
    """Batch tool-breakage detection on a recorded signal (see the module docstring).

    Parameters
    ----------
    signal : array_like, shape (n,)
        Current [A] or force [N] samples.
    tooth_position : array_like, shape (n,)
        Tooth position of each sample (:func:`tooth_positions`).
    params : ToolBreakageParams

    Returns
    -------
    BreakageDetection
    """
    period, avg, closing = tooth_period_average_fractional(signal, tooth_position)
    p = avg.size
    prev = np.concatenate([[np.nan], avg[:-1]])
    diff = avg - prev
    z = params.teeth
    if params.threshold_policy == "relative_to_revolution_mean":
        ref = np.full(p, np.nan)
        if p > z:
            acc = np.zeros(p - z)
            for i in range(z):  # chronological sum, as the streaming ring
                acc = acc + avg[i : p - z + i]
            ref[z:] = acc / z
    else:
        ref = prev
    norm = _ratio(diff, ref)
    stat = np.abs(norm) if params.use_absolute else norm
    j = np.arange(p)
    start = params.decision_start_period
    thr = np.where(j >= start, params.threshold, np.nan)
    if params.threshold_policy == "learned":
        window = np.abs(norm[params.settle_periods : start])
        window = window[~np.isnan(window)]
        learned = params.k_sigma * (window.max() if window.size else 0.0)
        thr = np.where(j >= start, max(params.threshold, learned), np.nan)
    with np.errstate(invalid="ignore"):
        exceed = ~np.isnan(thr) & (stat > thr)
    d2 = diff - np.concatenate([[np.nan], diff[:-1]])
    if params.rule == "first":
        hits = np.flatnonzero(exceed)
        alarm = int(period[hits[0]]) if hits.size else -1
        suspect = alarm
    else:
        dprev = np.concatenate([[np.nan], diff[:-1]])
        sign = np.where(dprev > 0, 1.0, -1.0)
        with np.errstate(invalid="ignore"):
            confirm = (-sign * d2) > params.confirm_ratio * np.abs(dprev)
        cand = np.concatenate([[False], exceed[:-1]])
        hits = np.flatnonzero(cand & confirm)
        alarm = int(period[hits[0]]) if hits.size else -1
        suspect = alarm - 1 if hits.size else -1
    return BreakageDetection(period, closing, avg, diff, norm, d2, thr, alarm, suspect, z)


# --- compiled streaming element ----------------------------------------------------------
def _dtypes(ring: int = 8) -> tuple[np.dtype, np.dtype]:
    params = record(
        "monitor.tool_breakage",
        [
            ("teeth", "i8"),
            ("threshold", "f8"),
            ("policy", "i8"),
            ("k_sigma", "f8"),
            ("settle_periods", "i8"),
            ("decision_start", "i8"),
            ("rule", "i8"),
            ("confirm_ratio", "f8"),
            ("use_absolute", "b1"),
        ],
    )
    state = record(
        "monitor.tool_breakage",
        [
            ("begun", "b1"),
            ("valid", "b1"),
            ("period", "i8"),
            ("total", "f8"),
            ("count", "i8"),
            ("closed", "i8"),
            ("previous_average", "f8"),
            ("previous_difference", "f8"),
            ("history", "f8", (ring,)),
            ("filled", "i8"),
            ("learn_max", "f8"),
            ("candidate", "b1"),
            ("alarm_period", "i8"),
            ("suspect_period", "i8"),
        ],
    )
    return params, state


@jit
def init(p, s) -> None:  # noqa: ANN001
    """Before the first sample: no period, no history, no alarm."""
    s.begun = False
    s.valid = False
    s.period = 0
    s.total = 0.0
    s.count = 0
    s.closed = 0
    s.previous_average = np.nan
    s.previous_difference = np.nan
    s.history[:] = 0.0
    s.filled = 0
    s.learn_max = 0.0
    s.candidate = False
    s.alarm_period = -1
    s.suspect_period = -1


@jit
def _ratio_at(d: float, ref: float) -> float:
    if math.isnan(d) or math.isnan(ref):
        return np.nan
    if ref != 0.0:
        return d / ref
    if d > 0.0:
        return np.inf
    if d < 0.0:
        return -np.inf
    return 0.0


@jit
def _close(p, s, period: int, average: float) -> tuple[float, float]:  # noqa: ANN001
    """Decide on a closed period; returns the normalised difference and the threshold."""
    j = s.closed
    diff = average - s.previous_average
    mask = s.history.shape[0] - 1
    if p.policy == 2:
        ref = np.nan
        if s.filled >= p.teeth:
            acc = 0.0
            for i in range(p.teeth):
                acc = acc + s.history[(s.filled - p.teeth + i) & mask]
            ref = acc / p.teeth
    else:
        ref = s.previous_average
    norm = _ratio_at(diff, ref)
    stat = abs(norm) if p.use_absolute else norm
    if p.policy == 1 and j >= p.settle_periods and j < p.decision_start and not math.isnan(norm):
        s.learn_max = max(s.learn_max, abs(norm))
    thr = np.nan
    if j >= p.decision_start:
        thr = max(p.threshold, p.k_sigma * s.learn_max) if p.policy == 1 else p.threshold
    exceed = (not math.isnan(thr)) and stat > thr
    if s.alarm_period < 0:
        if p.rule == 0:
            if exceed:
                s.alarm_period = period
                s.suspect_period = period
        else:
            dprev = s.previous_difference
            if s.candidate:
                sign = 1.0 if dprev > 0 else -1.0
                if -sign * (diff - dprev) > p.confirm_ratio * abs(dprev):
                    s.alarm_period = period
                    s.suspect_period = period - 1
            s.candidate = exceed
    s.history[s.filled & mask] = average
    s.filled += 1
    s.previous_difference = diff
    s.previous_average = average
    s.closed = j + 1
    return norm, thr


@jit
def step(p, s, value: float, tooth_position: float) -> tuple:  # noqa: ANN001
    """Take one sample and its tooth position [tooth periods].

    Returns ``(closed_period, average, normalised_difference, threshold, alarm_period)``:
    the period closed at this sample (-1 if none) with its average, ``d'I`` and threshold
    (NaN if none), and the latched first alarm period (-1 while none).
    """
    n = math.floor(tooth_position)
    closed = -1
    average = np.nan
    norm = np.nan
    thr = np.nan
    if not s.begun:
        s.begun = True
        s.period = n
        s.valid = tooth_position == n
    elif n != s.period:
        if s.valid and s.count > 0:
            closed = s.period
            average = s.total / s.count
            norm, thr = _close(p, s, s.period, average)
        if n != s.period + 1:  # a gap (or backwards): the differences start again
            s.previous_average = np.nan
            s.previous_difference = np.nan
            s.filled = 0
            s.candidate = False
        s.period = n
        s.valid = True
        s.total = 0.0
        s.count = 0
    s.total += value
    s.count += 1
    return closed, average, norm, thr, s.alarm_period


TOOL_BREAKAGE = register_element(
    "monitor.tool_breakage",
    _dtypes,
    init,
    step,
    "tool breakage from tooth-period averages, normalised first (and second) differences "
    "(Peng 3.68-3.69)",
)


def tool_breakage_records(
    params: ToolBreakageParams | Sequence[ToolBreakageParams], runs: int | None = None
) -> tuple[NDArray, NDArray]:
    """Params and initial state records of a batch of detectors.

    Parameters
    ----------
    params : ToolBreakageParams or sequence of them, length runs
    runs : int, optional
        Batch size when one parameter set is given.

    Returns
    -------
    params, state : ndarray of records, shape (runs,)
    """
    if isinstance(params, ToolBreakageParams):
        params = [params] * (1 if runs is None else int(runs))
    params = list(params)
    ring = ring_size(max(q.teeth for q in params))
    rec, state = TOOL_BREAKAGE.records(len(params), ring=ring)
    for r, q in enumerate(params):
        rec[r]["teeth"] = q.teeth
        rec[r]["threshold"] = q.threshold
        rec[r]["policy"] = THRESHOLD_POLICIES[q.threshold_policy]
        rec[r]["k_sigma"] = q.k_sigma
        rec[r]["settle_periods"] = q.settle_periods
        rec[r]["decision_start"] = q.decision_start_period
        rec[r]["rule"] = RULES[q.rule]
        rec[r]["confirm_ratio"] = q.confirm_ratio
        rec[r]["use_absolute"] = bool(q.use_absolute)
    return rec, init_states(rec, state)


@jit(python_entry=True)
def _run_signals(p, s, signal, position, out_period, out_avg, out_norm, out_thr,  # noqa: ANN001
                 out_alarm) -> None:
    for r in range(signal.shape[0]):
        for k in range(signal.shape[1]):
            c, a, d, t, al = step(p[r], s[r], signal[r, k], position[r, k])
            out_period[r, k] = c
            out_avg[r, k] = a
            out_norm[r, k] = d
            out_thr[r, k] = t
            out_alarm[r, k] = al


def stream_breakage(
    signal: ArrayLike, tooth_position: ArrayLike,
    params: ToolBreakageParams | Sequence[ToolBreakageParams],
) -> dict[str, NDArray]:
    """Run the streaming element over recorded signals of a batch (compiled loop).

    Parameters
    ----------
    signal, tooth_position : array_like, shape (runs, n) or (n,)
    params : ToolBreakageParams or sequence of them (one per run)

    Returns
    -------
    dict of ndarray, each shape (runs, n)
        ``closed_period``, ``average``, ``normalised_difference``, ``threshold``,
        ``alarm_period``: the element's outputs at every sample.
    """
    x = np.atleast_2d(np.asarray(signal, dtype=float))
    q = np.broadcast_to(np.atleast_2d(np.asarray(tooth_position, dtype=float)), x.shape)
    rec, state = tool_breakage_records(params, runs=x.shape[0])
    if rec.shape[0] != x.shape[0]:
        raise ValueError("one parameter set per run (or one for all) is needed")
    shape = x.shape
    out = {
        "closed_period": np.empty(shape, np.int64), "average": np.empty(shape),
        "normalised_difference": np.empty(shape), "threshold": np.empty(shape),
        "alarm_period": np.empty(shape, np.int64),
    }
    _run_signals(rec, state, np.ascontiguousarray(x), np.ascontiguousarray(q),
                 out["closed_period"], out["average"], out["normalised_difference"],
                 out["threshold"], out["alarm_period"])
    return out


# --- immersion-aware threshold -----------------------------------------------------------
def predicted_runout_threshold(
    tool: Any, cut: Any, coefficients: Any, runout_mm: Sequence[float], margin: float = 1.5,
    samples_per_tooth: int = 64, revolutions: int = 3,
) -> float:
    """Run-out threshold predicted from the geometric force model for a cut (immersion).

    The intact cutter with the given runout is simulated for a few revolutions (feed
    force), tooth-averaged with aligned bins, and the largest normalised first difference
    ``max d'F`` is multiplied by ``margin``: the "predicted run-out threshold" of Peng's
    L993 for that immersion.

    Parameters
    ----------
    tool : plants.end_mill_geometry.EndMill
    cut : plants.end_mill_geometry.MillingCut
    coefficients : plants.cutting_coefficients.CuttingCoefficients
    runout_mm : sequence of float, length N
        Radial runout per tooth [mm].
    margin : float
        Safety factor on the predicted maximum [-] (> 1).
    samples_per_tooth : int
        Samples per tooth period of the simulation.
    revolutions : int
        Simulated revolutions (the first is discarded).

    Returns
    -------
    float
        Threshold on the normalised first difference [-].
    """
    from plants.cutter_faults import CutterFaults, faulted_forces_vs_time
    from plants.end_mill_geometry import entry_exit_angles_rad

    st = float(entry_exit_angles_rad(tool, cut)[0])
    tooth_s = 60.0 / (cut.spindle_speed_rpm * tool.teeth)
    n = samples_per_tooth * tool.teeth * revolutions
    t = np.arange(n) * (tooth_s / samples_per_tooth)
    forces = faulted_forces_vs_time(tool, cut, coefficients, t,
                                    CutterFaults(runout_mm=tuple(runout_mm)), start_angle_rad=st)
    q = tooth_positions(t, cut.spindle_speed_rpm, tool.teeth, st, st)
    res = detect_breakage(forces.feed_N, q, ToolBreakageParams(teeth=tool.teeth))
    d = np.abs(res.normalised_difference[tool.teeth :])
    return float(margin * np.nanmax(d)) if d.size else 0.0


# --- metrics -----------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class BreakageMetrics:
    """Detection performance over a batch of runs.

    Attributes
    ----------
    detection_delay_periods : ndarray, shape (runs,)
        ``alarm - breakage`` [tooth periods] for detected breakages, NaN otherwise.
    detected : ndarray of bool, shape (runs,)
    false_alarm : ndarray of bool, shape (runs,)
        Alarm before the breakage, or in a run without breakage.
    missed : ndarray of bool, shape (runs,)
        Breakage without an alarm within the allowed delay (and no earlier alarm).
    healthy_cut_m : float
        Cut length with an intact cutter, summed over runs [m].
    false_alarms_per_m : float
        False alarms per metre of healthy cut [1/m] (NaN when nothing was cut).
    """

    detection_delay_periods: NDArray[np.float64]
    detected: NDArray[np.bool_]
    false_alarm: NDArray[np.bool_]
    missed: NDArray[np.bool_]
    healthy_cut_m: float
    false_alarms_per_m: float


def breakage_metrics(
    alarm_period: ArrayLike, breakage_period: ArrayLike, first_period: ArrayLike,
    last_period: ArrayLike, feed_per_tooth_mm: ArrayLike, max_delay_periods: int = 8,
) -> BreakageMetrics:
    """Detection delay, false alarms per metre and missed breakages.

    Parameters
    ----------
    alarm_period : array_like of int, shape (runs,)
        First alarm period, -1 if none.
    breakage_period : array_like of int, shape (runs,)
        First tooth period whose chip is missing (the broken tooth's turn), -1 if none.
    first_period, last_period : array_like of int, shape (runs,)
        First and last monitored periods.
    feed_per_tooth_mm : array_like, shape (runs,) or scalar
        Feed travel per tooth period [mm].
    max_delay_periods : int
        An alarm later than this after the breakage counts as missed.

    Returns
    -------
    BreakageMetrics
    """
    a = np.atleast_1d(np.asarray(alarm_period, dtype=np.int64))
    b = np.broadcast_to(np.asarray(breakage_period, dtype=np.int64), a.shape)
    f0 = np.broadcast_to(np.asarray(first_period, dtype=np.int64), a.shape)
    f1 = np.broadcast_to(np.asarray(last_period, dtype=np.int64), a.shape)
    c = np.broadcast_to(np.asarray(feed_per_tooth_mm, dtype=float), a.shape)
    broke = b >= 0
    alarmed = a >= 0
    false_alarm = alarmed & (~broke | (a < b))
    delay = (a - b).astype(float)
    detected = broke & alarmed & (a >= b) & (delay <= max_delay_periods)
    missed = broke & ~detected & ~false_alarm
    healthy_end = np.where(broke, np.minimum(b, f1 + 1), f1 + 1)
    healthy_end = np.where(false_alarm, np.minimum(healthy_end, a + 1), healthy_end)
    length_m = float(np.sum(np.maximum(healthy_end - f0, 0) * c) / 1000.0)
    rate = float(np.sum(false_alarm) / length_m) if length_m > 0 else math.nan
    return BreakageMetrics(
        np.where(detected, delay, np.nan), detected, false_alarm, missed, length_m, rate
    )


# --- plot --------------------------------------------------------------------------------
def plot_tool_breakage(
    ax: Any, detection: BreakageDetection, *, signal_label: str = "tooth-average current [A]",
    breakage_period: int | None = None,
) -> Any:
    """Tooth averages, normalised differences, threshold and alarm onto a given Axes
    (Peng Figs 3.22/3.23 in one panel).

    The normalised difference and the threshold go on ``ax`` (left axis); the tooth averages
    on a twin right axis.  Returns the twin Axes.
    """
    n = detection.period
    ax.step(n, detection.normalised_difference, where="mid", color="C0",
            label="normalised first difference")
    ax.plot(n, detection.threshold, "--", color="C3", label="threshold")
    if detection.alarm:
        ax.axvline(detection.alarm_period, color="C3", lw=1.5,
                   label=f"alarm (period {detection.alarm_period}; jump on tooth "
                         f"{detection.suspect_tooth})")
    if breakage_period is not None and breakage_period >= 0:
        ax.axvline(breakage_period, color="k", ls=":", label="breakage")
    ax.set_xlabel("tooth period")
    ax.set_ylabel("normalised first difference [-]")
    twin = ax.twinx()
    twin.step(n, detection.average, where="mid", color="C2", alpha=0.6)
    twin.set_ylabel(signal_label, color="C2")
    ax.legend(loc="upper left", fontsize="small")
    return twin


__all__ = [
    "RULES",
    "THRESHOLD_POLICIES",
    "TOOL_BREAKAGE",
    "BreakageDetection",
    "BreakageMetrics",
    "ToolBreakageParams",
    "breakage_metrics",
    "detect_breakage",
    "period_tooth",
    "plot_tool_breakage",
    "predicted_runout_threshold",
    "stream_breakage",
    "tool_breakage_records",
    "tooth_period_average_fractional",
    "tooth_positions",
]
