"""Briquez, Sandoz & Zaquini (seed 004): restricted state control on HSC milling machines.

Computed from the printed inputs only (spec §4.2): the Table 1 formulas against the roots of
Eq. (2), the example oscillator's step (Fig. 2), the sampling conditions (4)/(5), the noise of
double differentiation of the 0.2 um scale (method c), and the K_v limits of the sampled loop
with and without acceleration feedback on the Huron and Bokoe presets.  Printed values are
shown beside the workbench's where the paper states them as numbers; its K_v gain claims are
inconsistent (O4-3) and are held out.

``python experiments/reproduce_briquez_rsc.py [--out DIR]`` prints the table and, with
``--out``, writes ``DIR/validation.csv`` (a header of validation IDs, one row of values).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

import control
import numpy as np

from acc.design import axis_analysis as aa
from acc.output import validation_report
from controllers.axis.state_control import StateControlParams
from plants.axis.oscillating_axis import OscillatingAxisParams, boko_vh4_12, huron_kx10

Row = tuple[str, str, float, float | None, str]


def table1_rows() -> list[Row]:
    """H4-01/02: the example oscillator (L80): w_n = 251 rad/s, zeta = 0.22, K_3 = 0.0022."""
    f0, zeta, k3 = 251 / (2 * math.pi), 0.22, 0.0022
    t1 = aa.rsc_table1(f0, zeta, 0.0, k3)
    roots = np.roots(aa.rsc_transfer_function(f0, zeta, 0.0, k3).den[0][0])
    wn_roots = float(abs(roots[0]))
    zeta_roots = float(-roots[0].real / abs(roots[0]))
    rows: list[Row] = [
        ("H4-01_wnG", "Table 1 w_nG (example oscillator)", t1["natural_frequency_rad_s"],
         None, "rad/s"),
        ("H4-01_wn_roots", "w_nG from the roots of Eq. (2)", wn_roots, None, "rad/s"),
        ("H4-01_zetaG", "Table 1 zeta_G", t1["damping"], None, "-"),
        ("H4-01_zeta_roots", "zeta_G from the roots of Eq. (2)", zeta_roots, None, "-"),
    ]
    for label, gain in (("A", 0.0), ("B", k3)):
        t = np.linspace(0.0, 0.2, 200_001)  # 1 us grid: the peak's time is resolved
        info = control.step_info(aa.rsc_transfer_function(f0, zeta, 0.0, gain), T=t)
        rows.append((f"H4-02_overshoot_{label}", f"Fig. 2 ({label}) step overshoot",
                     float(info["Overshoot"]), None, "%"))
    return rows


def sampling_rows() -> list[Row]:
    """H4-03: condition (4) f_0Me < 1/(10 T) at 4 and 2 ms, condition (5) vs 400 Hz."""
    rows: list[Row] = []
    for period in (0.004, 0.002):
        c = aa.sampling_conditions(42.0, period, 400.0)
        rows.append((f"H4-03_limit_{round(1e3 * period)}ms", f"1/(10 T) at T = {1e3 * period:g} ms",
                     c["sampling_limit_Hz"], None, "Hz"))
        rows.append((f"H4-03_cond4_{round(1e3 * period)}ms", "condition (4) holds (1 = yes)",
                     float(c["condition_4"]), None, "-"))
    return rows


def noise_rows() -> list[Row]:
    """H4-04..07: method c on the 0.2 um scale at T_pC = 2 ms."""
    q_mm, period = 0.2e-3, 0.002
    sigma = aa.double_difference_noise_std(q_mm, period)  # mm/s^2
    return [
        ("H4-04", "velocity resolution q/T", q_mm / period, None, "mm/s"),
        ("H4-05", "acceleration noise q/(sqrt2 T^2)", sigma / 1e3, None, "m/s^2"),
        ("H4-06", "share of that noise above 50 Hz",
         aa.double_difference_noise_share_above(50.0, period), None, "-"),
        ("H4-07", "equivalent path noise K_3p sigma (K_3p = 0.00584 mm/(m/s^2))",
         1e3 * 0.00584 * sigma / 1e3, None, "um"),
    ]


def kv_rows() -> list[Row]:
    """H4-08..10: sampled K_v limits with and without acceleration feedback."""
    rows: list[Row] = []
    huron = replace(huron_kx10(), scale_resolution_um=0.0)
    period = 0.002
    plain = StateControlParams(source="none", acceleration_delay_samples=0)
    rsc = StateControlParams(source="observer", injection="position_reference",
                             acceleration_offset_gain_mm_per_m_s2=0.00584,
                             acceleration_delay_samples=1)
    without = aa.kv_limits(huron, plain, period, kv_max_1_s=300.0, grid=600)
    with_rsc = aa.kv_limits(huron, rsc, period, kv_max_1_s=300.0, grid=600)
    rows += [
        ("H4-09_without", "Huron K_v limit, P loop (2 ms)", without.stability_limit_1_s, None,
         "1/s"),
        ("H4-09_with", "Huron K_v limit, RSC observer, K_3p = 0.00584",
         with_rsc.stability_limit_1_s, None, "1/s"),
        ("H4-09_factor", "Huron K_v gain factor",
         with_rsc.stability_limit_1_s / without.stability_limit_1_s, None, "-"),
    ]
    raised = replace(plain, position_gain_1_s=0.99 * with_rsc.stability_limit_1_s)
    rows.append(("H4-10", "spectral radius of the P loop at the RSC limit (> 1: unstable)",
                 aa.spectral_radius(aa.rsc_closed_loop(huron, raised, period)), None, "-"))
    boko: OscillatingAxisParams = replace(boko_vh4_12(), scale_resolution_um=0.0)
    b_without = aa.kv_limits(boko, plain, period, kv_max_1_s=300.0, grid=600)
    b_rsc = replace(rsc, observer_frequency_Hz=21.0, observer_damping=0.1)
    b_with = aa.kv_limits(boko, b_rsc, period, kv_max_1_s=300.0, grid=600)
    rows += [
        ("H4-08_without", "Bokoe K_v limit, P loop", b_without.stability_limit_1_s, None, "1/s"),
        ("H4-08_with", "Bokoe K_v limit, RSC observer", b_with.stability_limit_1_s, None, "1/s"),
        ("H4-08_factor", "Bokoe K_v gain factor",
         b_with.stability_limit_1_s / b_without.stability_limit_1_s, None, "-"),
    ]
    accel = replace(rsc, source="accelerometer", accelerometer_bandwidth_Hz=100.0)
    a_with = aa.kv_limits(huron, accel, period, kv_max_1_s=300.0, grid=600)
    rows += [
        ("H4-11", "Huron K_v limit, RSC with a 100 Hz accelerometer (noise-free, linear)",
         a_with.stability_limit_1_s, None, "1/s"),
        ("H4-12", "largest K_v gain factor of the presets",
         max(with_rsc.stability_limit_1_s / without.stability_limit_1_s,
             b_with.stability_limit_1_s / b_without.stability_limit_1_s), None, "-"),
    ]
    return rows


def quantities() -> list[Row]:
    """Every row, in validation-ID order."""
    return table1_rows() + sampling_rows() + noise_rows() + kv_rows()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    print(validation_report(quantities(), args.out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
