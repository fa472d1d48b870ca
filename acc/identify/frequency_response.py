"""Measured frequency response of the feed drive, with coherence and intervals.

Two estimators, one result type (:class:`FrequencyResponse`):

``stepped_sine_response``
    Per tone (Kim & Chung Sec. 3.1: sinusoidal feedrates from 0.2 to 8 Hz): over the
    measured part of each tone, after its settling periods, least squares of
    ``c0 + c1 cos(w t) + c2 sin(w t)`` on the command and on the velocity; the response is
    the ratio of the complex amplitudes.  The tone's *coherence* is the share of the
    velocity's variance the tone explains (1 for a clean linear response; noise, drift and
    harmonics from a non-linear drive lower it).  The relative standard deviation of the
    response comes from the velocity fit's residual variance and ``(X^T X)^{-1}``.
``welch_response``
    For broadband excitation (chirp, PRBS): ``H1 = P_uv / P_uu`` with Welch's averaged
    periodograms (Hann window, half overlap), the magnitude-squared coherence
    ``|P_uv|^2 / (P_uu P_vv)`` and the relative standard deviation
    ``sqrt((1 - g^2) / (2 n_d g^2))`` (Bendat & Piersol, *Random Data*, Eq. 9.90, ``n_d``
    averages).

Both measure the response of the *sampled* system from the command held over each log
step to the sampled velocity: the model to compare with is
:func:`acc.identify.feed_drive_fit.sampled_lag_frequency_response`, which differs from the
continuous ``a e^{-Ls}/(s + a)`` by the hold's half-sample delay and attenuation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import signal

from acc.identify.checks import IdentificationError
from acc.identify.measurement import Record


@dataclass(frozen=True, eq=False)
class FrequencyResponse:
    """A measured frequency response from the drive's command to its velocity.

    Attributes
    ----------
    frequency_hz : ndarray, shape (m,)
    response : ndarray of complex, shape (m,)
        ``V/U`` [-].
    coherence : ndarray, shape (m,)
        In [0, 1] (module docstring).
    relative_std : ndarray, shape (m,)
        Standard deviation of the estimate over its magnitude [-].
    method : {"stepped_sines", "welch"}
    source : str
    averages : int
        Welch segments averaged (1 for stepped sines).
    """

    frequency_hz: NDArray[np.float64]
    response: NDArray[np.complex128]
    coherence: NDArray[np.float64]
    relative_std: NDArray[np.float64]
    method: str
    source: str
    averages: int

    @property
    def magnitude_db(self) -> NDArray[np.float64]:
        """``20 log10 |H|`` [dB], shape (m,)."""
        return 20.0 * np.log10(np.abs(self.response))

    @property
    def phase_deg(self) -> NDArray[np.float64]:
        """Unwrapped phase [deg], shape (m,)."""
        return np.degrees(np.unwrap(np.angle(self.response)))

    def coherent(self, min_coherence: float) -> NDArray[np.bool_]:
        """Frequencies whose coherence reaches ``min_coherence``, shape (m,)."""
        return self.coherence >= min_coherence


def _tone_fit(t: NDArray, x: NDArray, omega: float) -> tuple[complex, float, float, NDArray]:
    """Complex amplitude ``X`` (``x ~ c0 + Re(X e^{j w t})``), explained share of the AC
    variance, residual variance and the covariance factor of (cos, sin) coefficients."""
    basis = np.column_stack([np.ones_like(t), np.cos(omega * t), np.sin(omega * t)])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    resid = x - basis @ coef
    ac = x - x.mean()
    total = float(ac @ ac)
    explained = 1.0 - float(resid @ resid) / total if total > 0 else 0.0
    var = float(resid @ resid) / max(len(x) - 3, 1)
    cov = np.linalg.inv(basis.T @ basis)[1:, 1:]
    return complex(coef[1], -coef[2]), explained, var, cov


@dataclass(frozen=True)
class ToneWindow:
    """Where one tone is measured in a record.

    Attributes
    ----------
    frequency_hz : float
    start_s, end_s : float
        The measured part (after the tone's settling periods), record time [s].
    """

    frequency_hz: float
    start_s: float
    end_s: float


def stepped_sine_response(record: Record, tones: Sequence[ToneWindow]) -> FrequencyResponse:
    """Per-tone response of a stepped-sine record (module docstring).

    Parameters
    ----------
    record : Record
        With ``feed_velocity_mm_min``.
    tones : sequence of ToneWindow
        Tone frequencies and their measured windows in the record's time.

    Returns
    -------
    FrequencyResponse
    """
    if record.feed_velocity_mm_min is None:
        raise IdentificationError(f"{record.source}: no feed_velocity_mm_min for the FRF")
    t_all = record.time_s
    freq, resp, coh, rel = [], [], [], []
    for tone in tones:
        sel = (t_all >= tone.start_s) & (t_all < tone.end_s)
        if np.count_nonzero(sel) < 8:
            continue
        t = t_all[sel] - tone.start_s
        w = 2.0 * np.pi * tone.frequency_hz
        u_amp, _, _, _ = _tone_fit(t, record.drive_input_mm_min[sel], w)
        v_amp, share, var, cov = _tone_fit(t, record.feed_velocity_mm_min[sel], w)
        if abs(u_amp) == 0:
            continue
        h = v_amp / u_amp
        # variance of the complex amplitude: var of cos coef + var of sin coef
        v_sd = float(np.sqrt(var * (cov[0, 0] + cov[1, 1])))
        freq.append(tone.frequency_hz)
        resp.append(h)
        coh.append(max(share, 0.0))
        rel.append(v_sd / abs(v_amp) if abs(v_amp) > 0 else np.inf)
    if not freq:
        raise IdentificationError(
            f"{record.source}: no tone of the excitation lies inside the record (check that "
            "the log covers the whole schedule)"
        )
    return FrequencyResponse(
        np.array(freq), np.array(resp), np.array(coh), np.array(rel), "stepped_sines",
        record.source, 1,
    )


def welch_response(
    record: Record, band_hz: tuple[float, float] | None = None, segment_s: float | None = None
) -> FrequencyResponse:
    """``H1`` estimate from Welch's averaged spectra (module docstring).

    Parameters
    ----------
    record : Record
        With ``feed_velocity_mm_min``.
    band_hz : (float, float), optional
        Frequencies kept [Hz]; default: from 4 / duration to a quarter of the sample rate.
    segment_s : float, optional
        Segment length [s]; default: long enough for two periods of the band's lowest
        frequency, at most a quarter of the record.

    Returns
    -------
    FrequencyResponse
        Only frequencies in the band where the command has power (above 1e-4 of its peak).
    """
    if record.feed_velocity_mm_min is None:
        raise IdentificationError(f"{record.source}: no feed_velocity_mm_min for the FRF")
    h = record.sample_time_s
    fs = 1.0 / h
    n = record.n_samples
    lo, hi = band_hz if band_hz else (4.0 / record.duration_s, 0.25 * fs)
    if segment_s is None:
        segment_s = min(record.duration_s / 4.0, max(2.0 / max(lo, 1e-6), 4.0))
    nper = int(min(n, max(16, round(segment_s / h))))
    u = record.drive_input_mm_min
    v = record.feed_velocity_mm_min
    kw = dict(fs=fs, window="hann", nperseg=nper, noverlap=nper // 2, detrend="constant")
    f, puu = signal.welch(u, **kw)
    _, pvv = signal.welch(v, **kw)
    _, puv = signal.csd(u, v, **kw)
    averages = 1 + (n - nper) // (nper - nper // 2)
    keep = (f >= lo) & (f <= hi) & (puu > 1e-4 * puu.max()) & (f > 0)
    if not np.any(keep):
        raise IdentificationError(
            f"{record.source}: the command has no power in {lo:.3g}..{hi:.3g} Hz: no frequency "
            "response can be measured"
        )
    resp = puv[keep] / puu[keep]
    coh = np.clip(np.abs(puv[keep]) ** 2 / (puu[keep] * pvv[keep]), 0.0, 1.0)
    rel = np.sqrt((1.0 - coh) / (2.0 * averages * np.maximum(coh, 1e-12)))
    return FrequencyResponse(f[keep], resp, coh, rel, "welch", record.source, int(averages))


__all__ = ["FrequencyResponse", "ToneWindow", "stepped_sine_response", "welch_response"]
