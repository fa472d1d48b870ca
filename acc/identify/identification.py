"""From measured records to the scenario's plant: the whole identification in one call.

:func:`identify` takes the records of a machine (feed-drive tests in air and cutting tests
at each depth, in any number of logs) and returns an :class:`Identification`:

1. the feed drive, fitted on every record with a measured velocity
   (:mod:`acc.identify.feed_drive_fit`: Eq. 6 or a rate-limited planner);
2. its measured frequency response on the air records (per tone when the stepped-sine
   design is given and found in the log, else Welch), with coherence, checked against the
   fitted model (:mod:`acc.identify.frequency_response`);
3. ``K2`` and ``p2`` of every stretch cut at one depth (:mod:`acc.identify.cutting_fit`),
   driven by the identified drive's velocity, and the table pooled by radial depth;
4. the nominal plant (Eq. 9): the drive with the middle depth's row (the paper's choice,
   its 3 mm row of three).

:meth:`Identification.scenario_sections` gives ``[feed_drive]``, ``[nominal_plant]`` and
``[force_process]`` in the keys of ``experiments/kim_chung_2001.toml``
(:mod:`acc.identify.scenario_sections` writes them as TOML, a runnable scenario and replays).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from acc.identify.checks import MIN_COHERENCE, IdentificationError, check_length
from acc.identify.cutting_fit import CuttingFit, CutVelocity, ProcessTable, fit_cut, process_table
from acc.identify.excitation import Excitation, align, tone_windows
from acc.identify.feed_drive_fit import (
    MAX_DEAD_TIME_S,
    FeedDriveFit,
    fit_feed_drive,
    sampled_lag_frequency_response,
)
from acc.identify.frequency_response import (
    FrequencyResponse,
    stepped_sine_response,
    welch_response,
)
from acc.identify.measurement import Record
from acc.identify.output_error import one_blas_thread

CUT_VELOCITIES = ("model", "measured")
#: Band of the Welch FRF without an excitation design [Hz] (Kim & Chung's 0.2-8 Hz).
DEFAULT_BAND_HZ = (0.2, 8.0)
#: Share of the coherent frequencies outside the model's interval above which it is warned [-].
FRF_MISFIT_SHARE = 0.2


@dataclass(frozen=True)
class IdentifySettings:
    """How :func:`identify` ran (reported and written with the results).

    Attributes
    ----------
    drive_model : {"auto", "lag", "rate_limited"}
    cut_velocity : {"model", "measured"}
        What drives the force model (:class:`acc.identify.cutting_fit.CutVelocity`).
    lowpass_hz : float
        Force sensor's low-pass in the cutting model [Hz] (0 = none).
    min_coherence : float
    confidence : float
    max_dead_time_s : float
    velocity_delay_s : float
        The velocity measurement's own delay [s] (half the servo period for a backward
        difference of positions), subtracted from the fitted dead time.
    """

    drive_model: str = "auto"
    cut_velocity: str = "model"
    lowpass_hz: float = 0.0
    min_coherence: float = MIN_COHERENCE
    confidence: float = 0.95
    max_dead_time_s: float = MAX_DEAD_TIME_S
    velocity_delay_s: float = 0.0

    def __post_init__(self) -> None:
        if self.cut_velocity not in CUT_VELOCITIES:
            raise IdentificationError(
                f"cut velocity must be one of {', '.join(CUT_VELOCITIES)}, got "
                f"{self.cut_velocity!r}")
        if not 0 < self.confidence < 1:
            raise IdentificationError(f"confidence must be in (0, 1), got {self.confidence}")
        if not 0 <= self.min_coherence <= 1:
            raise IdentificationError(f"min coherence must be in [0, 1], got {self.min_coherence}")
        if not self.lowpass_hz >= 0:
            raise IdentificationError(f"the sensor low-pass must be >= 0 Hz, got {self.lowpass_hz}")
        if not self.velocity_delay_s >= 0:
            raise IdentificationError(
                f"the velocity measurement's delay must be >= 0 s, got {self.velocity_delay_s}")
        if not self.max_dead_time_s > 0:
            raise IdentificationError(f"max dead time must be > 0 s, got {self.max_dead_time_s}")


@dataclass(frozen=True, eq=False)
class CutRecord:
    """One stretch cut at one depth: the data, what drove its model, and its fit."""

    record: Record
    velocity: CutVelocity
    fit: CuttingFit


@dataclass(frozen=True, eq=False)
class Identification:
    """Everything identified from a machine's records.

    Attributes
    ----------
    drive : FeedDriveFit
    drive_records : tuple of Record
        The records the drive was fitted on, in fit order.
    responses : tuple of FrequencyResponse
        Measured FRFs (one per air record).
    cuts : tuple of CutRecord
    table : ProcessTable or None
        None without cutting records.
    warnings : tuple of str
        Every warning of the fits and checks, each a sentence naming its record.
    notes : tuple of str
        What was done to the logs (resampling, column choices, alignment).
    settings : IdentifySettings
    """

    drive: FeedDriveFit
    drive_records: tuple[Record, ...]
    responses: tuple[FrequencyResponse, ...]
    cuts: tuple[CutRecord, ...]
    table: ProcessTable | None
    warnings: tuple[str, ...]
    notes: tuple[str, ...]
    settings: IdentifySettings

    def nominal_row(self) -> Any:
        """The process table's nominal row (None without cuts)."""
        return None if self.table is None else self.table.nominal_row()

    def scenario_sections(self, plant_step_s: float = 0.001) -> dict[str, dict[str, Any]]:
        """``[feed_drive]``, ``[nominal_plant]`` and (with cuts) ``[force_process]``.

        Parameters
        ----------
        plant_step_s : float
            The scenario's plant step [s]: the dead time is rounded to whole steps of it
            (a scenario's dead time is a delay line of whole steps).
        """
        a = round(self.drive.bandwidth_rad_s, 4)
        ell = round(self.drive.dead_time_for_step_s(plant_step_s), 9)
        out: dict[str, dict[str, Any]] = {
            "feed_drive": {"bandwidth_rad_s": a, "dead_time_s": ell},
            "nominal_plant": {"bandwidth_rad_s": a, "dead_time_s": ell},
        }
        if self.table is not None:
            row = self.table.nominal_row()
            out["nominal_plant"].update(k2_N_min_per_mm_s=round(row.k2_N_min_per_mm_s, 6),
                                        p2_rad_s=round(row.p2_rad_s, 6))
            out["force_process"] = self.table.section()
        return out

    def plant_transfer_function(self, radial_depth_mm: float, pade_order: int = 5) -> Any:
        """Eq. (8) at one identified depth, ``a K2 e^{-Ls} / ((s + a)(s - p2))``, the delay
        as a Padé approximant of ``pade_order`` (python-control TransferFunction)."""
        if self.table is None:
            raise IdentificationError("no cutting records were identified")
        rows = {r.radial_depth_mm: r for r in self.table.rows}
        if radial_depth_mm not in rows:
            raise IdentificationError(
                f"no identified row at {radial_depth_mm} mm (rows: "
                f"{', '.join(f'{d:g}' for d in rows)})")
        import control

        row = rows[radial_depth_mm]
        process = control.tf([row.k2_N_min_per_mm_s], [1.0, -row.p2_rad_s])
        return self.drive.transfer_function(pade_order) * process


def _frequency_responses(
    recs: Sequence[Record], drive: FeedDriveFit, excitation: Excitation | None,
    settings: IdentifySettings, warnings: list[str], notes: list[str],
) -> list[FrequencyResponse]:
    out = []
    for r in recs:
        if excitation is not None and excitation.tones:
            offset = align(r, excitation)
            notes.append(f"{r.source}: the stepped-sine schedule starts at t = {offset:.4g} s")
            frf = stepped_sine_response(r, tone_windows(excitation, offset))
        else:
            lo, hi = excitation.band_hz if (excitation and excitation.band_hz) else DEFAULT_BAND_HZ
            band = (max(lo, 4.0 / r.duration_s), min(hi, 0.25 / r.sample_time_s))
            frf = welch_response(r, band)
        good = frf.coherent(settings.min_coherence)
        if not np.any(good):
            raise IdentificationError(
                f"{r.source}: no frequency of the response reaches coherence "
                f"{settings.min_coherence:g} (best {frf.coherence.max():.2f}): noise or "
                "non-linearity dominates; excite with a larger amplitude or log longer"
            )
        if not np.all(good):
            bad = frf.frequency_hz[~good]
            warnings.append(
                f"{r.source}: coherence below {settings.min_coherence:g} at {len(bad)} of "
                f"{len(good)} frequencies ({', '.join(f'{f:.3g}' for f in bad[:8])}"
                f"{'...' if len(bad) > 8 else ''} Hz): those points are unreliable"
            )
        model = sampled_lag_frequency_response(
            frf.frequency_hz, r.sample_time_s, drive.bandwidth_rad_s, drive.measured_dead_time_s,
            drive.dc_gain)
        # 2 % floor: Welch's H1 is biased by about L / segment (leakage of the delay)
        off = np.abs(frf.response - model) > 1.96 * np.maximum(frf.relative_std, 0.02) * np.abs(
            frf.response)
        share = float(np.mean(off[good])) if np.any(good) else 0.0
        if share > FRF_MISFIT_SHARE and drive.model == "lag":
            warnings.append(
                f"{r.source}: the fitted lag lies outside the measured response's interval at "
                f"{100 * share:.0f} % of the coherent frequencies: the drive is not a first-order "
                "lag with dead time over this band (see bode.png)"
            )
        out.append(frf)
    return out


def identify(
    records: Sequence[Record],
    *,
    excitation: Excitation | None = None,
    settings: IdentifySettings | None = None,
) -> Identification:
    """Identify the feed drive and the cutting process from a machine's records.

    Parameters
    ----------
    records : sequence of Record
        Air and cutting records (:func:`acc.identify.measurement.read_log`).  A record with a
        force but no known radial depth is refused; one without force or depth is an air
        record.
    excitation : Excitation, optional
        The schedule played (:func:`acc.identify.excitation.read_excitation`): its tones
        give the per-tone FRF, its band the Welch FRF's.
    settings : IdentifySettings, optional

    Returns
    -------
    Identification

    Raises
    ------
    IdentificationError
        One line on what the data cannot support (:mod:`acc.identify.checks`).

    Notes
    -----
    BLAS runs on one thread inside (restored on return): the fits are many small matrix
    products, which multi-threaded BLAS makes slower on a busy machine
    (:mod:`acc.engine.threads`).
    """
    with one_blas_thread():
        return _identify(records, excitation, settings or IdentifySettings())


def _identify(
    records: Sequence[Record], excitation: Excitation | None, settings: IdentifySettings
) -> Identification:
    if not records:
        raise IdentificationError("no records to identify from")
    warnings: list[str] = []
    notes: list[str] = []
    for r in records:
        check_length(r.n_samples, r.duration_s, r.source)
        notes += [f"{r.source}: {n}" for n in r.notes]
        if r.force_N is not None and np.all(np.isnan(r.radial_depth_mm)):
            force = np.abs(r.force_N)
            if np.max(force) > 0:
                raise IdentificationError(
                    f"{r.source}: the record has a force but no radial depth of cut: give a "
                    "radial_depth_mm column or --radial-depth-mm (0 for an air cut)"
                )
    drive_records = [r for r in records if r.feed_velocity_mm_min is not None]
    drive = fit_feed_drive(drive_records, model=settings.drive_model,
                           confidence=settings.confidence,
                           max_dead_time_s=settings.max_dead_time_s,
                           velocity_delay_s=settings.velocity_delay_s)
    warnings += [f"feed drive: {w}" for w in drive.warnings]
    air = [r for r in drive_records if not r.cuts()]
    responses = _frequency_responses(air or drive_records, drive, excitation, settings, warnings,
                                     notes)
    cuts = []
    for r in records:
        for start, stop in r.cuts():
            depth = r.radial_depth_mm[start]
            axial = r.axial_depth_mm[start]
            label = f"{r.source} @ {depth:g} mm" + (
                f" x {axial:g} mm" if np.isfinite(axial) else "")
            piece = r.piece(start, stop, label)
            index = next((i for i, d in enumerate(drive_records) if d is r), None)
            source = "drive model" if settings.cut_velocity == "model" else "measured"
            velocity = CutVelocity(source, r, start, stop, drive, index)
            fit = fit_cut(piece, velocity=velocity, lowpass_hz=settings.lowpass_hz,
                          confidence=settings.confidence)
            warnings += [f"{label}: {w}" for w in fit.warnings]
            cuts.append(CutRecord(piece, velocity, fit))
    table = None
    if cuts:
        table = process_table([c.fit for c in cuts], settings.confidence)
        warnings += [f"process table: {w}" for w in table.warnings]
    return Identification(drive, tuple(drive_records), tuple(responses), tuple(cuts), table,
                          tuple(warnings), tuple(notes), settings)


__all__ = [
    "CUT_VELOCITIES",
    "DEFAULT_BAND_HZ",
    "FRF_MISFIT_SHARE",
    "CutRecord",
    "IdentifySettings",
    "Identification",
    "identify",
]
