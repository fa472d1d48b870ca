"""Identification: from a machine's measurements to the scenario's plant.

``acc excite`` designs the test (:mod:`acc.identify.excitation`), the CNC plays it, and
``acc identify`` turns the logs (:mod:`acc.identify.measurement`) into the feed drive
(:mod:`acc.identify.feed_drive_fit`, with its measured frequency response,
:mod:`acc.identify.frequency_response`), the cutting process per depth
(:mod:`acc.identify.cutting_fit`) and the scenario's sections
(:mod:`acc.identify.scenario_sections`), with a report (:mod:`acc.identify.report`) and
figures (:mod:`acc.identify.plots`).  What the data cannot support is refused or warned
(:mod:`acc.identify.checks`); intervals come from :mod:`acc.identify.output_error`.

Python API::

    from acc.identify import identify, read_log
    ident = identify([read_log("air.csv"), read_log("cut_3mm.csv", radial_depth_mm=3.0)])
    ident.drive.transfer_function()        # control.TransferFunction, delay as Pade
    ident.scenario_sections()              # [feed_drive], [nominal_plant], [force_process]
"""

from __future__ import annotations

from acc.identify.checks import IdentificationError
from acc.identify.cutting_fit import CuttingFit, ProcessTable, fit_cut, process_table
from acc.identify.excitation import (
    Excitation,
    OverrideLimits,
    chirp,
    feed_steps,
    prbs,
    read_excitation,
    stepped_sines,
)
from acc.identify.feed_drive_fit import FeedDriveFit, fit_feed_drive
from acc.identify.frequency_response import (
    FrequencyResponse,
    stepped_sine_response,
    welch_response,
)
from acc.identify.identification import Identification, IdentifySettings, identify
from acc.identify.measurement import Record, read_log, record_from_arrays

__all__ = [
    "CuttingFit",
    "Excitation",
    "FeedDriveFit",
    "FrequencyResponse",
    "Identification",
    "IdentificationError",
    "IdentifySettings",
    "OverrideLimits",
    "ProcessTable",
    "Record",
    "chirp",
    "feed_steps",
    "fit_cut",
    "fit_feed_drive",
    "identify",
    "prbs",
    "process_table",
    "read_excitation",
    "read_log",
    "record_from_arrays",
    "stepped_sine_response",
    "stepped_sines",
    "welch_response",
]
