"""Per-run metrics of a cutting-force loop, accumulated online (no trace needed).

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
  ``productivity_gain_pct = 100 (conventional_time / machining_time - 1)``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq


def safe_feed_mm_min(reference_force_N: float, static_gains_N_per_mm_min: NDArray) -> float:
    """Largest constant feed whose steady force is at most the reference on every depth.

    With the force process realised as ``f = G x`` and ``x`` a monotone first-order response
    to the feed, a constant feed ``F`` started at rest never gives more force than ``G F``;
    so ``F_safe = r / max G`` over the cutting segments [mm/min].
    """
    g = np.asarray(static_gains_N_per_mm_min, dtype=float)
    g = g[g > 0]
    return reference_force_N / float(g.max())


def constant_feed_time_s(
    length_mm: float, feed_mm_min: float, bandwidth_rad_s: float, dead_time_s: float
) -> float:
    """Time for the feed drive (Eq. 6), started at rest, to travel a length at a constant command.

    Travel ``s(t) = F/60 (t - L - (1 - exp(-a (t - L))) / a)`` for ``t >= L``; solved for
    ``s = length`` [s].
    """
    v = feed_mm_min / 60.0
    a, L = bandwidth_rad_s, dead_time_s

    def travel(t: float) -> float:
        tau = t - L
        return v * (tau + math.expm1(-a * tau) / a) - length_mm

    hi = L + length_mm / v + 1.0 / a + 1.0
    return brentq(travel, L, hi, xtol=1e-12, rtol=1e-14)


_NEVER = np.iinfo(np.int64).max


class MetricsAccumulator:
    """Online metrics for a batch (see the module docstring).

    Parameters
    ----------
    reference_force_N : ndarray, shape (runs,)
    cutting : ndarray of bool, shape (runs, segments + 1)
        Whether each segment (with the trailing "left the part" column) is a cut.
    settling_band_pct : ndarray, shape (runs,)
    plant_step_s : float
    """

    def __init__(
        self,
        reference_force_N: NDArray,
        cutting: NDArray[np.bool_],
        settling_band_pct: NDArray,
        plant_step_s: float,
    ) -> None:
        runs, ncol = cutting.shape
        self.runs = runs
        self.dt = plant_step_s
        self.reference = np.asarray(reference_force_N, dtype=float)
        self.band = self.reference * np.asarray(settling_band_pct, dtype=float) / 100.0
        self.cutting = cutting
        self._rows = np.arange(runs)
        self.iae = np.zeros(runs)
        self.ise = np.zeros(runs)
        self.cut_steps = np.zeros(runs, dtype=np.int64)
        self.peak = np.full((runs, ncol), -np.inf)
        #: first step in each segment; NEVER (a large number) if not reached
        self.enter_step = np.full((runs, ncol), _NEVER, dtype=np.int64)
        self.last_out_step = np.full((runs, ncol), -1, dtype=np.int64)
        self.last_step_in = np.full((runs, ncol), -1, dtype=np.int64)
        self.finish_step = np.full(runs, -1, dtype=np.int64)
        self._row_offset = np.arange(runs) * ncol
        self._cutting_flat = self.cutting.ravel()
        self._peak_flat = self.peak.reshape(-1)
        self._enter_flat = self.enter_step.reshape(-1)
        self._last_out_flat = self.last_out_step.reshape(-1)
        self._last_in_flat = self.last_step_in.reshape(-1)

    def update(
        self, k: int, force_N: NDArray, segment: NDArray[np.intp], finished: NDArray
    ) -> None:
        """Account for plant step ``k`` (force at ``t_k``, segment over the step)."""
        flat = self._row_offset + segment  # index into the raveled (runs, segments + 1) tables
        cut = self._cutting_flat[flat]
        e = force_N - self.reference
        abs_e = np.abs(e)
        self.iae += abs_e * cut * self.dt
        self.ise += e * e * cut * self.dt
        self.cut_steps += cut
        peak = self._peak_flat
        peak[flat] = np.maximum(peak[flat], force_N)
        enter = self._enter_flat
        enter[flat] = np.minimum(enter[flat], k)
        self._last_in_flat[flat] = k
        last_out = self._last_out_flat
        last_out[flat] = np.where(abs_e > self.band, k, last_out[flat])
        newly = finished & (self.finish_step < 0)
        if newly.any():
            self.finish_step[newly] = k

    def result(self, segments: int) -> dict[str, NDArray[np.float64]]:
        """Metrics per run, each of shape (runs,); per-segment keys for ``segments`` columns."""
        dt = self.dt
        cut_time = self.cut_steps * dt
        with np.errstate(invalid="ignore", divide="ignore"):
            rms = np.sqrt(self.ise / cut_time)
        out: dict[str, NDArray[np.float64]] = {
            "iae_N_s": self.iae.copy(),
            "ise_N2_s": self.ise.copy(),
            "rms_error_N": rms,
            "cutting_time_s": cut_time.astype(float),
            "machining_time_s": np.where(self.finish_step >= 0, self.finish_step * dt, np.nan),
        }
        peaks = []
        for j in range(segments):
            reached = self.enter_step[:, j] != _NEVER
            is_cut = self.cutting[:, j]
            peak = np.where(reached & is_cut, self.peak[:, j], np.nan)
            peaks.append(peak)
            settled = reached & (self.last_out_step[:, j] < self.last_step_in[:, j])
            settle = np.where(
                self.last_out_step[:, j] < 0,
                0.0,
                (self.last_out_step[:, j] - self.enter_step[:, j] + 1) * dt,
            )
            out[f"peak_force_N_seg{j + 1}"] = peak
            out[f"overshoot_pct_seg{j + 1}"] = 100.0 * (peak - self.reference) / self.reference
            out[f"settling_time_s_seg{j + 1}"] = np.where(settled & is_cut, settle, np.nan)
        stacked = np.vstack(peaks) if peaks else np.full((1, self.runs), np.nan)
        with np.errstate(invalid="ignore"):
            all_nan = np.all(np.isnan(stacked), axis=0)
            peak_all = np.where(
                all_nan, np.nan, np.nanmax(np.where(np.isnan(stacked), -np.inf, stacked), axis=0)
            )
        out["peak_force_N"] = peak_all
        out["max_overshoot_pct"] = 100.0 * (peak_all - self.reference) / self.reference
        return out


__all__ = ["MetricsAccumulator", "constant_feed_time_s", "safe_feed_mm_min"]
