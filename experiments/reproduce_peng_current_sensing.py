"""Reproduce Peng's current sensing (seed 000, Sec. 3.2-3.4): the feed drive as a force sensor.

* nut efficiency and torque factor (3.34), L680;
* inverse-model estimator coefficients (3.40) with B = 0.196 (L730; the printed coefficients
  come from a parameter variant, spec O-7: their W-coefficients sum to -0.238, not -0.196);
* I_a settling for the ramp X_r = 1000 counts/s (Fig. 3.15, spec O-19) and for a torque
  step (Fig. 3.16), L846-L848 (2 % settling);
* steady currents (3.54), (3.58);
* current-sensor bandwidth (3.64), L971.

Prints "printed vs workbench vs residual"; with ``--out DIR`` writes ``DIR/validation.csv``.

Usage::

    python experiments/reproduce_peng_current_sensing.py --out out/peng_current
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from controllers.axis.lead_lag import LeadLagParams  # noqa: E402
from controllers.monitoring.servo_force_sensing import (  # noqa: E402
    current_sensor_tf,
    gain_bandwidth_rad_s,
    inverse_model_coefficients,
    steady_currents_A,
)
from plants.axis.servo_axis import ServoAxisParams  # noqa: E402

T = 1e-3


def settling_time_s(tf, ramp: bool = False) -> float:  # noqa: ANN001
    """2 % settling time of the step (or ramp) response of ``tf``."""
    import control

    sys_ = tf * control.tf([1.0], [1.0, 0.0]) if ramp else tf
    t = np.arange(0.0, 1.0, 1e-4)
    _, y = control.step_response(sys_, t)
    y = np.squeeze(y)
    final = y[-1]
    outside = np.flatnonzero(np.abs(y - final) > 0.02 * abs(final))
    return float(t[outside[-1] + 1]) if outside.size else 0.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)

    axis = ServoAxisParams()
    ll = LeadLagParams()
    c = inverse_model_coefficients(ServoAxisParams(viscous_friction_Nm_s_rad=0.196)
                                   .velocity_loop, T)
    tf_t = current_sensor_tf(axis, ll, T)
    tf_r = current_sensor_tf(axis, ll, T, "reference")
    bw_hz = gain_bandwidth_rad_s(tf_t) / (2 * math.pi)
    i_ar, i_ac = steady_currents_A(axis, 1000.0, 1.0)
    rows = [
        # (id, quantity, printed (None: not printed), workbench, source line)
        ("H0-11", "nut efficiency nu [-]", 0.89, axis.nut_efficiency, "L680"),
        ("H0-12", "torque factor p/(2 pi nu) [N m/N]", 9.0e-4,
         axis.nut_model_force_to_torque_m, "L680"),
        ("H0-13_c1", "c1 [N m/A], B = 0.196", 0.1643, c[0], "L730"),
        ("H0-13_c2", "c2 [N m s/rad]", -3.6405, c[1], "L730"),
        ("H0-13_c3", "c3 [N m/A]", 0.1357, c[2], "L730"),
        ("H0-13_c4", "c4 [N m s/rad]", 3.4026, c[3], "L730"),
        ("H0-13_sum_I", "c1 + c3 = K_t [N m/A]", 0.1643 + 0.1357, c[0] + c[2], "L730"),
        ("H0-13_sum_W", "c2 + c4 = -B [N m s/rad]", -3.6405 + 3.4026, c[1] + c[3], "L730"),
        ("H0-14_ramp", "I_a settling, ramp X_r [s]", 0.100, settling_time_s(tf_r, True), "L846"),
        ("H0-14_torque", "I_a settling, T_c step [s]", 0.050, settling_time_s(tf_t), "L848"),
        ("H0-15", "I_ar at 1000 counts/s [A]", None, i_ar, "(3.54)"),
        ("H0-16", "I_ac per N m [A]", None, i_ac, "(3.58)"),
        ("H0-19", "current-sensor bandwidth [Hz]", 120.0, bw_hz, "L971"),
    ]
    print(f"{'quantity':36s} {'printed':>10s} {'workbench':>11s} {'residual':>10s}  source")
    for _, name, printed, value, src in rows:
        p = f"{printed:10.4g}" if printed is not None else f"{'-':>10s}"
        r = f"{value - printed:10.3g}" if printed is not None else f"{'-':>10s}"
        print(f"{name:36s} {p} {value:11.5g} {r}  {src}")
    print("note: the printed c1..c4 come from a parameter variant (spec O-7); the workbench "
          "uses App. A")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        with open(args.out / "validation.csv", "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([r[0] for r in rows])
            w.writerow([r[3] for r in rows])
        print(f"wrote {args.out / 'validation.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
