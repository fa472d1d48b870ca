"""How well acc identify recovers known plants: the figures quoted in docs/identification.md.

Uses the independent oracle of ``tests/test_identification.py`` (the exact sampled drive and
force process, a 17-bit encoder with backward-difference velocity, 5 N force noise through a
20 Hz low-pass, +-1 ms sampling jitter on a 10 ms log) and prints, over ``--seeds`` seeds:

* the feed drive from a 30 s PRBS (Eq. 6 and two other drives): worst error of a [%] and L
  [log samples];
* K2 and p2 per depth (Table 1 and a 5 mm row of other values) from one PRBS in air and one
  21 s feed-step cut per depth: worst and mean error [%];
* interval coverage (95 %) of a, L, K2, p2 from feed-step cuts alone at L = 9.4 samples, and
  the estimates' spread over the mean reported standard deviation;
* the time to identify a 60 s record logged at 100 Hz and at 1 kHz.

Usage (from the repository root)::

    python experiments/identification_example/recovery_study.py --seeds 20
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))

import test_identification as oracle  # noqa: E402

from acc.identify import fit_cut, fit_feed_drive, identify, record_from_arrays  # noqa: E402
from acc.identify.cutting_fit import CutVelocity  # noqa: E402


def drive_recovery(seeds: int) -> None:
    print("feed drive from a 30 s PRBS (10 ms log): worst |error| over seeds")
    for a, ell in (oracle.EQ6, (50.0, 0.047), (12.0, 0.23)):
        ea, el = [], []
        for seed in range(seeds):
            rng = np.random.default_rng(1000 + seed)
            rec = oracle.log_record(oracle.prbs_override(), rng, a, ell)
            fit = fit_feed_drive([rec], velocity_delay_s=oracle.VELOCITY_DELAY_S)
            ea.append(fit.bandwidth_rad_s / a - 1)
            el.append((fit.dead_time_s - ell) / oracle.LOG_S)
        print(f"  a = {a:5.2f} rad/s, L = {ell:.3f} s: a {100 * np.max(np.abs(ea)):.2f} %, "
              f"L {np.max(np.abs(el)):.3f} samples")


def cutting_recovery(seeds: int) -> None:
    truth = (*oracle.TABLE1, (5.0, 26.0, -7.0))
    ek, ep = [], []
    for seed in range(seeds):
        rng = np.random.default_rng(2000 + seed)
        records = [oracle.log_record(oracle.prbs_override(), rng, *oracle.EQ6)]
        for depth, k2, p2 in truth:
            records.append(oracle.log_record(oracle.steps_override(), rng, *oracle.EQ6, k2, p2,
                                             depth, source=f"cut {depth:g}"))
        ident = identify(records, settings=oracle.SETTINGS)
        ek.append([r.k2_N_min_per_mm_s / t[1] - 1 for r, t in zip(ident.table.rows, truth,
                                                                     strict=True)])
        ep.append([r.p2_rad_s / t[2] - 1 for r, t in zip(ident.table.rows, truth, strict=True)])
    ek, ep = 100 * np.array(ek), 100 * np.array(ep)
    print("cutting process (Table 1 and a 5 mm row): worst / mean error over seeds [%]")
    for j, (depth, k2, p2) in enumerate(truth):
        print(f"  {depth:g} mm (K2 {k2:g}, p2 {p2:g}): K2 {np.max(np.abs(ek[:, j])):.2f} / "
              f"{np.mean(ek[:, j]):+.2f}, p2 {np.max(np.abs(ep[:, j])):.2f} / "
              f"{np.mean(ep[:, j]):+.2f}")


def coverage(seeds: int) -> None:
    a, ell, k2, p2 = 29.33, 0.094, 12.57, -3.75
    rows = []
    for seed in range(seeds):
        rng = np.random.default_rng(100 + seed)
        cut = oracle.log_record(oracle.steps_override(), rng, a, ell, k2, p2, 3.0)
        drive = fit_feed_drive([cut], model="lag", velocity_delay_s=oracle.VELOCITY_DELAY_S)
        fit = fit_cut(cut, velocity=CutVelocity("drive model", cut, 0, cut.n_samples, drive, 0),
                      lowpass_hz=oracle.LOWPASS_HZ)
        rows.append([(drive.bandwidth_rad_s, drive.bandwidth_interval_rad_s, a),
                     (drive.dead_time_s, drive.dead_time_interval_s, ell),
                     (fit.k2_N_min_per_mm_s, fit.k2_interval, k2),
                     (fit.p2_rad_s, fit.p2_interval, p2)])
    print("95 % intervals from feed-step cuts alone: coverage, spread / reported sd")
    for j, name in enumerate(("a", "L", "K2", "p2")):
        v = np.array([r[j][0] for r in rows])
        lo = np.array([r[j][1][0] for r in rows])
        hi = np.array([r[j][1][1] for r in rows])
        t = rows[0][j][2]
        print(f"  {name:2s}: {np.mean((lo <= t) & (t <= hi)):.2f}, "
              f"{v.std(ddof=1) / np.mean((hi - lo) / 3.92):.2f}")


def speed() -> None:
    print("time to identify a 60 s PRBS record (drive, planner, FRF)")
    for log_s in (0.01, 0.001):
        rng = np.random.default_rng(0)
        rec = oracle.log_record(oracle.prbs_override(60.0), rng, *oracle.EQ6, log_s=log_s)
        identify([rec])  # the first call compiles the planner's loop
        t0 = time.perf_counter()
        identify([record_from_arrays(rec.time_s, rec.drive_input_mm_min,
                                     feed_velocity_mm_min=rec.feed_velocity_mm_min)])
        print(f"  {rec.n_samples} samples at {1000 * log_s:g} ms: "
              f"{time.perf_counter() - t0:.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=20)
    args = parser.parse_args()
    drive_recovery(args.seeds)
    cutting_recovery(args.seeds)
    coverage(2 * args.seeds)
    speed()


if __name__ == "__main__":
    main()
