"""Reproduce Kim & Chung Figs. 2-6 in the workbench: geometric model, currents, depth of cut.

Fig. 2  average forces versus radial and axial depth of cut
Fig. 3  model against "measured" averages (noisy sampled forces) at 140 and 280 mm/min
Fig. 4  feed and tangential force estimated from feed and spindle motor currents
Fig. 5  (a) immersion quantities versus R_r = a_e / R, (b) tangential force per mm of axial
        depth versus R_r (the axial-depth interpolation)
Fig. 6  identified versus true radial and axial depth over a cut whose depth changes, and
        the normal force the identified depths predict

The paper's coefficients are not published; the defaults of
:class:`plants.cutting_coefficients.CuttingCoefficients` (Al7075, textbook values) are
used, so magnitudes differ from the paper while shapes compare.  Writes ``fig2.png`` ..
``fig6.png`` and ``metrics.csv`` into ``--out``.

Usage::

    python experiments/reproduce_kim_chung_figs_2_6.py --out out/kim_chung_figs --seed 1
"""

from __future__ import annotations

import argparse
import csv
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from controllers.current_force_estimator import (  # noqa: E402
    feed_force_from_current,
    identify_drive_from_air_cuts,
    tangential_force_from_current,
    tooth_period_average,
)
from controllers.depth_of_cut_identification import (  # noqa: E402
    identify_depth_of_cut,
    immersion_quantity,
)
from plants.cutting_coefficients import CuttingCoefficients  # noqa: E402
from plants.end_mill_geometry import (  # noqa: E402
    EndMill,
    MillingCut,
    average_forces,
    feed_per_tooth_from_feedrate,
    forces_vs_time,
    tooth_period_s,
)
from plants.motor_drive import (  # noqa: E402
    DEFAULT_SPINDLE_MOTOR,
    BallScrew,
    ServoMotor,
    SpeedControlledDrive,
    SpindleTransmission,
)

TOOL = EndMill()
COEFFS = CuttingCoefficients()
SPINDLE_RPM = 600.0
DT_S = 1e-4
CURRENT_NOISE_A = 0.05
FORCE_NOISE_FRACTION = 0.01
MODE = "up"


def _axes(ax: Axes | None) -> Axes:
    return Figure(figsize=(6.4, 4.2), layout="constrained").add_subplot() if ax is None else ax


# ----------------------------------------------------------------------------- Fig. 2, 3
def plot_average_forces_vs_radial_depth(feedrate_mm_min: float, axial_depths_mm, ax=None) -> Axes:
    """Fig. 2a: average feed, normal and tangential forces versus radial depth."""
    ax = _axes(ax)
    ae = np.linspace(0.1, TOOL.diameter_mm, 200)
    c = float(feed_per_tooth_from_feedrate(TOOL, feedrate_mm_min, SPINDLE_RPM))
    for a, style in zip(axial_depths_mm, ("-", "--", ":"), strict=False):
        f = average_forces(TOOL, MillingCut(radial_depth_mm=ae, axial_depth_mm=a,
                                            feed_per_tooth_mm=c, mode=MODE), COEFFS)
        ax.plot(ae, f.feed_N, "C0" + style, label=f"feed, a={a:g} mm")
        ax.plot(ae, f.normal_N, "C1" + style, label=f"normal, a={a:g} mm")
        ax.plot(ae, f.tangential_N, "C2" + style, label=f"tangential, a={a:g} mm")
    ax.set(xlabel="radial depth of cut [mm]", ylabel="average force [N]",
           title=f"Average forces, {MODE}-milling, {feedrate_mm_min:g} mm/min")
    ax.legend(fontsize=6, ncol=3)
    return ax


def plot_average_forces_vs_axial_depth(feedrate_mm_min: float, radial_depths_mm, ax=None) -> Axes:
    """Fig. 2b: average resultant force versus axial depth (exactly linear)."""
    ax = _axes(ax)
    a = np.linspace(0.0, 20.0, 50)
    c = float(feed_per_tooth_from_feedrate(TOOL, feedrate_mm_min, SPINDLE_RPM))
    for ae in radial_depths_mm:
        f = average_forces(TOOL, MillingCut(radial_depth_mm=ae, axial_depth_mm=a,
                                            feed_per_tooth_mm=c, mode=MODE), COEFFS)
        ax.plot(a, f.resultant_xy_N, label=f"a_e = {ae:g} mm")
    ax.set(xlabel="axial depth of cut [mm]", ylabel="average resultant force [N]",
           title="Average force versus axial depth")
    ax.legend(fontsize=7)
    return ax


@dataclass(frozen=True)
class MeasuredAverages:
    """Simulated dynamometer averages (Fig. 3)."""

    feedrate_mm_min: float
    radial_depth_mm: np.ndarray
    model_N: np.ndarray  # (n, 3) feed, normal, tangential
    measured_N: np.ndarray  # (n, 3)


def simulate_measured_averages(feedrate_mm_min: float, rng: np.random.Generator,
                               noise_N: float = 20.0) -> MeasuredAverages:
    """Average over 20 tooth periods of sampled forces with white dynamometer noise."""
    ae = np.array([1.0, 2.0, 3.0, 4.0, 6.0, 8.0])
    n = 20 * round(tooth_period_s(TOOL, SPINDLE_RPM) / DT_S)
    t = np.arange(n) * DT_S
    cut = MillingCut(radial_depth_mm=ae[:, None], axial_depth_mm=10.0, mode=MODE,
                     spindle_speed_rpm=SPINDLE_RPM)
    inst = forces_vs_time(TOOL, cut, COEFFS, t[None, :], feedrate_mm_min=feedrate_mm_min)
    measured = np.stack([np.mean(x + noise_N * rng.standard_normal(x.shape), axis=1)
                         for x in (inst.feed_N, inst.normal_N, inst.tangential_N)], axis=1)
    avg = average_forces(TOOL, MillingCut(
        radial_depth_mm=ae, axial_depth_mm=10.0, mode=MODE,
        feed_per_tooth_mm=float(feed_per_tooth_from_feedrate(TOOL, feedrate_mm_min,
                                                             SPINDLE_RPM))), COEFFS)
    model = np.stack([avg.feed_N, avg.normal_N, avg.tangential_N], axis=1)
    return MeasuredAverages(feedrate_mm_min, ae, model, measured)


def plot_measured_vs_model(data: list[MeasuredAverages], ax=None) -> Axes:
    """Fig. 3: model lines and simulated measured averages (markers)."""
    ax = _axes(ax)
    for d, marker in zip(data, ("o", "s"), strict=False):
        for i, name in enumerate(("feed", "normal", "tangential")):
            ax.plot(d.radial_depth_mm, d.model_N[:, i], f"C{i}-")
            ax.plot(d.radial_depth_mm, d.measured_N[:, i], f"C{i}{marker}",
                    label=f"{name}, {d.feedrate_mm_min:g} mm/min")
    ax.set(xlabel="radial depth of cut [mm]", ylabel="average force [N]",
           title="Model (lines) and measured (markers) average forces")
    ax.legend(fontsize=6, ncol=2)
    return ax


# ----------------------------------------------------------------------------- Fig. 4, 6
@dataclass(frozen=True)
class CurrentCut:
    """A cut with changing depth, true forces and forces estimated from currents."""

    time_s: np.ndarray  # tooth-period centres, (m,)
    radial_depth_mm: np.ndarray  # true, per tooth period
    axial_depth_mm: np.ndarray
    true_feed_N: np.ndarray
    true_normal_N: np.ndarray
    true_tangential_N: np.ndarray
    est_feed_N: np.ndarray
    est_tangential_N: np.ndarray
    feed_per_tooth_mm: float


def _air_cut_identification(motor: ServoMotor, speeds_rad_s: np.ndarray,
                            rng: np.random.Generator):
    drive = SpeedControlledDrive(motor, 200.0, DT_S, runs=1)
    _, out = drive.simulate(np.repeat(speeds_rad_s, 2000)[None, :], 0.0)
    noisy = out.current_A + CURRENT_NOISE_A * rng.standard_normal(out.current_A.shape)
    return identify_drive_from_air_cuts(noisy, out.speed_rad_s, motor.torque_constant_Nm_A,
                                        DT_S)


def simulate_current_cut(rng: np.random.Generator, feedrate_mm_min: float = 140.0) -> CurrentCut:
    """Radial depth 2 -> 3 -> 4 mm, then axial depth 10 -> 15 mm, 0.5 s each."""
    screw, transmission = BallScrew(), SpindleTransmission()
    feed_id = _air_cut_identification(
        ServoMotor(), screw.motor_speed_rad_s(np.array([50, 200, 800, 2000, -200, -2000.0])), rng)
    spindle_id = _air_cut_identification(
        DEFAULT_SPINDLE_MOTOR,
        transmission.motor_speed_rad_s(np.array([300, 600, 1200, 2400, -600.0])), rng)
    segment = 5000
    ae = np.repeat([2.0, 3.0, 4.0, 4.0], segment)
    a = np.repeat([10.0, 10.0, 10.0, 15.0], segment)
    t = np.arange(ae.size) * DT_S
    cut = MillingCut(radial_depth_mm=ae, axial_depth_mm=a, mode=MODE,
                     spindle_speed_rpm=SPINDLE_RPM)
    forces = forces_vs_time(TOOL, cut, COEFFS, t, feedrate_mm_min=feedrate_mm_min)
    feed_drive = SpeedControlledDrive(ServoMotor(), 200.0, DT_S, 1)
    _, fo = feed_drive.simulate(screw.motor_speed_rad_s(feedrate_mm_min),
                                screw.motor_torque_Nm(forces.feed_N))
    spindle_drive = SpeedControlledDrive(DEFAULT_SPINDLE_MOTOR, 200.0, DT_S, 1)
    _, so = spindle_drive.simulate(transmission.motor_speed_rad_s(SPINDLE_RPM),
                                   transmission.motor_torque_Nm(forces.spindle_torque_Nm(TOOL)))
    fi = fo.current_A + CURRENT_NOISE_A * rng.standard_normal(fo.current_A.shape)
    si = so.current_A + CURRENT_NOISE_A * rng.standard_normal(so.current_A.shape)
    est_feed = feed_force_from_current(feed_id, screw, fi, fo.speed_rad_s)[0]
    est_tang = tangential_force_from_current(spindle_id, transmission, TOOL, si,
                                             so.speed_rad_s)[0]
    m = round(tooth_period_s(TOOL, SPINDLE_RPM) / DT_S)

    def avg(x: np.ndarray) -> np.ndarray:
        return tooth_period_average(x[: est_feed.size], m)

    return CurrentCut(
        time_s=avg(t) + 0.5 * DT_S,
        radial_depth_mm=avg(ae), axial_depth_mm=avg(a),
        true_feed_N=avg(forces.feed_N), true_normal_N=avg(forces.normal_N),
        true_tangential_N=avg(forces.tangential_N),
        est_feed_N=tooth_period_average(est_feed, m),
        est_tangential_N=tooth_period_average(est_tang, m),
        feed_per_tooth_mm=float(feed_per_tooth_from_feedrate(TOOL, feedrate_mm_min,
                                                             SPINDLE_RPM)),
    )


def plot_current_estimates(data: CurrentCut, ax=None) -> Axes:
    """Fig. 4: feed and tangential forces, true and estimated from currents."""
    ax = _axes(ax)
    ax.plot(data.time_s, data.true_feed_N, "C0-", label="feed, true")
    ax.plot(data.time_s, data.est_feed_N, "C0.", label="feed, from feed current")
    ax.plot(data.time_s, data.true_tangential_N, "C2-", label="tangential, true")
    ax.plot(data.time_s, data.est_tangential_N, "C2.", label="tangential, from spindle current")
    ax.set(xlabel="time [s]", ylabel="tooth-period average force [N]",
           title=f"Forces from motor currents (noise {CURRENT_NOISE_A} A)")
    ax.legend(fontsize=7)
    return ax


def plot_immersion_quantities(ax=None) -> Axes:
    """Fig. 5a: rotated quantity q and the paper's F_x/F_t versus R_r."""
    ax = _axes(ax)
    ae = np.linspace(0.01, TOOL.diameter_mm, 400)
    for mode, style in (("up", "-"), ("down", "--")):
        f = average_forces(TOOL, MillingCut(radial_depth_mm=ae, mode=mode), COEFFS)
        q = immersion_quantity(f.feed_N, f.normal_N, f.tangential_N, COEFFS.radial_ratio)
        ax.plot(ae / TOOL.radius_mm, q, "C0" + style, label=f"q (rotated), {mode}")
        ax.plot(ae / TOOL.radius_mm, f.feed_N / f.tangential_N, "C3" + style,
                label=f"F_x / F_t, {mode}")
    ax.set(xlabel="radial immersion R_r = a_e / R", ylabel="quantity [-]",
           title="Immersion quantities")
    ax.legend(fontsize=7)
    return ax


def plot_force_per_axial_depth(ax=None) -> Axes:
    """Fig. 5b: average tangential force per mm of axial depth versus R_r."""
    ax = _axes(ax)
    ae = np.linspace(0.01, TOOL.diameter_mm, 400)
    for feed in (140.0, 280.0):
        c = float(feed_per_tooth_from_feedrate(TOOL, feed, SPINDLE_RPM))
        f = average_forces(TOOL, MillingCut(radial_depth_mm=ae, axial_depth_mm=1.0,
                                            feed_per_tooth_mm=c, mode=MODE), COEFFS)
        ax.plot(ae / TOOL.radius_mm, f.tangential_N, label=f"{feed:g} mm/min")
    ax.set(xlabel="radial immersion R_r = a_e / R",
           ylabel="tangential force per mm axial depth [N/mm]",
           title="Force change for the axial depth")
    ax.legend(fontsize=7)
    return ax


def plot_identified_depths(data: CurrentCut, estimate, ax=None) -> Axes:
    """Fig. 6: identified versus true radial and axial depth."""
    ax = _axes(ax)
    ax.plot(data.time_s, data.radial_depth_mm, "C0-", label="radial, true")
    ax.plot(data.time_s, estimate.radial_depth_mm, "C0.", label="radial, identified")
    ax.plot(data.time_s, data.axial_depth_mm, "C1-", label="axial, true")
    ax.plot(data.time_s, estimate.axial_depth_mm, "C1.", label="axial, identified")
    ax.set(xlabel="time [s]", ylabel="depth of cut [mm]",
           title="Depth of cut identified from current-estimated forces")
    ax.legend(fontsize=7)
    return ax


def identification_grid_errors(rng: np.random.Generator, samples: int = 200) -> dict[str, float]:
    """RMS identification errors over a depth grid with 1 % force noise (rotated method)."""
    ae, a = np.meshgrid(np.linspace(1.0, 16.0, 16), np.linspace(2.0, 20.0, 10))
    ae = np.repeat(ae.ravel(), samples)
    a = np.repeat(a.ravel(), samples)
    f = average_forces(TOOL, MillingCut(radial_depth_mm=ae, axial_depth_mm=a,
                                        feed_per_tooth_mm=0.05, mode=MODE), COEFFS)
    sigma = FORCE_NOISE_FRACTION * f.tangential_N
    noisy = [getattr(f, n) + sigma * rng.standard_normal(ae.size)
             for n in ("feed_N", "normal_N", "tangential_N")]
    est = identify_depth_of_cut(TOOL, COEFFS, 0.05, MODE, noisy[0], noisy[2], noisy[1])
    rel_a = est.axial_depth_mm / a - 1
    big = ae >= 3.0
    return {
        "grid_radial_rms_mm": float(np.sqrt(np.mean((est.radial_depth_mm - ae) ** 2))),
        "grid_radial_max_mm": float(np.max(np.abs(est.radial_depth_mm - ae))),
        "grid_axial_rms_rel": float(np.sqrt(np.mean(rel_a**2))),
        "grid_axial_rms_rel_ae_ge_3mm": float(np.sqrt(np.mean(rel_a[big] ** 2))),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, type=Path, help="output directory")
    parser.add_argument("--seed", type=int, default=1, help="root random seed")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(args.seed).spawn(3)]
    metrics: list[tuple[str, float, str]] = [("seed", args.seed, "-")]

    fig = Figure(figsize=(11, 4.2), layout="constrained")
    plot_average_forces_vs_radial_depth(140.0, (5.0, 10.0, 15.0), ax=fig.add_subplot(1, 2, 1))
    plot_average_forces_vs_axial_depth(140.0, (2.0, 3.0, 4.0), ax=fig.add_subplot(1, 2, 2))
    fig.savefig(args.out / "fig2.png", dpi=120)

    measured = [simulate_measured_averages(f, rngs[0]) for f in (140.0, 280.0)]
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    plot_measured_vs_model(measured, ax=fig.add_subplot())
    fig.savefig(args.out / "fig3.png", dpi=120)
    for d in measured:
        rms = float(np.sqrt(np.mean((d.measured_N - d.model_N) ** 2)))
        metrics.append((f"fig3_model_vs_measured_rms_N_{d.feedrate_mm_min:g}", rms, "N"))

    cutdata = simulate_current_cut(rngs[1])
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    plot_current_estimates(cutdata, ax=fig.add_subplot())
    fig.savefig(args.out / "fig4.png", dpi=120)
    for name, est, true in (("feed", cutdata.est_feed_N, cutdata.true_feed_N),
                            ("tangential", cutdata.est_tangential_N, cutdata.true_tangential_N)):
        err = est - true
        metrics.append((f"fig4_{name}_force_rms_error_N", float(np.sqrt(np.mean(err**2))), "N"))
        metrics.append((f"fig4_{name}_force_max_error_N", float(np.max(np.abs(err))), "N"))
        metrics.append((f"fig4_{name}_force_rms_error_rel",
                        float(np.sqrt(np.mean(err**2)) / np.mean(np.abs(true))), "-"))

    fig = Figure(figsize=(11, 4.2), layout="constrained")
    plot_immersion_quantities(ax=fig.add_subplot(1, 2, 1))
    plot_force_per_axial_depth(ax=fig.add_subplot(1, 2, 2))
    fig.savefig(args.out / "fig5.png", dpi=120)

    # only feed and tangential force come from the currents: the paper's ratio
    estimate = identify_depth_of_cut(TOOL, COEFFS, cutdata.feed_per_tooth_mm, MODE,
                                     cutdata.est_feed_N, cutdata.est_tangential_N,
                                     method="feed_tangential")
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    plot_identified_depths(cutdata, estimate, ax=fig.add_subplot(1, 2, 1))
    ax = fig.add_subplot(1, 2, 2)
    predicted = average_forces(TOOL, MillingCut(
        radial_depth_mm=estimate.radial_depth_mm, axial_depth_mm=estimate.axial_depth_mm,
        feed_per_tooth_mm=cutdata.feed_per_tooth_mm, mode=MODE), COEFFS)
    ax.plot(cutdata.time_s, cutdata.true_normal_N, "C1-", label="normal, true")
    ax.plot(cutdata.time_s, predicted.normal_N, "C1.", label="normal, from identified depths")
    ax.set(xlabel="time [s]", ylabel="average normal force [N]", title="Normal force")
    ax.legend(fontsize=7)
    fig.savefig(args.out / "fig6.png", dpi=120)
    rad_err = estimate.radial_depth_mm - cutdata.radial_depth_mm
    ax_err = estimate.axial_depth_mm - cutdata.axial_depth_mm
    normal_err = predicted.normal_N - cutdata.true_normal_N
    metrics += [
        ("fig6_radial_rms_error_mm", float(np.sqrt(np.mean(rad_err**2))), "mm"),
        ("fig6_axial_rms_error_mm", float(np.sqrt(np.mean(ax_err**2))), "mm"),
        ("fig6_normal_force_rms_error_N", float(np.sqrt(np.mean(normal_err**2))), "N"),
        ("fig6_min_identifiable_radial_depth_mm",
         float(np.max(estimate.min_identifiable_radial_depth_mm)), "mm"),
    ]
    for key, value in identification_grid_errors(rngs[2]).items():
        metrics.append((key, value, "mm" if key.endswith("_mm") else "-"))

    with open(args.out / "metrics.csv", "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(["metric", "value", "unit"])
        for row in metrics:
            writer.writerow([row[0], f"{row[1]:.6g}", row[2]])
    for row in metrics:
        print(f"{row[0]:45s} {row[1]:12.5g} {row[2]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
