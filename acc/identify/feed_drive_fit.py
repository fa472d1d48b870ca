"""The feed drive from its measured input and velocity: Eq. (6), or a rate-limited planner.

Two models compete (Kim & Chung Sec. 3.1 fit the first; some CNCs show the second):

``lag``
    ``v/u = K a e^{-L s} / (s + a)`` (Eq. 6 with a DC gain ``K``, 1 when the command is
    logged in mm/min).  Simulated exactly for a command held over each log step (zero-order
    hold) with a fractional dead time ``L = (N + f) h``, ``0 <= f < 1``:
    ``v[k+1] = phi v[k] + K (b1 u[k-N] + b2 u[k-N-1])``, ``phi = exp(-a h)``,
    ``b1 = 1 - exp(-a (h - f h))``, ``b2 = exp(-a (h - f h)) - phi`` (the modified
    z-transform), so ``L`` is continuous and the fit can place it between samples.
``rate_limited``
    A planner that moves the velocity towards the delayed command at most by its
    acceleration limit ``A`` per unit time (LinuxCNC's trajectory planner: a new feed is
    reached as a ramp, about one servo cycle late):
    ``v[k+1] = v[k] + clip(K u[k-N] - v[k], -A h, A h)``.

Fit.  The dead time is searched over whole samples first: for a grid of bandwidths the
model is simulated once without delay and its misfit for every delay comes from one FFT
cross-correlation (a delayed response of a shift-invariant model is the undelayed one
shifted, the past held at the initial velocity).  The best whole-sample delay and its
neighbours are then fitted by output error (:mod:`acc.identify.output_error`), and finally
``a``, ``L`` and ``K`` together (each record starting at rest at its first measured
velocity), with sandwich intervals and the dead time's from its profile.
The planner is fitted the same way over a grid of accelerations.  The model with the
smaller residual wins when it is smaller by more than :data:`MODEL_MARGIN`; otherwise the
lag, the workbench's own model, is kept.  Both residuals and the noise floor are reported.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import fft as sp_fft
from scipy import optimize, signal

from acc.engine.element import jit
from acc.identify.checks import (
    IdentificationError,
    check_length,
    check_response_resolved,
    relative_half_width,
)
from acc.identify.measurement import Record
from acc.identify.output_error import (
    LeastSquaresFit,
    central_jacobian,
    fit_output_error,
    hac_covariance,
    hac_lags,
    one_blas_thread,
)

#: A competing model must cut the residual RMS below this fraction of the lag's to win [-].
MODEL_MARGIN = 0.9
#: Bandwidths of the whole-sample delay search [-] (times 1/h: ``a h`` from 1e-3 to 20).
_SCAN_POINTS = 28
#: Default largest dead time searched [s].
MAX_DEAD_TIME_S = 1.0
FEED_DRIVE_MODELS = ("auto", "lag", "rate_limited")


def lag_coefficients(
    bandwidth_rad_s: float, dead_time_s: float, sample_time_s: float
) -> tuple[int, float, float, float]:
    """``N, phi, b1, b2`` of the exact sampled lag with a fractional dead time (docstring).

    Parameters
    ----------
    bandwidth_rad_s : float
        ``a`` [rad/s], > 0.
    dead_time_s : float
        ``L`` [s], >= 0.
    sample_time_s : float
        ``h`` [s].

    Returns
    -------
    N : int
        Whole samples of the delay.
    phi, b1, b2 : float
        Pole and the two input weights (``b1 + b2 = 1 - phi``).
    """
    h = sample_time_s
    d = max(dead_time_s / h, 0.0)
    n = int(np.floor(d + 1e-12))
    frac = min(max(d - n, 0.0), 1.0)
    a = bandwidth_rad_s
    phi = float(np.exp(-a * h))
    rest = float(np.exp(-a * h * (1.0 - frac)))
    return n, phi, float(-np.expm1(-a * h * (1.0 - frac))), rest - phi


def lag_response(
    drive_input_mm_min: ArrayLike,
    sample_time_s: float,
    bandwidth_rad_s: float,
    dead_time_s: float,
    dc_gain: float = 1.0,
    initial_velocity_mm_min: float | None = None,
) -> NDArray[np.float64]:
    """Velocity of the lag model for a command held over each step [mm/min].

    The past before the record is at rest at the initial velocity (the command before it was
    ``v0 / K``).

    Parameters
    ----------
    drive_input_mm_min : array_like, shape (n,)
        Command ``u[k]`` held over ``[t_k, t_k+1)`` [mm/min].
    sample_time_s : float
    bandwidth_rad_s, dead_time_s, dc_gain : float
        ``a`` [rad/s], ``L`` [s], ``K`` [-].
    initial_velocity_mm_min : float, optional
        ``v[0]`` [mm/min]; default ``K u[0]``.

    Returns
    -------
    ndarray, shape (n,)
        ``v[k]`` at the sample times [mm/min].
    """
    u = np.asarray(drive_input_mm_min, dtype=float)
    v0 = dc_gain * u[0] if initial_velocity_mm_min is None else float(initial_velocity_mm_min)
    n_delay, phi, b1, b2 = lag_coefficients(bandwidth_rad_s, dead_time_s, sample_time_s)
    u_pre = v0 / dc_gain
    # w[k] = u[k - N - 1]; v[k] = phi v[k-1] + K (b1 w[k] + b2 w[k-1]), v[0] = v0
    n = len(u)
    w = np.empty(n)
    head = min(n_delay + 1, n)
    w[:head] = u_pre
    w[head:] = u[: n - head]
    b = [dc_gain * b1, dc_gain * b2]
    out = np.empty(n)
    out[0] = v0
    # transposed direct form: the state before w[1] is b2 K w[0] + phi v0
    out[1:] = signal.lfilter(b, [1.0, -phi], w[1:], zi=[b[1] * w[0] + phi * v0])[0]
    return out


def sampled_lag_frequency_response(
    frequency_hz: ArrayLike,
    sample_time_s: float,
    bandwidth_rad_s: float,
    dead_time_s: float,
    dc_gain: float = 1.0,
) -> NDArray[np.complex128]:
    """Frequency response of the sampled lag (what a log of a held command measures).

    ``H(z) = K (b1 + b2 z^-1) z^-(N+1) / (1 - phi z^-1)`` at ``z = exp(j 2 pi f h)``.

    Parameters
    ----------
    frequency_hz : array_like, shape (m,)
    sample_time_s, bandwidth_rad_s, dead_time_s, dc_gain : float

    Returns
    -------
    ndarray, shape (m,)
    """
    f = np.asarray(frequency_hz, dtype=float)
    n_delay, phi, b1, b2 = lag_coefficients(bandwidth_rad_s, dead_time_s, sample_time_s)
    zi = np.exp(-2j * np.pi * f * sample_time_s)
    return dc_gain * (b1 + b2 * zi) * zi ** (n_delay + 1) / (1.0 - phi * zi)


@jit(python_entry=True)
def _rate_limited(target: np.ndarray, step_limit: float, v0: float) -> np.ndarray:
    """``v[k+1] = v[k] + clip(target[k] - v[k], -s, s)``, ``v[0] = v0``."""
    n = target.shape[0]
    out = np.empty(n)
    v = v0
    for k in range(n):
        out[k] = v
        d = target[k] - v
        if d > step_limit:
            d = step_limit
        elif d < -step_limit:
            d = -step_limit
        v += d
    return out


def rate_limited_response(
    drive_input_mm_min: ArrayLike,
    sample_time_s: float,
    acceleration_mm_min_s: float,
    delay_s: float,
    dc_gain: float = 1.0,
    initial_velocity_mm_min: float | None = None,
) -> NDArray[np.float64]:
    """Velocity of the rate-limited planner (module docstring) [mm/min].

    Parameters
    ----------
    drive_input_mm_min : array_like, shape (n,)
    sample_time_s : float
    acceleration_mm_min_s : float
        Acceleration limit ``A`` [mm/min per s] (1 mm/s^2 is 60 mm/min/s).
    delay_s : float
        Delay, rounded to whole samples [s].
    dc_gain : float
    initial_velocity_mm_min : float, optional

    Returns
    -------
    ndarray, shape (n,)
    """
    u = np.asarray(drive_input_mm_min, dtype=float)
    v0 = dc_gain * u[0] if initial_velocity_mm_min is None else float(initial_velocity_mm_min)
    n_delay = int(round(max(delay_s, 0.0) / sample_time_s))
    target = dc_gain * np.concatenate([np.full(min(n_delay, len(u)), v0 / dc_gain), u])[: len(u)]
    return _rate_limited(target, acceleration_mm_min_s * sample_time_s, v0)


@dataclass(frozen=True)
class FeedDriveFit:
    """The identified feed drive.

    Attributes
    ----------
    model : {"lag", "rate_limited"}
        The model the data support better (module docstring); ``reason`` says why.
    bandwidth_rad_s : float
        ``a`` of the lag model [rad/s] (fitted whichever model won: it is what a scenario's
        ``[feed_drive]`` can hold).
    bandwidth_interval_rad_s : tuple of float
        Its interval at ``confidence`` [rad/s].
    dead_time_s : float
        ``L`` of the lag model [s].
    dead_time_interval_s : tuple of float
    dc_gain : float
        ``K`` [-] (1 when the command is the logged feed; the programmed feed otherwise).
    dc_gain_interval : tuple of float
    lag_rms_mm_min : float
        Residual RMS of the lag model [mm/min].
    acceleration_mm_min_s : float
        Acceleration limit ``A`` of the planner model [mm/min/s] (NaN if not fitted).
    acceleration_interval_mm_min_s : tuple of float
    planner_delay_s : float
        Whole-sample delay of the planner model [s] (NaN if not fitted).
    planner_rms_mm_min : float
        Residual RMS of the planner model [mm/min] (NaN if not fitted).
    noise_rms_mm_min : float
        Velocity noise floor from second differences of the measurement [mm/min].
    sample_time_s : float
        Log step ``h`` [s].
    n_samples : int
        Samples fitted (all records).
    duration_s : float
        Length of the records fitted [s].
    reason : str
        Why ``model`` was chosen, with the numbers.
    warnings : tuple of str
    confidence : float
        Level of the intervals [-].
    initial_velocity_mm_min : tuple of float
        ``v[0]`` per record (the mean of its first three samples) [mm/min].
    covariance_a_L : tuple of tuple of float
        2 x 2 covariance of ``(a, L)`` [rad^2/s^2, rad, s^2]: the dead time's variance from
        its profile interval, the correlation from the sandwich (for propagating the drive's
        uncertainty into the cutting fits).
    velocity_delay_s : float
        The velocity measurement's own delay [s] (e.g. half the servo period for a backward
        difference of positions), subtracted from the fitted dead time: ``dead_time_s`` is
        the drive's, the measured velocity lags it by this much more.
    """

    model: str
    bandwidth_rad_s: float
    bandwidth_interval_rad_s: tuple[float, float]
    dead_time_s: float
    dead_time_interval_s: tuple[float, float]
    dc_gain: float
    dc_gain_interval: tuple[float, float]
    lag_rms_mm_min: float
    acceleration_mm_min_s: float
    acceleration_interval_mm_min_s: tuple[float, float]
    planner_delay_s: float
    planner_rms_mm_min: float
    noise_rms_mm_min: float
    sample_time_s: float
    n_samples: int
    duration_s: float
    reason: str
    warnings: tuple[str, ...]
    confidence: float
    initial_velocity_mm_min: tuple[float, ...]
    covariance_a_L: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (0.0, 0.0))
    velocity_delay_s: float = 0.0

    @property
    def time_constant_s(self) -> float:
        """``1/a`` [s]."""
        return 1.0 / self.bandwidth_rad_s

    @property
    def measured_dead_time_s(self) -> float:
        """Dead time from the command to the *measured* velocity, ``L`` plus the velocity
        measurement's delay [s] (what a measured FRF shows)."""
        return self.dead_time_s + self.velocity_delay_s

    def dead_time_for_step_s(self, plant_step_s: float) -> float:
        """``L`` rounded to whole plant steps (what a scenario's ``[feed_drive]`` holds) [s]."""
        return round(self.dead_time_s / plant_step_s) * plant_step_s

    def rational_part(self) -> Any:
        """``K a / (s + a)`` as a python-control transfer function (no delay)."""
        import control

        a = self.bandwidth_rad_s
        return control.tf([self.dc_gain * a], [1.0, a])

    def transfer_function(self, pade_order: int = 5) -> Any:
        """``K a e^{-L s} / (s + a)`` with the delay as a Padé approximant of ``pade_order``.

        The Padé approximant is for analysis only; :meth:`frequency_response` and
        :meth:`frd` carry the exact delay.

        Returns
        -------
        control.TransferFunction
        """
        import control

        num, den = control.pade(self.dead_time_s, pade_order)
        return self.rational_part() * control.tf(num, den)

    def frequency_response(self, omega_rad_s: ArrayLike) -> NDArray[np.complex128]:
        """``K a e^{-j w L} / (j w + a)`` with the exact delay, shape of ``omega_rad_s``."""
        s = 1j * np.asarray(omega_rad_s, dtype=float)
        a = self.bandwidth_rad_s
        return self.dc_gain * a * np.exp(-self.dead_time_s * s) / (s + a)

    def frd(self, omega_rad_s: ArrayLike) -> Any:
        """The lag model with its exact delay as a python-control FRD."""
        import control

        w = np.asarray(omega_rad_s, dtype=float)
        return control.frd(self.frequency_response(w), w)

    def simulate(
        self, record: Record, model: str | None = None, index: int | None = None,
        bandwidth_rad_s: float | None = None, dead_time_s: float | None = None,
        as_measured: bool = False,
    ) -> NDArray:
        """The chosen (or named) model's velocity for a record's input [mm/min], shape (n,).

        ``index`` selects the record's fitted initial velocity (records in fit order; None:
        at rest at ``K u[0]``); ``bandwidth_rad_s`` and ``dead_time_s`` replace the lag's
        (to propagate their uncertainty); ``as_measured`` adds the velocity measurement's
        delay (to compare with the measured velocity).
        """
        extra = self.velocity_delay_s if as_measured else 0.0
        which = model or self.model
        v0 = (self.initial_velocity_mm_min[index]
              if index is not None and index < len(self.initial_velocity_mm_min) else None)
        if which == "rate_limited":
            return rate_limited_response(
                record.drive_input_mm_min, record.sample_time_s, self.acceleration_mm_min_s,
                max(self.planner_delay_s - self.velocity_delay_s + extra, 0.0), self.dc_gain,
                v0,
            )
        ell = self.dead_time_s if dead_time_s is None else dead_time_s
        return lag_response(
            record.drive_input_mm_min, record.sample_time_s,
            self.bandwidth_rad_s if bandwidth_rad_s is None else bandwidth_rad_s,
            max(ell + extra, 0.0), self.dc_gain, v0,
        )


def _velocity(record: Record) -> NDArray[np.float64]:
    """The record's feed velocity [mm/min], shape (n,): the fits below take only records
    :func:`_velocity_records` kept, which have one."""
    assert record.feed_velocity_mm_min is not None
    return record.feed_velocity_mm_min


def _velocity_records(records: Sequence[Record]) -> list[Record]:
    usable = [r for r in records if r.feed_velocity_mm_min is not None]
    if not usable:
        raise IdentificationError(
            "no record has a feed_velocity_mm_min column: the feed drive cannot be identified"
        )
    for r in usable:
        check_length(r.n_samples, r.duration_s, r.source)
    if not any(np.ptp(r.drive_input_mm_min) > 0 for r in usable):
        raise IdentificationError(
            f"{usable[0].source}: the drive input never changes: nothing excites the feed drive "
            "(play an acc excite schedule)"
        )
    return usable


def noise_floor(x: NDArray) -> float:
    """White-noise RMS of a smooth signal from its second differences, ``rms / sqrt 6``
    (the largest 5 % of them, where the signal itself jumps, left out)."""
    d2 = np.diff(np.asarray(x, dtype=float), 2)
    if len(d2) == 0:
        return 0.0
    kept = np.sort(np.abs(d2))[: max(1, int(0.95 * len(d2)))]
    return float(np.sqrt(np.mean(kept**2) / 6.0))


def _fft_size(n: int, max_shift: int) -> int:
    """FFT length for lags 0..max_shift of a length-n correlation without wrap-around."""
    return sp_fft.next_fast_len(n + max_shift + 1, real=True)


def _shift_misfit(
    e_spectrum: NDArray, z: NDArray, max_shift: int
) -> tuple[NDArray, NDArray]:
    """``c[N] = sum_k e[k] z[k-N]`` and ``s[N] = sum_k z[k-N]^2`` for N = 0..max_shift, with
    ``e_spectrum = rfft(e, _fft_size(n, max_shift))``."""
    n = len(z)
    size = _fft_size(n, max_shift)
    c = sp_fft.irfft(e_spectrum * np.conj(sp_fft.rfft(z, size)), size)[: max_shift + 1]
    tail = np.cumsum(z**2)
    s = tail[n - 1 - np.arange(max_shift + 1)]
    return c, s


def _scan_lag(
    recs: Sequence[Record], gain_guess: float, max_dead_time_s: float
) -> tuple[float, float]:
    """Best ``(a, L)`` on a grid of bandwidths and whole-sample delays (module docstring)."""
    h = min(r.sample_time_s for r in recs)
    grid_a = np.geomspace(1e-3 / h, 20.0 / h, _SCAN_POINTS)
    candidates = np.arange(int(max_dead_time_s / h) + 1) * h
    best = (np.inf, grid_a[0], 0.0)
    shifts = [min(int(max_dead_time_s / r.sample_time_s) + 1, r.n_samples - 2) for r in recs]
    spectra = [sp_fft.rfft(_velocity(r) - _velocity(r)[0],
                           _fft_size(r.n_samples, m)) for r, m in zip(recs, shifts, strict=True)]
    for a in grid_a:
        c_tot = np.zeros(len(candidates))
        s_tot = np.zeros(len(candidates))
        e_tot = 0.0
        for i, (r, max_shift) in enumerate(zip(recs, shifts, strict=True)):
            v = _velocity(r)
            hr = r.sample_time_s
            phi = np.exp(-a * hr)
            u_pre = v[0] / gain_guess
            z = signal.lfilter([0.0, 1.0 - phi], [1.0, -phi], r.drive_input_mm_min - u_pre)
            e = v - v[0]
            c, s = _shift_misfit(spectra[i], z, max_shift)
            idx = np.minimum(np.round(candidates / hr).astype(int), max_shift)
            c_tot += c[idx]
            s_tot += s[idx]
            e_tot += float(e @ e)
        j_cost = e_tot - np.where((c_tot > 0) & (s_tot > 0), c_tot**2 / np.maximum(s_tot, 1e-300),
                                  0.0)
        i = int(np.argmin(j_cost))
        if j_cost[i] < best[0]:
            best = (float(j_cost[i]), float(a), float(candidates[i]))
    return best[1], best[2]


def _stack(recs: Sequence[Record]) -> tuple[NDArray, list[tuple[int, int]]]:
    ys = [_velocity(r) for r in recs]
    bounds, start = [], 0
    for y in ys:
        bounds.append((start, start + len(y)))
        start += len(y)
    return np.concatenate(ys), bounds


def _lag_model(recs: Sequence[Record], a: float, ell: float, k: float,
               v0s: Sequence[float]) -> NDArray:
    """The lag model's velocity of every record, stacked [mm/min]."""
    return np.concatenate([
        lag_response(r.drive_input_mm_min, r.sample_time_s, a, ell, k, v0s[i])
        for i, r in enumerate(recs)
    ])


def _fit_lag(
    recs: Sequence[Record], a0: float, dead_time_s: float | None, k0: float,
    v0s: Sequence[float], confidence: float, dead_time_bounds: tuple[float, float] | None,
) -> LeastSquaresFit:
    """Output-error fit of ``a, [L], K`` (L fixed when ``dead_time_s`` is given), each
    record starting at rest at its initial velocity ``v0s``."""
    measured, segments = _stack(recs)
    h = min(r.sample_time_s for r in recs)
    free_l = dead_time_s is None

    def model(theta: NDArray) -> NDArray:
        if dead_time_s is None:
            return _lag_model(recs, theta[0], theta[1], theta[2], v0s)
        return _lag_model(recs, theta[0], dead_time_s, theta[1], v0s)

    names = ["bandwidth_rad_s"] + (["dead_time_s"] if free_l else []) + ["dc_gain"]
    lo_l, hi_l = dead_time_bounds or (0.0, np.inf)
    start = [a0] + ([0.5 * (lo_l + hi_l)] if free_l else []) + [k0]
    lower = [1e-4 / h] + ([lo_l] if free_l else []) + [1e-3 * abs(k0)]
    upper = [50.0 / h] + ([hi_l] if free_l else []) + [1e3 * abs(k0)]
    scale = [a0] + ([h] if free_l else []) + [abs(k0)]
    return fit_output_error(model, measured, start, names, lower, upper, scale, confidence,
                            segments)


class _DeadTimeProfile:
    """Residual sum of squares over the dead time, the other parameters re-fitted.

    A sampled model's misfit has a kink wherever the dead time is a whole number of
    samples (the held command's edges move from one sample to the next), so its curvature
    at the estimate says little about how far the dead time may go; the profile does.  At
    each dead time the other parameters take two Gauss-Newton steps from the estimate's.
    The interval is where the profile stays within ``z^2 s^2 c`` of its minimum, with ``c``
    the colour factor of the dead time's sandwich variance
    (:meth:`LeastSquaresFit.colour_factor`).
    """

    def __init__(self, recs: Sequence[Record], fit: LeastSquaresFit,
                 v0s: Sequence[float]) -> None:
        self.recs = recs
        self.v0s = v0s
        self.measured = _stack(recs)[0]
        self.fit = fit
        self.nuisance = np.delete(fit.values, 1)
        self.rss_hat = float(np.sum(fit.residual**2))
        self.threshold = fit.z**2 * fit.variance_per_dof * max(fit.colour_factor("dead_time_s"),
                                                               1.0)
        self.sample_time_s = min(r.sample_time_s for r in recs)

    def _model(self, ell: float, nu: NDArray) -> NDArray:
        return _lag_model(self.recs, nu[0], ell, nu[1], self.v0s)

    def rss(self, ell: float) -> float:
        """Profile residual sum of squares at dead time ``ell`` [s]."""
        nu = self.nuisance.copy()
        scale = np.abs(nu) * 1e-6 + 1e-9
        best = np.inf
        for _ in range(2):
            base = self._model(ell, nu)
            r = self.measured - base
            best = min(best, float(r @ r))
            jac = np.column_stack([
                (self._model(ell, nu + np.eye(len(nu))[i] * scale[i]) - base) / scale[i]
                for i in range(len(nu))
            ])
            trial = nu + np.linalg.solve(jac.T @ jac, jac.T @ r)
            if not (trial[0] > 0 and trial[1] > 0):
                break
            nu = trial
        r = self.measured - self._model(ell, nu)
        return min(best, float(r @ r))

    def lower_point(self) -> float | None:
        """A dead time within a sample and a half whose profile is below the estimate's
        (the solver stopped at a kink's local minimum), or None."""
        h = self.sample_time_s
        ell_hat = self.fit.value("dead_time_s")
        grid = [x for x in ell_hat + h * np.arange(-3, 4) / 2.0 if x >= 0]
        values = [self.rss(x) for x in grid]
        i = int(np.argmin(values))
        return grid[i] if values[i] < self.rss_hat - 1e-3 * self.threshold else None

    def interval(self) -> tuple[float, float, bool]:
        """``(low, high, open)``: the interval, and whether a side hit the search's end
        (20 samples, or 0)."""
        h = self.sample_time_s
        ell_hat = self.fit.value("dead_time_s")
        sigma = max(float(self.fit.std[1]), h / 100.0)

        def excess(x: float) -> float:
            return self.rss(x) - self.rss_hat - self.threshold

        ends, open_end = [], False
        for sign in (-1.0, 1.0):
            inner, step = ell_hat, sigma
            while True:
                outer = ell_hat + sign * step
                if outer < 0:
                    outer = 0.0
                if excess(outer) > 0:
                    ends.append(optimize.brentq(excess, min(inner, outer), max(inner, outer),
                                                xtol=1e-2 * sigma))
                    break
                if outer == 0.0 or step > 20 * h:
                    ends.append(outer)
                    open_end = open_end or outer != 0.0
                    break
                inner, step = outer, 2.0 * step
        return ends[0], ends[1], open_end


def _fit_planner(
    recs: Sequence[Record], gain: float, v0s: Sequence[float], max_dead_time_s: float,
    confidence: float,
) -> tuple[float, tuple[float, float], float, float]:
    """Acceleration limit (with interval), delay and residual RMS of the planner model."""
    measured, segments = _stack(recs)
    h = min(r.sample_time_s for r in recs)
    steps = np.concatenate([np.abs(np.diff(r.drive_input_mm_min)) for r in recs])
    fastest = gain * max(float(steps.max()), 1e-9) / h
    grid = np.geomspace(fastest * 1e-4, fastest * 2.0, 40)
    max_shift = int(max_dead_time_s / h) + 1

    errors = [_velocity(r) - v0s[i] for i, r in enumerate(recs)]
    spectra = [sp_fft.rfft(e, _fft_size(len(e), min(max_shift, len(e) - 2))) for e in errors]

    def misfit_all(acc: float) -> NDArray:
        total = np.zeros(max_shift + 1)
        for i, r in enumerate(recs):
            ms = min(max_shift, r.n_samples - 2)
            y0 = rate_limited_response(r.drive_input_mm_min, r.sample_time_s, acc, 0.0, gain,
                                       v0s[i])
            e, z = errors[i], y0 - v0s[i]
            c, s = _shift_misfit(spectra[i], z, ms)
            j = float(e @ e) - 2.0 * c + s
            total[: ms + 1] += j
            total[ms + 1:] += j[-1]
        return total

    costs = np.array([misfit_all(acc) for acc in grid])
    ia, n_best = np.unravel_index(int(np.argmin(costs)), costs.shape)

    def model(log_acc: float, n_delay: int) -> NDArray:
        return np.concatenate([
            rate_limited_response(r.drive_input_mm_min, r.sample_time_s, float(np.exp(log_acc)),
                                  n_delay * h, gain, v0s[i]) for i, r in enumerate(recs)
        ])

    best = (np.inf, 0.0, int(n_best))
    lo = np.log(grid[max(ia - 1, 0)])
    hi = np.log(grid[min(ia + 1, len(grid) - 1)])
    for n_delay in {max(int(n_best) - 1, 0), int(n_best), int(n_best) + 1}:
        res = optimize.minimize_scalar(
            lambda x, nd=n_delay: float(np.sum((measured - model(x, nd)) ** 2)),
            bounds=(lo, hi), method="bounded", options={"xatol": 1e-4},
        )
        if res.fun < best[0]:
            best = (float(res.fun), float(res.x), n_delay)
    _, log_acc, n_delay = best
    residual = measured - model(log_acc, n_delay)
    jac = central_jacobian(lambda th: model(th[0], n_delay), np.array([log_acc]),
                           np.array([1e-4]))
    cov = hac_covariance(jac, residual, hac_lags(residual, segments), segments)
    from scipy import stats

    z = float(stats.norm.ppf(0.5 + 0.5 * confidence))
    sd = float(np.sqrt(max(cov[0, 0], 0.0)))
    acc = float(np.exp(log_acc))
    interval = (float(np.exp(log_acc - z * sd)), float(np.exp(log_acc + z * sd)))
    return acc, interval, n_delay * h, float(np.sqrt(np.mean(residual**2)))


def fit_feed_drive(
    records: Sequence[Record],
    *,
    model: str = "auto",
    confidence: float = 0.95,
    max_dead_time_s: float = MAX_DEAD_TIME_S,
    velocity_delay_s: float = 0.0,
) -> FeedDriveFit:
    """Identify the feed drive from records with a measured velocity.

    Parameters
    ----------
    records : sequence of Record
        Records with ``feed_velocity_mm_min`` (others are skipped); fitted together (shared
        ``a``, ``L``, ``K``; each record at rest at its first measured velocity before it
        starts).
    model : {"auto", "lag", "rate_limited"}
        ``"auto"`` fits both and keeps the better (module docstring); the others force one
        (the lag is always fitted: a scenario's ``[feed_drive]`` holds it).
    confidence : float
        Level of the intervals [-].
    max_dead_time_s : float
        Largest dead time searched [s].
    velocity_delay_s : float
        The velocity measurement's own delay [s], >= 0 (half the servo period for velocity
        from a backward difference of positions); subtracted from the fitted dead time.

    Returns
    -------
    FeedDriveFit

    Raises
    ------
    IdentificationError
        No velocity, no excitation, a record too short for the fitted response.
    """
    with one_blas_thread():
        return _fit_feed_drive(records, model, confidence, max_dead_time_s, velocity_delay_s)


def _fit_feed_drive(
    records: Sequence[Record], model: str, confidence: float, max_dead_time_s: float,
    velocity_delay_s: float,
) -> FeedDriveFit:
    if model not in FEED_DRIVE_MODELS:
        raise IdentificationError(
            f"feed-drive model must be one of {', '.join(FEED_DRIVE_MODELS)}, got {model!r}"
        )
    recs = _velocity_records(records)
    h = min(r.sample_time_s for r in recs)
    duration = sum(r.duration_s for r in recs)
    max_dead = min(max_dead_time_s, 0.5 * max(r.duration_s for r in recs))
    u_all = np.concatenate([r.drive_input_mm_min for r in recs])
    v_all = np.concatenate([_velocity(r) for r in recs])
    gain_guess = float(np.mean(v_all) / np.mean(u_all)) if np.mean(u_all) != 0 else 1.0
    if not np.isfinite(gain_guess) or gain_guess <= 0:
        gain_guess = 1.0
    a0, l0 = _scan_lag(recs, gain_guess, max_dead)
    # each record starts at rest at its initial velocity (the mean of its first samples)
    v0s = [float(np.mean(_velocity(r)[:3])) for r in recs]
    # whole-sample neighbours of the scanned delay, then the fractional refinement
    best: tuple[float, LeastSquaresFit | None, float] = (np.inf, None, l0)
    for ell in (l0 - h, l0, l0 + h):
        if ell < 0:
            continue
        trial = _fit_lag(recs, a0, ell, gain_guess, v0s, confidence, None)
        if trial.rms < best[0]:
            best = (trial.rms, trial, ell)
    _, fixed, l_best = best
    assert fixed is not None  # l0 >= 0 (a scanned delay): l0 and l0 + h were both fitted
    a1, k1 = fixed.values[0], fixed.values[1]
    fit = None
    lo_l, hi_l = max(l_best - h, 0.0), l_best + h
    for _ in range(3):
        fit = _fit_lag(recs, a1, None, k1, v0s, confidence, (lo_l, hi_l))
        ell = fit.value("dead_time_s")
        at_edge = (ell - lo_l < 1e-3 * h and lo_l > 0) or hi_l - ell < 1e-3 * h
        if not at_edge:
            break
        lo_l, hi_l = max(ell - h, 0.0), ell + h
        a1, k1 = fit.values[0], fit.values[2]
    assert fit is not None
    profile = _DeadTimeProfile(recs, fit, v0s)
    better = profile.lower_point()
    if better is not None:
        # the solver stopped at a kink's local minimum: start again from the profile's best
        fit = _fit_lag(recs, fit.values[0], None, fit.values[2], v0s, confidence,
                       (max(better - h / 4.0, 0.0), better + h / 4.0))
        profile = _DeadTimeProfile(recs, fit, v0s)
    lo_ci, hi_ci, open_end = profile.interval()
    a, ell, k = fit.value("bandwidth_rad_s"), fit.value("dead_time_s"), fit.value("dc_gain")
    warnings: list[str] = []
    check_response_resolved(min(r.duration_s for r in recs), ell + 1.0 / a, "feed drive",
                            recs[0].source)
    ia, ik = fit.interval("bandwidth_rad_s"), fit.interval("dc_gain")
    il = (min(lo_ci, ell), max(hi_ci, ell))
    if open_end:
        warnings.append(
            f"the dead time's interval reaches the end of its profile ({il[0]:.4g}..{il[1]:.4g} "
            "s): the dead time is poorly determined"
        )
    for name, value, interval, unit in (("bandwidth a", a, ia, "rad/s"),
                                        ("dc gain K", k, ik, "")):
        if relative_half_width(value, interval) > 1.0:
            raise IdentificationError(
                f"{recs[0].source}: the feed drive's {name} is not identified "
                f"({value:.4g} {unit}, interval {interval[0]:.3g}..{interval[1]:.3g}): excite "
                "the drive more (larger amplitude, higher frequencies) or log longer"
            )
    if velocity_delay_s > 0:
        ell = ell - velocity_delay_s
        il = (il[0] - velocity_delay_s, il[1] - velocity_delay_s)
        if ell < 0:
            raise IdentificationError(
                f"{recs[0].source}: the fitted dead time {ell + velocity_delay_s:.4g} s is "
                f"shorter than the velocity measurement's delay {velocity_delay_s:g} s")
        il = (max(il[0], 0.0), il[1])
    if ell < h:
        warnings.append(
            f"the dead time {ell * 1000:.3g} ms is below one log sample ({h * 1000:.3g} ms): "
            "the log does not resolve it; log faster to measure it"
        )
    if abs(k - 1.0) > max(0.02, ik[1] - k) and recs[0].override is not None:
        warnings.append(
            f"the drive's DC gain is {k:.4g}, not 1: the velocity in steady state differs from "
            "the commanded feed (check the programmed feed and the velocity's units)"
        )
    noise = float(np.median([noise_floor(_velocity(r)) for r in recs]))
    acc, acc_int, delay, planner_rms = (np.nan, (np.nan, np.nan), np.nan, np.nan)
    chosen = "lag"
    reason = f"lag model forced (residual RMS {fit.rms:.3g} mm/min)"
    if model in ("auto", "rate_limited"):
        acc, acc_int, delay, planner_rms = _fit_planner(recs, k, v0s, max_dead,
                                                        confidence)
        if model == "rate_limited":
            chosen = "rate_limited"
            reason = (f"rate-limited planner forced (residual RMS {planner_rms:.3g} mm/min; the "
                      f"lag's {fit.rms:.3g} mm/min)")
        elif planner_rms < MODEL_MARGIN * fit.rms:
            chosen = "rate_limited"
            reason = (
                f"the rate-limited planner fits better: residual RMS {planner_rms:.3g} mm/min "
                f"against the lag's {fit.rms:.3g} mm/min (noise floor {noise:.3g} mm/min); the "
                "velocity ramps at a constant acceleration instead of approaching the command "
                "exponentially"
            )
        else:
            reason = (
                f"the lag (Eq. 6) fits as well or better: residual RMS {fit.rms:.3g} mm/min "
                f"against the rate-limited planner's {planner_rms:.3g} mm/min (noise floor "
                f"{noise:.3g} mm/min)"
            )
    if chosen == "rate_limited":
        warnings.append(
            "the scenario's [feed_drive] holds the planner as kind = 'linuxcnc' (G61 at the "
            "fitted ramp); its bandwidth_rad_s and dead_time_s and the nominal plant hold the "
            f"lag that fits best (residual {fit.rms:.3g} mm/min against the planner's "
            f"{planner_rms:.3g}), right only for steps of the size tested"
        )
    if noise > 0 and fit.rms > 3.0 * noise and chosen == "lag":
        warnings.append(
            f"the lag's residual RMS ({fit.rms:.3g} mm/min) is {fit.rms / noise:.1f} times the "
            "velocity noise floor: the drive has dynamics the model lacks (see the figures)"
        )
    z = fit.z
    sd_a = (ia[1] - ia[0]) / (2 * z)
    sd_l = (il[1] - il[0]) / (2 * z)
    c = fit.covariance
    rho = float(c[0, 1] / np.sqrt(c[0, 0] * c[1, 1])) if c[0, 0] > 0 and c[1, 1] > 0 else 0.0
    cov_al = ((sd_a**2, rho * sd_a * sd_l), (rho * sd_a * sd_l, sd_l**2))
    return FeedDriveFit(
        model=chosen, bandwidth_rad_s=a, bandwidth_interval_rad_s=ia, dead_time_s=ell,
        dead_time_interval_s=il, dc_gain=k, dc_gain_interval=ik, lag_rms_mm_min=fit.rms,
        acceleration_mm_min_s=acc, acceleration_interval_mm_min_s=acc_int,
        planner_delay_s=delay, planner_rms_mm_min=planner_rms, noise_rms_mm_min=noise,
        sample_time_s=h, n_samples=int(sum(r.n_samples for r in recs)), duration_s=duration,
        reason=reason, warnings=tuple(warnings), confidence=confidence,
        initial_velocity_mm_min=tuple(v0s),
        covariance_a_L=cov_al,
        velocity_delay_s=velocity_delay_s,
    )


__all__ = [
    "FEED_DRIVE_MODELS",
    "MAX_DEAD_TIME_S",
    "MODEL_MARGIN",
    "FeedDriveFit",
    "fit_feed_drive",
    "lag_coefficients",
    "lag_response",
    "noise_floor",
    "rate_limited_response",
    "sampled_lag_frequency_response",
]
