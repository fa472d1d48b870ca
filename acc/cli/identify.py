"""``acc excite`` and ``acc identify``: registered into :data:`acc.cli.main.COMMANDS` on import.

``acc excite KIND --out DIR`` designs an identification test (``stepped-sines``, ``chirp``,
``prbs`` or ``feed-steps``) within the CNC's override range and the axis's acceleration, and
writes ``excitation.csv`` (``time_s, override``: the schedule to play), ``excitation.toml``
(its design, for ``acc identify --excitation``) and ``excitation.png``.

``acc identify LOG [LOG ...] --out DIR`` identifies the feed drive and the cutting process
from measured logs (:mod:`acc.identify.measurement` lists the columns; ``acc run``'s
``traces.csv`` is read as it is) and writes ``identified.toml`` (the ``[feed_drive]``,
``[nominal_plant]`` and ``[force_process]`` sections), ``scenario.toml`` (a runnable
scenario with them), ``replay_<i>.toml`` (each cut's feed steps through the identified
plant, for ``acc run``), ``report.md``, ``identification.csv``, ``frf.csv``, ``bode.png``,
``drive.png`` and ``cutting.png``.

What the data cannot support is one line ``acc: error: ...`` (exit status 2); outputs are
written all or nothing.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from acc.cli.main import COMMANDS, say

EXCITE_KINDS = {"stepped-sines": "stepped_sines", "chirp": "chirp", "prbs": "prbs",
                "feed-steps": "feed_steps"}
#: Options of ``acc excite`` that only some kinds read.
_KIND_OPTIONS = {
    "tones": ("stepped-sines",),
    "band_hz": ("stepped-sines", "chirp", "prbs"),
    "amplitude": ("stepped-sines", "chirp", "prbs"),
    "duration_s": ("chirp", "prbs"),
    "levels": ("feed-steps",),
    "dwell_s": ("feed-steps",),
}


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _non_negative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def _add_excite_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("kind", choices=list(EXCITE_KINDS), help="the test to design")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--programmed-feed-mm-min", type=_positive, default=120.0,
                   help="feed the override multiplies [mm/min] (default 120)")
    p.add_argument("--override-min", type=_non_negative, default=0.1,
                   help="the CNC's lowest override (default 0.1)")
    p.add_argument("--override-max", type=_positive, default=2.0,
                   help="the CNC's highest override (default 2.0)")
    p.add_argument("--centre-override", type=_positive, default=1.0,
                   help="override the excitation varies around (default 1.0)")
    p.add_argument("--max-acceleration-mm-s2", type=_positive, default=None,
                   help="the axis's acceleration limit [mm/s^2]: amplitudes are reduced to "
                        "stay below it (default: not checked)")
    p.add_argument("--sample-time-s", type=_positive, default=0.01,
                   help="override update period of the schedule [s] (default 0.01)")
    p.add_argument("--band-hz", type=_positive, nargs=2, metavar=("LOW", "HIGH"), default=None,
                   help="band to excite [Hz] (default 0.2 8, as Kim & Chung)")
    p.add_argument("--amplitude", type=_positive, default=None,
                   help="override amplitude (default 0.2; reduced to the linear range)")
    p.add_argument("--tones", type=int, default=None, help="stepped sines: tones (default 12)")
    p.add_argument("--duration-s", type=_positive, default=None,
                   help="chirp, prbs: length [s] (default 60)")
    p.add_argument("--levels", type=_positive, nargs="+", default=None,
                   help="feed steps: override levels (default 1.0 1.2 0.8 1.2 0.9 1.1 1.0)")
    p.add_argument("--dwell-s", type=_positive, default=None,
                   help="feed steps: time at each level [s] (default 3)")


def _cmd_excite(args: argparse.Namespace) -> int:
    from acc.cli.main import CommandError
    from acc.output import check_output_dir

    check_output_dir(args.out)
    for name, kinds in _KIND_OPTIONS.items():
        if getattr(args, name) is not None and args.kind not in kinds:
            raise CommandError(
                f"--{name.replace('_', '-')} does not apply to {args.kind} (only to "
                f"{', '.join(kinds)})")
    from acc.identify import excitation as ex

    limits = ex.OverrideLimits(
        programmed_feed_mm_min=args.programmed_feed_mm_min, override_min=args.override_min,
        override_max=args.override_max, centre_override=args.centre_override,
        max_acceleration_mm_s2=args.max_acceleration_mm_s2, sample_time_s=args.sample_time_s)
    band = tuple(args.band_hz) if args.band_hz else (0.2, 8.0)
    amp = args.amplitude if args.amplitude is not None else 0.2
    if args.kind == "stepped-sines":
        design = ex.stepped_sines(limits, band, args.tones or 12, amp)
    elif args.kind == "chirp":
        design = ex.chirp(limits, band, args.duration_s or 60.0, amp)
    elif args.kind == "prbs":
        design = ex.prbs(limits, band, args.duration_s or 60.0, amp)
    else:
        levels = tuple(args.levels) if args.levels else (1.0, 1.2, 0.8, 1.2, 0.9, 1.1, 1.0)
        design = ex.feed_steps(limits, levels, args.dwell_s or 3.0)
    from matplotlib.figure import Figure

    from acc.output import staged_directory, write_csv

    out = Path(args.out)
    with staged_directory(out) as stage:
        write_csv(stage / "excitation.csv", design.rows())
        (stage / "excitation.toml").write_text(design.to_toml(), encoding="utf-8")
        fig = Figure(figsize=(9, 3.2), layout="constrained")
        ax = fig.subplots()
        ax.step(design.time_s, design.override, where="post", lw=0.8)
        ax.axhline(limits.override_min, color="C3", ls=":", lw=0.8)
        ax.axhline(limits.override_max, color="C3", ls=":", lw=0.8)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("override [-]")
        ax.set_title(f"{args.kind}: {design.duration_s:.4g} s at {limits.sample_time_s:g} s",
                     fontsize="small")
        ax.grid(True, alpha=0.3)
        fig.savefig(stage / "excitation.png", dpi=110)
    say(args,
        f"{args.kind}: {design.duration_s:.4g} s, override "
        f"{design.override.min():.4g}..{design.override.max():.4g} around "
        f"{limits.centre_override:g} at {limits.programmed_feed_mm_min:g} mm/min"
        + (f", {len(design.tones)} tones {design.band_hz[0]:g}..{design.band_hz[1]:g} Hz"
           if design.tones else ""),
        *[f"note: {n}" for n in design.notes],
        "play: set the feedrate override to `override` at each `time_s` (held to the next row) "
        "while feeding at the programmed feed and logging time_s, the override or commanded "
        "feed, the feed velocity and (cutting tests) the force; see docs/identification.md",
        f"wrote {out}/excitation.csv, excitation.toml, excitation.png")
    return 0


def _add_identify_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("logs", nargs="+", metavar="LOG",
                   help="measured CSV logs (time_s, override or commanded_feed_mm_min, "
                        "feed_velocity_mm_min, force_N; acc run's traces.csv as it is)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--excitation", default=None,
                   help="acc excite's directory or excitation.toml (tones and band)")
    p.add_argument("--programmed-feed-mm-min", type=_positive, default=None,
                   help="feed the logs' override multiplies [mm/min] (needed without a "
                        "commanded_feed_mm_min column; default: the excitation's)")
    p.add_argument("--radial-depth-mm", type=_non_negative, nargs="+", default=None,
                   help="radial depth of each LOG (one value for all, or one per LOG; 0 = air) "
                        "where it has no radial_depth_mm column")
    p.add_argument("--axial-depth-mm", type=_positive, nargs="+", default=None,
                   help="axial depth of each LOG (one for all, or one per LOG)")
    p.add_argument("--run", type=int, default=None,
                   help="the run to read from logs with a run column (acc run's traces.csv)")
    p.add_argument("--force-lowpass-hz", type=_non_negative, default=0.0,
                   help="the force sensor's low-pass, part of the cutting model [Hz] "
                        "(default 0: none)")
    p.add_argument("--drive-model", choices=("auto", "lag", "rate_limited"), default="auto",
                   help="feed-drive model (default auto: the better fit)")
    p.add_argument("--cut-velocity", choices=("model", "measured"), default="model",
                   help="velocity driving the force model (default: the identified drive's)")
    p.add_argument("--min-coherence", type=_non_negative, default=0.8,
                   help="least coherence of a reliable FRF point (default 0.8)")
    p.add_argument("--confidence", type=_positive, default=0.95,
                   help="level of the intervals (default 0.95)")
    p.add_argument("--max-dead-time-s", type=_positive, default=1.0,
                   help="largest dead time searched [s] (default 1)")
    p.add_argument("--velocity-delay-s", type=_non_negative, default=0.0,
                   help="the velocity measurement's own delay, taken off the dead time [s] "
                        "(half the servo period for velocity from position differences; "
                        "default 0)")
    p.add_argument("--scenario", default=None,
                   help="base scenario whose other sections scenario.toml keeps")
    p.add_argument("--plant-step-s", type=_positive, default=None,
                   help="plant step the dead time is rounded to [s] (default: the base "
                        "scenario's, or 0.001)")


def _per_log(values: list[float] | None, logs: list[str], option: str) -> list[float | None]:
    from acc.cli.main import CommandError

    if values is None:
        return [None] * len(logs)
    if len(values) == 1:
        return values * len(logs)
    if len(values) != len(logs):
        raise CommandError(f"{option}: give one value or one per LOG ({len(logs)}), got "
                           f"{len(values)}")
    return list(values)


def _cmd_identify(args: argparse.Namespace) -> int:
    from acc.output import check_output_dir

    check_output_dir(args.out)
    radial = _per_log(args.radial_depth_mm, args.logs, "--radial-depth-mm")
    axial = _per_log(args.axial_depth_mm, args.logs, "--axial-depth-mm")
    from acc.identify import IdentifySettings, identify, read_excitation, read_log
    from acc.identify.plots import bode_figure, cutting_figure, drive_figure
    from acc.identify.report import frf_rows, parameter_rows, report_text
    from acc.identify.scenario_sections import (
        dumps,
        identified_scenario,
        replay_scenario,
        sections_toml,
    )
    from acc.output import staged_directory, write_csv

    excitation = read_excitation(args.excitation) if args.excitation else None
    feed = args.programmed_feed_mm_min
    if feed is None and excitation is not None:
        feed = excitation.limits.programmed_feed_mm_min
    records = [read_log(path, programmed_feed_mm_min=feed, run=args.run, radial_depth_mm=r,
                        axial_depth_mm=a) for path, r, a in zip(args.logs, radial, axial,
                                                                strict=True)]
    settings = IdentifySettings(
        drive_model=args.drive_model, cut_velocity=args.cut_velocity,
        lowpass_hz=args.force_lowpass_hz, min_coherence=args.min_coherence,
        confidence=args.confidence, max_dead_time_s=args.max_dead_time_s,
        velocity_delay_s=args.velocity_delay_s)
    ident = identify(records, excitation=excitation, settings=settings)
    base = None
    if args.scenario:
        from acc.inputs import read_toml

        base = read_toml(args.scenario, "scenario")
    step = args.plant_step_s or (float(base.get("simulation", {}).get("plant_step_s", 0.001))
                                 if base else 0.001)
    scenario_data, _ = identified_scenario(ident, base, step,
                                           source=args.scenario or "<identified>")
    replays = []
    skipped = []
    from acc.identify.checks import IdentificationError

    for i, cut in enumerate(ident.cuts):
        try:
            replays.append((i, *replay_scenario(ident, cut, step)))
        except IdentificationError as exc:
            skipped.append(str(exc))
    out = Path(args.out)
    with staged_directory(out) as stage:
        (stage / "identified.toml").write_text(sections_toml(ident, step), encoding="utf-8")
        head = ("# acc identify: " + (f"{args.scenario} with " if args.scenario else
                                      "the workbench's defaults with ")
                + "the identified [feed_drive], [nominal_plant] and [force_process]\n")
        (stage / "scenario.toml").write_text(head + dumps(scenario_data), encoding="utf-8")
        for i, data, lead in replays:
            text = (f"# acc identify: replay of {ident.cuts[i].record.source} through the "
                    f"identified plant; replay time {lead:g} s + t is the record's t\n")
            (stage / f"replay_{i}.toml").write_text(text + dumps(data), encoding="utf-8")
        (stage / "report.md").write_text(report_text(ident, step), encoding="utf-8")
        write_csv(stage / "identification.csv", parameter_rows(ident))
        write_csv(stage / "frf.csv", frf_rows(ident))
        figures = [("bode.png", bode_figure(ident)), ("drive.png", drive_figure(ident))]
        if ident.cuts:
            figures.append(("cutting.png", cutting_figure(ident)))
        for name, fig in figures:
            fig.savefig(stage / name, dpi=110)
    d = ident.drive
    lines = [
        f"feed drive: {d.model}; a = {d.bandwidth_rad_s:.4g} rad/s "
        f"[{d.bandwidth_interval_rad_s[0]:.4g}, {d.bandwidth_interval_rad_s[1]:.4g}], "
        f"L = {d.dead_time_s:.4g} s [{d.dead_time_interval_s[0]:.4g}, "
        f"{d.dead_time_interval_s[1]:.4g}] ({100 * settings.confidence:g} %)",
    ]
    if ident.table is not None:
        for r in ident.table.rows:
            lines.append(
                f"radial depth {r.radial_depth_mm:g} mm: K2 = {r.k2_N_min_per_mm_s:.4g} "
                f"[{r.k2_interval[0]:.4g}, {r.k2_interval[1]:.4g}], p2 = {r.p2_rad_s:.4g} "
                f"[{r.p2_interval[0]:.4g}, {r.p2_interval[1]:.4g}]")
    lines += [f"warning: {w}" for w in ident.warnings]
    lines += [f"no replay: {s}" for s in skipped]
    names = ["identified.toml", "scenario.toml"] + [f"replay_{i}.toml" for i, _, _ in replays]
    names += ["report.md", "identification.csv", "frf.csv"] + [n for n, _ in figures]
    lines.append(f"wrote {out}/" + ", ".join(names))
    say(args, *lines)
    return 0


COMMANDS["excite"] = ("design an identification test: an override schedule to play on the "
                      "CNC", _add_excite_args, _cmd_excite)
COMMANDS["identify"] = ("identify the feed drive and the cutting process from measured logs "
                        "and write the scenario's plant", _add_identify_args, _cmd_identify)
