"""Run pi, adaptive_pi, dob_pi and dob_adaptive_pi on the Kim & Chung stepped part.

Usage::

    python experiments/compare_controllers.py --out out/compare [--scenario FILE]

Writes ``comparison.png`` (force, commanded feed, estimated gain, disturbance estimate),
``metrics.csv`` and ``metrics.md``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from acc.cli.main import load_with_overrides  # noqa: E402
from acc.design.comparison import compare, comparison_figure, markdown_table  # noqa: E402
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
    args = parser.parse_args(argv)
    scenario = load_with_overrides(args.scenario, [*defaults, *args.set])
    args.out.mkdir(parents=True, exist_ok=True)
    comparison = compare(scenario, gain_multipliers=gain_multipliers)
    rows = comparison.table()
    write_csv(args.out / "metrics.csv", rows)
    (args.out / "metrics.md").write_text(markdown_table(rows), encoding="utf-8")
    for g in comparison.gain_multipliers:
        fig = comparison_figure(comparison, g)
        fig.savefig(args.out / f"comparison_gain_x{g:g}.png", dpi=110)
        plt.close(fig)
    print(markdown_table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
