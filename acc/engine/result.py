"""Immutable result of a batch simulation: named signals, metrics and the runs' parameters."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acc.scenarios.force import Scenario

#: Recorded signals, their units and meaning.
SIGNALS: dict[str, str] = {
    "force_N": "true cutting force [N]",
    "measured_force_N": "measured (noisy, filtered) force [N]",
    "reference_force_N": "force reference [N]",
    "override": "feedrate override [-]",
    "commanded_feed_mm_min": "commanded feedrate, override x programmed feed [mm/min]",
    "feed_velocity_mm_min": "feed velocity of the drive [mm/min]",
    "position_mm": "tool position along the path [mm]",
    "radial_depth_mm": "radial depth of cut the tool meets [mm]",
    "axial_depth_mm": "axial depth of cut the tool meets [mm]",
    "feed_current_A": "measured feed-motor current (with current sensing or Peng's "
    "estimators on the servo axis) [A]",
    "breakage_monitor_signal": "sample the tool-breakage monitor watched ([tool_breakage]) "
    "[A or N]",
    "kp_per_N": "proportional gain in use (adaptive and observer kinds; else NaN) [1/N]",
    "ki_per_N_s": "integral gain in use (adaptive and observer kinds; else NaN) [1/(N s)]",
    "estimated_k2_N_min_per_mm_s": "estimated process gain K2 [N/(mm/min)/s]",
    "estimated_p2_rad_s": "estimated process pole p2 [rad/s]",
    "estimated_static_gain_N_per_mm_min": "estimated static gain K2/(-p2) [N/(mm/min)]",
    "estimator_updated": "1 where the gain estimator updated at the last period [-]",
    "disturbance_estimate_mm_min": "disturbance-observer estimate on the feed [mm/min]",
}


def _frozen(a: NDArray) -> NDArray:
    a = np.asarray(a)
    a.flags.writeable = False
    return a


def frozen_copy(a: ArrayLike) -> NDArray:
    """A read-only copy of ``a`` (the caller's array stays writeable)."""
    a = np.array(a)
    a.flags.writeable = False
    return a


class FrozenSignals:
    """Read-only ``time_s``, ``signals`` and ``metrics`` of a frozen result dataclass.

    Mixed into the axis, XY and contouring results (and :class:`SimulationResult`, which
    freezes its arrays in place instead): ``__post_init__`` stores read-only
    copies of ``time_s`` (shape (n,)) and of every array of the ``signals`` (shape
    (runs, n)) and ``metrics`` (shape (runs,)) mappings, behind read-only mappings.
    :attr:`runs` counts the tuple field named by ``_runs_field``.
    """

    _runs_field: ClassVar[str]
    time_s: NDArray[np.float64]
    signals: Mapping[str, NDArray[np.float64]]
    metrics: Mapping[str, NDArray[np.float64]]

    def __post_init__(self) -> None:
        object.__setattr__(self, "time_s", frozen_copy(self.time_s))
        for name in ("signals", "metrics"):
            frozen = {k: frozen_copy(v) for k, v in getattr(self, name).items()}
            object.__setattr__(self, name, MappingProxyType(frozen))

    @property
    def runs(self) -> int:
        """Number of runs."""
        return len(getattr(self, self._runs_field))

    def signal(self, name: str) -> NDArray[np.float64]:
        """One recorded signal, shape (runs, n); a clear KeyError for an unknown name."""
        if name not in self.signals:
            known = ", ".join(self.signals) or "none (traces were not recorded)"
            raise KeyError(f"no signal {name!r}; recorded: {known}")
        return self.signals[name]

    def columns(self, what: str = "traces") -> dict[str, NDArray]:
        """The result as flat columns of equal length (what a DataFrame is built from).

        Parameters
        ----------
        what : {"traces", "metrics"}
            ``"traces"``: long format, one row per run and sample: ``run`` (the run's id,
            as in the summary; its index in this result for a lab's result), ``time_s``
            and every recorded signal, each shape (runs * n,), run-major.  ``"metrics"``:
            one row per run, each shape (runs,): the columns of ``acc run``'s
            ``summary.csv`` where the result has them (``summary_rows``), else ``run`` and
            every metric.

        Returns
        -------
        dict of str to ndarray
            Column name (with its unit, as in :data:`SIGNALS` and the summary) to values.

        Raises
        ------
        ValueError
            Unknown ``what``, or traces asked of a result that recorded none.
        """
        if what == "metrics":
            rows = getattr(self, "summary_rows", None)
            if rows is not None:  # the summary.csv row of each run: parameters and metrics
                table = rows()
                return {k: np.asarray([r.get(k) for r in table]) for k in table[0]}
            return {"run": np.arange(self.runs), **{k: np.asarray(v)
                                                     for k, v in self.metrics.items()}}
        if what != "traces":
            raise ValueError(f"what must be 'traces' or 'metrics', got {what!r}")
        if not self.signals:
            raise ValueError("no traces were recorded (simulate with record_every_steps >= 1)")
        n = len(self.time_s)
        out: dict[str, NDArray] = {
            "run": np.repeat(np.asarray(getattr(self, "run_ids", np.arange(self.runs))), n),
            "time_s": np.tile(np.asarray(self.time_s), self.runs),
        }
        for name, values in self.signals.items():
            out[name] = np.asarray(values).reshape(-1)
        return out

    def to_dataframe(self, what: str = "traces") -> Any:
        """The result as a :class:`pandas.DataFrame` (pandas imported only here).

        Parameters
        ----------
        what : {"traces", "metrics"}
            See :meth:`columns`: long-format traces (``run``, ``time_s``, signals) or one row
            of metrics per run.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        ImportError
            pandas is not installed (``pip install pandas``, or the ``acc[pandas]`` extra).
        """
        try:
            import pandas as pd
        except ImportError:
            raise ImportError(
                "to_dataframe needs pandas: pip install pandas (or acc[pandas]); "
                "columns() gives the same data as numpy arrays"
            ) from None
        return pd.DataFrame(self.columns(what))


@dataclass(frozen=True)
class SimulationResult(FrozenSignals):
    """What :func:`acc.engine.simulate.simulate` returns.

    Attributes
    ----------
    time_s : ndarray, shape (n,)
        Recorded sample times ``k dt`` [s].
    signals : mapping of str to ndarray, shape (runs, n)
        Recorded signals (see :data:`SIGNALS`); empty when traces were not recorded.
    metrics : mapping of str to ndarray, shape (runs,)
        Per-run metrics (columns defined in :mod:`acc.engine.metrics`).
    scenarios : tuple of Scenario, length runs
    run_ids : ndarray of int, shape (runs,)
        Index of each run in its campaign; with the seed it fixes the run's random stream.
    parameters : mapping of str to ndarray, shape (runs,)
        Derived per-run parameters (resolved gains, dead-time steps, safe feed).
    """

    time_s: NDArray[np.float64]
    signals: Mapping[str, NDArray[np.float64]]
    metrics: Mapping[str, NDArray[np.float64]]
    scenarios: tuple[Scenario, ...]
    run_ids: NDArray[np.int64]
    parameters: Mapping[str, NDArray[np.float64]]

    _runs_field: ClassVar[str] = "scenarios"

    def __post_init__(self) -> None:
        # frozen in place (no copies), with the run ids and parameters
        object.__setattr__(self, "time_s", _frozen(self.time_s))
        object.__setattr__(self, "run_ids", _frozen(self.run_ids))
        for name in ("signals", "metrics", "parameters"):
            frozen = {k: _frozen(v) for k, v in getattr(self, name).items()}
            object.__setattr__(self, name, MappingProxyType(frozen))

    def summary_table(self) -> dict[str, list[Any]]:
        """The summary as columns of Python values, each of length ``runs``: run id, seed,
        key parameters, every metric and ``failure_reason`` (``"diverged"`` for a failed
        run, else empty); :meth:`summary_rows` by column."""
        sc = self.scenarios
        table: dict[str, list[Any]] = {
            "run": [int(r) for r in np.asarray(self.run_ids).tolist()],
            "seed": [s.simulation.seed for s in sc],
            "controller": [s.controller.kind for s in sc],
            "reference_force_N": [s.controller.reference_force_N for s in sc],
            "radial_depths_mm": [
                " ".join(f"{d:g}" for d in s.workpiece.radial_depth_mm) for s in sc
            ],
            "gain_multiplier": [s.force_process.gain_multiplier for s in sc],
            "dead_time_s": [s.feed_drive.dead_time_s for s in sc],
            "noise_std_N": [s.sensor.noise_std_N for s in sc],
        }
        # a column at a time to Python numbers (as float(v[i]) and bool(v[i]) per cell)
        for k, v in self.parameters.items():
            table[k] = np.asarray(v, dtype=float).tolist()
        for k, v in self.metrics.items():
            table[k] = np.asarray(v, dtype=bool if v.dtype == bool else float).tolist()
        if "failed" in self.metrics:
            table["failure_reason"] = ["diverged" if f else "" for f in table["failed"]]
        return table

    def summary_rows(self) -> list[dict[str, Any]]:
        """One dict per run: run id, seed, key parameters, every metric and
        ``failure_reason`` (``"diverged"`` for a failed run, else empty)."""
        table = self.summary_table()
        return [dict(zip(table, cells, strict=True)) for cells in zip(*table.values(), strict=True)]


def merge_results(
    parts: Sequence[SimulationResult], positions: Sequence[Sequence[int]]
) -> SimulationResult:
    """Merge results of disjoint runs back into one, run ``positions[g][j]`` from part ``g``.

    Time axes must share the step; shorter ones are padded with NaN signals.
    """
    runs = sum(len(p) for p in positions)
    longest = max(parts, key=lambda r: len(r.time_s))
    n = len(longest.time_s)
    order = np.concatenate([np.asarray(p, dtype=np.int64) for p in positions])
    inverse = np.empty(runs, dtype=np.int64)
    inverse[order] = np.arange(runs)

    def stack(name: str, attr: str, width: int | None) -> np.ndarray:
        blocks = []
        for r in parts:
            table = getattr(r, attr)
            if name in table:
                a = np.asarray(table[name])
            elif width is not None:
                a = np.full((r.runs, 0), np.nan)
            else:
                a = np.full((r.runs,), np.nan)
            if width is not None:
                pad = np.full((r.runs, width), np.nan)
                pad[:, : a.shape[1]] = a
                a = pad
            blocks.append(a)
        return np.concatenate(blocks)[inverse]

    def names(attr: str) -> list[str]:
        out: list[str] = []
        for r in parts:
            out += [k for k in getattr(r, attr) if k not in out]
        return out

    scenarios = [sc for r in parts for sc in r.scenarios]
    return SimulationResult(
        time_s=longest.time_s,
        signals={k: stack(k, "signals", n) for k in names("signals")},
        metrics={k: stack(k, "metrics", None) for k in names("metrics")},
        scenarios=tuple(scenarios[j] for j in inverse),
        run_ids=np.concatenate([r.run_ids for r in parts])[inverse],
        parameters={k: stack(k, "parameters", None) for k in names("parameters")},
    )


__all__ = ["SIGNALS", "FrozenSignals", "SimulationResult", "frozen_copy", "merge_results"]
