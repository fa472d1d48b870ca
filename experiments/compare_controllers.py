"""Run pi, adaptive_pi, dob_pi and dob_adaptive_pi on the Kim & Chung stepped part, fairly.

Usage::

    python experiments/compare_controllers.py --out out/compare [--scenario FILE] [--seeds 20]

Every kind runs on the same noise realisations (common random numbers), over ``--seeds``
seeds.  Writes ``paired.csv``/``paired.md`` (per kind: mean IAE with its 95 % interval, the
paired difference against ``pi`` with its interval and whether it is significant),
``runs.csv`` (every run), ``distribution_gain_x*.png`` (each seed's IAE per kind, and the
paired differences) and ``comparison_gain_x*.png`` (seed 0's force, feed, estimated gain and
disturbance estimate, each run ending at its own end of cut).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from acc.cli.main import load_with_overrides  # noqa: E402
from acc.design.comparison import (  # noqa: E402
    compare,
    comparison_figure,
    markdown_table,
    plot_metric_distribution,
    plot_paired_differences,
)
from acc.output import write_csv  # noqa: E402

HERE = Path(__file__).resolve().parent


def main(
    argv: list[str] | None = None,
    gain_multipliers: tuple[float, ...] | None = None,
    defaults: tuple[str, ...] = (),
) -> int:
    """Compare the four controllers; one figure per gain multiplier.

    ``defaults`` are ``section.key=value`` settings applied before the command line's
    ``--set`` ones.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--scenario", default=str(HERE / "kim_chung_2001.toml"))
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    parser.add_argument("--seeds", type=int, default=20, help="paired noise realisations")
    parser.add_argument("--metric", default="iae_N_s", help="metric compared (summary column)")
    args = parser.parse_args(argv)
    scenario = load_with_overrides(args.scenario, [*defaults, *args.set])
    args.out.mkdir(parents=True, exist_ok=True)
    comparison = compare(scenario, gain_multipliers=gain_multipliers, seeds=args.seeds)
    write_csv(args.out / "runs.csv", comparison.table())
    paired = comparison.paired(args.metric)
    write_csv(args.out / "paired.csv", paired)
    (args.out / "paired.md").write_text(markdown_table(paired), encoding="utf-8")
    for g in comparison.gain_multipliers:
        fig, axes = plt.subplots(1, 2, figsize=(12.0, 4.5), constrained_layout=True)
        plot_metric_distribution(comparison, args.metric, g, ax=axes[0])
        plot_paired_differences(comparison, args.metric, ax=axes[1])
        fig.savefig(args.out / f"distribution_gain_x{g:g}.png", dpi=110)
        plt.close(fig)
        fig = comparison_figure(comparison, g)
        fig.savefig(args.out / f"comparison_gain_x{g:g}.png", dpi=110)
        plt.close(fig)
    print(markdown_table(paired))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
