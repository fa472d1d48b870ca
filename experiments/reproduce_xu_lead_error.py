"""Xu et al. (seed 003) lead-error monitoring: the thread kinematics of Table 1 and a monitored
thread.

* Table 1 (L154-L158): the Z feed of each row equals lead x C speed (``v_z = L n_C``), printed
  vs workbench vs residual (H3-02).
* A monitored thread, lead 40 mm, C 18 r/min, Z 2500-3200 mm (E3-1/E3-3) on the consistent
  CKG6800 chain, with an [ASSUMED] Z-axis error model (20 um/m accumulated lead error and a
  3 um lead-periodic error of a 10 mm-lead Z screw, semi-closed): the lead error vs Z, its
  accumulated part and max fluctuation, semi- against full-closed loop.  The paper's measured
  values need its machine; only the identities are compared.

Usage::

    python experiments/reproduce_xu_lead_error.py --out out/xu_lead
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from controllers.monitoring.builtin_sensors import (  # noqa: E402
    lead_error_metrics,
    lead_error_mm,
    thread_z_feed_mm_min,
)
from controllers.monitoring.machine_kinematics import ckg6800_chain  # noqa: E402
from plants.axis.axis_errors import AxisErrorParams, table_error_mm  # noqa: E402

TABLE_1 = [(250, 10, 25), (400, 16, 25), (500, 10, 50), (1000, 40, 25), (1250, 50, 25)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    print(f"{'Table 1 row (lead, n_C)':28s} {'printed v_z':>12s} {'L n_C':>8s} {'residual':>9s}")
    values = []
    for vz, lead, nc in TABLE_1:
        w = float(thread_z_feed_mm_min(lead, nc))
        values.append(w - vz)
        print(f"{f'{lead} mm, {nc} r/min':28s} {vz:12d} {w:8.0f} {w - vz:9.0f}")

    lead, nc = 40.0, 18.0
    c = np.linspace(0.0, 2 * math.pi * 700.0 / lead, 70001)  # 700 mm of thread
    z_cmd = 2500.0 + lead * c / (2 * math.pi)
    axis = AxisErrorParams(screw_lead_mm=10.0, accumulated_lead_error_um_per_m=20.0,
                           periodic_error_um=3.0)
    out = {}
    for mode in ("semi_closed", "full_closed"):
        z_real = z_cmd + table_error_mm(axis, z_cmd, mode=mode)
        pose = ckg6800_chain().tool_in_workpiece({"C": c, "X": np.zeros_like(c), "Z": z_real})
        e = lead_error_mm(pose[:, 2, 3], c, lead, 2500.0)
        m = lead_error_metrics(z_real, e)
        out[mode] = m
        print(f"{mode:12s}: accumulated {1e3 * m.accumulated_mm:7.2f} um over 700 mm, "
              f"max fluctuation {1e3 * m.fluctuation_mm:6.2f} um (v_z = {lead * nc:.0f} mm/min)")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        with open(args.out / "validation.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([f"H3-02_residual_row{i + 1}" for i in range(5)]
                       + ["H3-03_semi_closed_um", "H3-06_full_closed_fluctuation_um"])
            w.writerow(values + [1e3 * out["semi_closed"].accumulated_mm,
                                 1e3 * out["full_closed"].fluctuation_mm])
        print(f"wrote {args.out / 'validation.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
