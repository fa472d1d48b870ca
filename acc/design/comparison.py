"""Side-by-side comparison of controller kinds (and materials) on one scenario.

One batch simulates every (gain multiplier, controller kind) pair, so all runs share the time
grid and the random streams are fixed by run index.  The figure shows force, commanded feed,
estimated static gain and disturbance estimate; the table lists the metrics per run.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import matplotlib.pyplot as plt
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from acc.engine.result import SimulationResult
from acc.engine.simulate import simulate
from acc.scenario import Scenario

#: The four kinds of the robust adaptive controller study.
FOUR_KINDS = ("pi", "adaptive_pi", "dob_pi", "dob_adaptive_pi")

#: Metrics shown in comparison tables.
TABLE_METRICS = (
    "iae_N_s",
    "rms_error_N",
    "peak_force_N",
    "max_overshoot_pct",
    "machining_time_s",
    "productivity_gain_pct",
    "failed",
)


@dataclass(frozen=True)
class Comparison:
    """Result of :func:`compare`.

    Attributes
    ----------
    result : SimulationResult
        One run per (multiplier, kind), multipliers outer, kinds inner.
    kinds : tuple of str
    gain_multipliers : tuple of float
    """

    result: SimulationResult
    kinds: tuple[str, ...]
    gain_multipliers: tuple[float, ...]

    def run(self, kind: str, gain_multiplier: float | None = None) -> int:
        """Run index of a (kind, multiplier) pair (multiplier None: the first one)."""
        g = self.gain_multipliers[0] if gain_multiplier is None else gain_multiplier
        return self.gain_multipliers.index(g) * len(self.kinds) + self.kinds.index(kind)

    def table(self) -> list[dict[str, float | str]]:
        """One row per run: kind, gain multiplier and :data:`TABLE_METRICS`."""
        rows = []
        for g, kind in itertools.product(self.gain_multipliers, self.kinds):
            i = self.run(kind, g)
            row: dict[str, float | str] = {"controller": kind, "gain_multiplier": g}
            row.update({m: float(self.result.metrics[m][i]) for m in TABLE_METRICS})
            rows.append(row)
        return rows


def compare(
    scenario: Scenario,
    kinds: Sequence[str] = FOUR_KINDS,
    gain_multipliers: Sequence[float] | None = None,
    record_every_steps: int = 10,
) -> Comparison:
    """Simulate every kind on the scenario, for each process-gain multiplier.

    Parameters
    ----------
    scenario : Scenario
    kinds : sequence of str
        Controller kinds (``controller.kind`` values).
    gain_multipliers : sequence of float, optional
        ``force_process.gain_multiplier`` values (material harder > 1 > softer); default:
        the scenario's own.
    record_every_steps : int
        Trace decimation [plant steps].
    """
    if gain_multipliers is None:
        gain_multipliers = (scenario.force_process.gain_multiplier,)
    runs = [
        scenario.with_values({"controller.kind": k, "force_process.gain_multiplier": g})
        for g, k in itertools.product(gain_multipliers, kinds)
    ]
    result = simulate(runs, record_every_steps=record_every_steps)
    return Comparison(result, tuple(kinds), tuple(float(g) for g in gain_multipliers))


def _plot_signal(
    comparison: Comparison, signal: str, gain_multiplier: float | None, ax: Axes, ylabel: str
) -> Axes:
    res = comparison.result
    for kind in comparison.kinds:
        i = comparison.run(kind, gain_multiplier)
        ax.plot(res.time_s, res.signal(signal)[i], lw=1.0, label=kind)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    return ax


def plot_comparison_force(
    comparison: Comparison, gain_multiplier: float | None = None, ax: Axes | None = None
) -> Axes:
    """Force of every kind [N] with the reference, over time [s]."""
    ax = ax or plt.subplots()[1]
    _plot_signal(comparison, "force_N", gain_multiplier, ax, "force [N]")
    i = comparison.run(comparison.kinds[0], gain_multiplier)
    ref = comparison.result.signal("reference_force_N")[i]
    ax.plot(comparison.result.time_s, ref, "k--", lw=0.8, label="reference")
    ax.legend(fontsize="small", ncol=2)
    return ax


def comparison_figure(comparison: Comparison, gain_multiplier: float | None = None) -> Figure:
    """Force, commanded feed, estimated static gain and disturbance estimate, stacked."""
    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(8.0, 9.0), constrained_layout=True)
    plot_comparison_force(comparison, gain_multiplier, axes[0])
    _plot_signal(comparison, "commanded_feed_mm_min", gain_multiplier, axes[1], "feed [mm/min]")
    _plot_signal(
        comparison,
        "estimated_static_gain_N_per_mm_min",
        gain_multiplier,
        axes[2],
        "est. gain [N/(mm/min)]",
    )
    _plot_signal(
        comparison, "disturbance_estimate_mm_min", gain_multiplier, axes[3], "dist. est. [mm/min]"
    )
    axes[3].set_xlabel("time [s]")
    g = comparison.gain_multipliers[0] if gain_multiplier is None else gain_multiplier
    axes[0].set_title(f"process gain x{g:g}")
    return fig


def markdown_table(rows: Sequence[dict[str, float | str]]) -> str:
    """A Markdown table of comparison rows (numbers to 4 significant digits)."""
    columns = list(rows[0])
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        cells = [v if isinstance(v, str) else f"{v:.4g}" for v in row.values()]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


__all__ = [
    "FOUR_KINDS",
    "TABLE_METRICS",
    "Comparison",
    "compare",
    "comparison_figure",
    "markdown_table",
    "plot_comparison_force",
]
