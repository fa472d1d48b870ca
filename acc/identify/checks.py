"""Honest limits of identification: what is refused in one line, and what is only warned.

A fit that the data cannot support is never returned silently.  Either the data are
refused with an :class:`IdentificationError` (the command line prints
``acc: error: <message>`` and exits with status 2), or the fit is returned with a stated
warning that the report prints.

=========================================  =================================================
condition                                  outcome
=========================================  =================================================
record shorter than :data:`MIN_SAMPLES`    error
samples or :data:`MIN_DURATION_S`
a drive input that never changes           error (nothing to identify from)
record shorter than                        error: the response is not resolved
:data:`MIN_RESPONSE_TIMES` x the fitted
``L + 1/a`` (drive) or ``1/|p2|`` (cut)
every frequency of the FRF below the       error; some below: warning naming them
coherence threshold
a cutting record whose drive input         error: a feed controller was closing the loop
follows the force residual (feedback)      (:func:`feedback_evidence`), the fit is biased
a dead time below one sample               warning: the log does not resolve it
an interval wider than                     warning; wider than
:data:`WIDE_INTERVAL_REL` of the value     :data:`UNIDENTIFIABLE_REL`: error
=========================================  =================================================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats

from acc.errors import AccError

#: Fewest samples of a record [-].
MIN_SAMPLES = 100
#: Shortest record [s].
MIN_DURATION_S = 1.0
#: A record must span this many of the fitted response times [-].
MIN_RESPONSE_TIMES = 5.0
#: Default least coherence of a frequency of the FRF [-].
MIN_COHERENCE = 0.8
#: Relative interval half-width above which a parameter is warned about [-].
WIDE_INTERVAL_REL = 0.25
#: Relative interval half-width above which a parameter is refused as not identified [-].
UNIDENTIFIABLE_REL = 1.0
#: Family-wise false-alarm probability of the feedback test over all tested lags [-].
FEEDBACK_FALSE_ALARM = 1e-3


class IdentificationError(AccError):
    """Data that cannot give the asked-for model; one line, exit status 2 on the CLI."""


def check_length(n_samples: int, duration_s: float, source: str) -> None:
    """Refuse a record too short to identify anything from.

    Parameters
    ----------
    n_samples : int
    duration_s : float
        Record length [s].
    source : str
        The record's name, for the message.
    """
    if n_samples < MIN_SAMPLES or duration_s < MIN_DURATION_S:
        raise IdentificationError(
            f"{source}: the record is too short ({n_samples} samples, {duration_s:.3g} s); "
            f"at least {MIN_SAMPLES} samples and {MIN_DURATION_S:g} s are needed"
        )


def check_response_resolved(
    duration_s: float, response_time_s: float, what: str, source: str
) -> None:
    """Refuse a fit whose response time is not covered :data:`MIN_RESPONSE_TIMES` times.

    Parameters
    ----------
    duration_s : float
        Record length [s].
    response_time_s : float
        The fitted model's response time [s] (``L + 1/a``, or ``1/|p2|``).
    what : str
        What was fitted (for the message).
    source : str
    """
    if duration_s < MIN_RESPONSE_TIMES * response_time_s:
        raise IdentificationError(
            f"{source}: the record ({duration_s:.3g} s) is too short for the {what} "
            f"(response time {response_time_s:.3g} s; at least {MIN_RESPONSE_TIMES:g} response "
            "times are needed): record longer"
        )


@dataclass(frozen=True)
class FeedbackEvidence:
    """Correlation between the drive input's increments and the earlier force residual.

    Attributes
    ----------
    max_abs_z : float
        Largest ``|r| / sigma_r`` over the tested lags [-] (``sigma_r`` from Bartlett's
        formula with both series' autocorrelations).
    lag_s : float
        Lag at which it occurs (residual earlier than the input) [s].
    threshold_z : float
        Bonferroni threshold for :data:`FEEDBACK_FALSE_ALARM` over the lags [-].
    """

    max_abs_z: float
    lag_s: float
    threshold_z: float

    @property
    def closed_loop(self) -> bool:
        """Whether the input follows the residual (feedback) beyond chance."""
        return self.max_abs_z > self.threshold_z


def _autocorrelation(x: np.ndarray, lags: int) -> np.ndarray:
    x = x - x.mean()
    n = len(x)
    spec = np.fft.rfft(x, 2 * n)
    acov = np.fft.irfft(spec * np.conj(spec), 2 * n)[: lags + 1]
    return acov / acov[0] if acov[0] > 0 else np.zeros(lags + 1)


def feedback_evidence(
    input_increment: ArrayLike, residual: ArrayLike, sample_time_s: float, max_lag_s: float = 0.5
) -> FeedbackEvidence:
    """Test whether the drive input reacts to the force noise (data taken in closed loop).

    In open loop the override is a schedule: its increments ``du[k]`` are independent of the
    force noise that came before them, so the correlation of ``du[k]`` with the fitted
    model's residual ``e[k - j]``, ``j = 0 .. max_lag``, is zero but for chance (Ljung,
    *System Identification*, 16.6).  A force controller makes ``du[k]`` a function of the
    measured force at the control instant, and the correlation is large.  Each lag's
    correlation is scaled by its standard deviation under independence (Bartlett:
    ``var r = (1/n) sum_l rho_du(l) rho_e(l)``) and compared with a Bonferroni threshold.

    Parameters
    ----------
    input_increment : array_like, shape (n,)
        ``u[k] - u[k-1]`` of the drive input [mm/min].
    residual : array_like, shape (n,)
        Measured minus model force [N].
    sample_time_s : float
    max_lag_s : float
        Largest lag tested [s].

    Returns
    -------
    FeedbackEvidence
    """
    du = np.asarray(input_increment, dtype=float)
    e = np.asarray(residual, dtype=float)
    n = len(du)
    lags = int(min(max(1, round(max_lag_s / sample_time_s)), n // 4))
    threshold = float(stats.norm.isf(FEEDBACK_FALSE_ALARM / (2 * (lags + 1))))
    du0 = du - du.mean()
    e0 = e - e.mean()
    denom = np.sqrt(np.sum(du0**2) * np.sum(e0**2))
    if denom == 0:
        return FeedbackEvidence(0.0, 0.0, threshold)
    spec_u = np.fft.rfft(du0, 2 * n)
    spec_e = np.fft.rfft(e0, 2 * n)
    # c[j] = sum_k du[k] e[k - j]
    cross = np.fft.irfft(spec_u * np.conj(spec_e), 2 * n)[: lags + 1] / denom
    span = min(n // 4, 4 * lags + 50)
    rho_u = _autocorrelation(du, span)
    rho_e = _autocorrelation(e, span)
    var = (1.0 + 2.0 * np.sum(rho_u[1:] * rho_e[1:])) / n
    sigma = np.sqrt(max(var, 1.0 / n))
    z = np.abs(cross) / sigma
    j = int(np.argmax(z))
    return FeedbackEvidence(float(z[j]), j * sample_time_s, threshold)


def relative_half_width(value: float, interval: tuple[float, float]) -> float:
    """Half the interval's width over ``|value|`` [-] (inf for a zero value)."""
    half = 0.5 * (interval[1] - interval[0])
    return float(half / abs(value)) if value != 0 else float("inf")


__all__ = [
    "FEEDBACK_FALSE_ALARM",
    "MIN_COHERENCE",
    "MIN_DURATION_S",
    "MIN_RESPONSE_TIMES",
    "MIN_SAMPLES",
    "UNIDENTIFIABLE_REL",
    "WIDE_INTERVAL_REL",
    "FeedbackEvidence",
    "IdentificationError",
    "check_length",
    "check_response_resolved",
    "feedback_evidence",
    "relative_half_width",
]
