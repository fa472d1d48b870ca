"""The sweep's report phase alone on a large summary, this tree and an older one in one run.

``python benchmarks/bench_report_phase.py [--copies 500] [--runs 2000] [--baseline DIR]
[--write FILE]``

Sweeps ``bench_loop.py``'s speed campaign with ``--runs`` runs (noisy ``dob_adaptive_pi``,
random radial and axial depth lists), repeats its summary's rows ``--copies`` times (1e6
rows by default), then times what ``acc sweep`` does after the last chunk (read the summary
back, draw the figures, write the report text) in a fresh process per tree, reporting wall
time and maximum resident memory.  The report texts of the trees must be equal.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_cli import add_tree_args, copy_trees, finish_report  # noqa: E402
from bench_loop import SWEEP_CAMPAIGN  # noqa: E402

SCENARIO = Path("experiments") / "kim_chung_2001.toml"

#: What ``acc sweep``'s report step does (``acc.cli.campaigns._cmd_sweep``), on either tree:
#: a column at a time where the tree reads a large summary so, else the report's columns
#: where the tree reads only those, else every column.
_REPORT = """
import sys, tempfile
from pathlib import Path
import matplotlib
matplotlib.use("Agg")
import acc.campaigns.report as rep
from acc.campaigns.campaign import load_campaign
from acc.campaigns.sweep import read_summary
from acc.cli.campaigns import _figures
campaign = load_campaign(sys.argv[2])
try:  # a large summary a column at a time, where the tree does so
    from acc.campaigns.summary_columns import summary_for_report
except ImportError:
    summary_for_report = None
if summary_for_report is not None:
    summary = summary_for_report(sys.argv[1], rep.report_columns(campaign))
    swept = tuple(k for k in campaign.swept_keys if k in summary)
elif hasattr(rep, "report_columns"):
    summary = read_summary(sys.argv[1], rep.report_columns(campaign))
    swept = tuple(k for k in campaign.swept_keys if k in summary)
else:
    summary, swept = read_summary(sys.argv[1]), campaign.swept_keys
figures = _figures(Path(tempfile.mkdtemp()), summary, swept, [], campaign.model)
print(rep.report_text(campaign.name, summary, figures, campaign.model))
"""


def report_phase(tree: Path, summary: Path, campaign: Path) -> tuple[float, float, str]:
    """Wall time [s], maximum RSS [bytes] and report text of the report step on ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    code = (
        "import resource, subprocess, sys\n"
        "done = subprocess.run([sys.executable, '-c', sys.argv[1], *sys.argv[2:]],"
        " capture_output=True, text=True, check=True)\n"
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
        "print(done.stdout, end='')\n"
    )
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code, _REPORT, str(summary), str(campaign)],
                          cwd=tree, env=env, capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - t0
    first, _, text = done.stdout.partition("\n")
    return seconds, float(first) * 1024, text


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=2000, help="runs of the sweep")
    ap.add_argument("--copies", type=int, default=500, help="copies of its summary's rows")
    add_tree_args(ap, "an older source tree, measured after")
    args = ap.parse_args(argv)
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        w = Path(tmp)
        trees = copy_trees(args.baseline, w)
        campaign = w / "sweep.toml"
        campaign.write_text(SWEEP_CAMPAIGN.format(scenario=trees["this tree"] / SCENARIO,
                                                  runs=args.runs), encoding="utf-8")
        env = {**os.environ, "PYTHONPATH": str(trees["this tree"]), "MPLBACKEND": "Agg"}
        subprocess.run([sys.executable, "-m", "acc", "sweep", str(campaign), "--out",
                        str(w / "out"), "--no-progress", "-q", "--no-figures"],
                       cwd=trees["this tree"], env=env, check=True)
        head, *body = (w / "out" / "summary.csv").read_text(encoding="utf-8").splitlines(True)
        big = w / "big.csv"
        with big.open("w", encoding="utf-8") as fh:
            fh.write(head)
            for _ in range(args.copies):
                fh.writelines(body)
        rows = len(body) * args.copies
        results = {label: report_phase(tree, big, campaign) for label, tree in trees.items()}
    texts = {text for _, _, text in results.values()}
    if len(texts) != 1:
        raise SystemExit("the trees wrote different reports")
    load_after = os.getloadavg()[0]
    lines = ["| quantity | value |", "|---|---|"]
    for label, (seconds, rss, _) in results.items():
        tag = "" if label == "this tree" else f" ({label}: {args.baseline.name})"
        lines.append(f"| report step of a {rows}-row summary{tag}: wall time [s] | "
                     f"{seconds:.1f} |")
        lines.append(f"| report step of a {rows}-row summary{tag}: maximum RSS [MiB] | "
                     f"{rss / 2**20:.0f} |")
    return finish_report(lines, "bench_report_phase.py", argv, (load_before, load_after),
                         args.write, note="The report texts are equal. ")


if __name__ == "__main__":
    raise SystemExit(main())
