"""Cutting-force coefficients of the mechanistic end-milling model, and their calibration.

The force on an axial element ``dz`` of a cutting edge at immersion angle ``phi`` is split
into a *cutting* part proportional to the instantaneous chip thickness ``h = c sin(phi)``
and an *edge* (ploughing) part that is not (Kim & Chung, Eq. 1, extended with edge terms as
in Altintas, *Manufacturing Automation*, Ch. 2)::

    dF_t = (K_tc h + K_te) dz      tangential
    dF_r = (K_rc h + K_re) dz      radial
    dF_a = (K_ac h + K_ae) dz      axial

Kim & Chung write ``dF_t = K_s h dz`` and ``dF_r = r_t dF_t``; that is the special case
``K_tc = K_s``, ``K_rc = r_t K_s`` and zero edge coefficients
(:meth:`CuttingCoefficients.from_cutting_pressure`).  Their remark that "the cutting pressure
``K_s`` can be expressed as a function of the average chip thickness" is the optional
power law ``K(h_m) = K (h_m / h_ref)^(-x)`` applied to the three cutting coefficients
(``chip_thickness_exponent`` ``x``; ``x = 0`` means constant coefficients).

Slot-cut calibration (CSV)
--------------------------
In a full-immersion slot the average forces per tooth period are affine in the feed per
tooth ``c`` (derived in :mod:`plants.end_mill_geometry`; forces exerted by the tool on the
workpiece, ``x`` along the feed, ``y`` normal to it, ``z`` along the tool axis)::

    mean F_x =  N a K_rc c / 4  +  N a K_re / pi
    mean F_y = -N a K_tc c / 4  -  N a K_te / pi
    mean F_z =  N a K_ac c / pi +  N a K_ae / 2

so a straight-line fit of ``mean F / (N a)`` against ``c`` gives every coefficient
(:func:`calibrate_from_slot_averages`).  :func:`calibrate_from_slot_csv` reads the averages
from a CSV file with a header row and these columns (any order, extra columns ignored):

=====================  ======  =====================================================
column                 unit    meaning
=====================  ======  =====================================================
``feed_per_tooth_mm``  mm      feed per tooth ``c`` of the slot cut, > 0
``axial_depth_mm``     mm      axial depth of cut ``a``, > 0
``mean_force_x_N``     N       average force along the feed direction, on the workpiece
``mean_force_y_N``     N       average force normal to the feed, on the workpiece
``mean_force_z_N``     N       optional: average axial force; without it the axial
                               coefficients are returned as 0
=====================  ======  =====================================================

Sign convention: the tool turns clockwise seen from the spindle (a right-hand cutter),
``x`` points along the feed of the tool relative to the workpiece, ``y`` is ``x`` turned by
+90 deg.  In a slot ``mean_force_x_N`` is then positive and ``mean_force_y_N`` negative.
A table dynamometer with other axes must be rotated to this frame first.  At least two
distinct feeds per tooth are needed; five or more spread over the usable range are
advisable.  An example file is ``experiments/slot_calibration_example.csv``.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from os import PathLike

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Columns :func:`calibrate_from_slot_csv` requires.
SLOT_CSV_REQUIRED_COLUMNS = (
    "feed_per_tooth_mm",
    "axial_depth_mm",
    "mean_force_x_N",
    "mean_force_y_N",
)
#: Optional column for the axial coefficients.
SLOT_CSV_AXIAL_COLUMN = "mean_force_z_N"


@dataclass(frozen=True)
class CuttingCoefficients:
    """Mechanistic cutting and edge coefficients of a tool-material pair.

    The defaults are for Al7075-T6 cut dry with a carbide end mill, as tabulated in
    Table 5 of the review "Milling force model for aviation aluminum alloy: academic
    insight and perspective analysis" (Chinese Journal of Mechanical Engineering, 2021),
    values of the same order as the aluminium example in Altintas, *Manufacturing
    Automation*, Ch. 2.  They are typical textbook values, **not** values from Kim & Chung
    (the paper does not give its coefficients).

    Attributes
    ----------
    tangential_cutting_N_mm2 : float
        ``K_tc`` [N/mm^2], >= 0.
    radial_cutting_N_mm2 : float
        ``K_rc`` [N/mm^2], >= 0.
    axial_cutting_N_mm2 : float
        ``K_ac`` [N/mm^2].
    tangential_edge_N_mm : float
        ``K_te`` [N/mm], >= 0.
    radial_edge_N_mm : float
        ``K_re`` [N/mm], >= 0.
    axial_edge_N_mm : float
        ``K_ae`` [N/mm].
    chip_thickness_exponent : float
        ``x`` in ``K(h_m) = K (h_m / h_ref)^(-x)`` [-], in [0, 1); 0 = constant.
    reference_chip_thickness_mm : float
        ``h_ref`` [mm], > 0, the mean chip thickness at which the cutting coefficients hold.
    """

    tangential_cutting_N_mm2: float = 767.0
    radial_cutting_N_mm2: float = 168.8
    axial_cutting_N_mm2: float = 222.0
    tangential_edge_N_mm: float = 27.7
    radial_edge_N_mm: float = 26.6
    axial_edge_N_mm: float = 0.7
    chip_thickness_exponent: float = 0.0
    reference_chip_thickness_mm: float = 0.05

    def __post_init__(self) -> None:
        for name in (
            "tangential_cutting_N_mm2",
            "radial_cutting_N_mm2",
            "tangential_edge_N_mm",
            "radial_edge_N_mm",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        for name in ("axial_cutting_N_mm2", "axial_edge_N_mm"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)}")
        if self.tangential_cutting_N_mm2 == 0 and self.tangential_edge_N_mm == 0:
            raise ValueError("tangential_cutting_N_mm2 and tangential_edge_N_mm are both 0")
        if not 0 <= self.chip_thickness_exponent < 1:
            raise ValueError(
                f"chip_thickness_exponent must be in [0, 1), got {self.chip_thickness_exponent}"
            )
        if not self.reference_chip_thickness_mm > 0:
            raise ValueError(
                "reference_chip_thickness_mm must be > 0, "
                f"got {self.reference_chip_thickness_mm}"
            )

    @classmethod
    def from_cutting_pressure(
        cls,
        cutting_pressure_N_mm2: float,
        radial_ratio: float,
        chip_thickness_exponent: float = 0.0,
        reference_chip_thickness_mm: float = 0.05,
    ) -> CuttingCoefficients:
        """Kim & Chung's form: ``K_tc = K_s``, ``K_rc = r_t K_s``, no edge or axial force.

        Parameters
        ----------
        cutting_pressure_N_mm2 : float
            Cutting pressure ``K_s`` [N/mm^2] at ``reference_chip_thickness_mm``.
        radial_ratio : float
            Radial-to-tangential force ratio ``r_t`` [-].
        chip_thickness_exponent, reference_chip_thickness_mm : float
            Optional dependence of ``K_s`` on the mean chip thickness (see class).
        """
        if not cutting_pressure_N_mm2 > 0:
            raise ValueError(f"cutting_pressure_N_mm2 must be > 0, got {cutting_pressure_N_mm2}")
        if not radial_ratio >= 0:
            raise ValueError(f"radial_ratio must be >= 0, got {radial_ratio}")
        return cls(
            tangential_cutting_N_mm2=cutting_pressure_N_mm2,
            radial_cutting_N_mm2=radial_ratio * cutting_pressure_N_mm2,
            axial_cutting_N_mm2=0.0,
            tangential_edge_N_mm=0.0,
            radial_edge_N_mm=0.0,
            axial_edge_N_mm=0.0,
            chip_thickness_exponent=chip_thickness_exponent,
            reference_chip_thickness_mm=reference_chip_thickness_mm,
        )

    @property
    def radial_ratio(self) -> float:
        """Radial-to-tangential cutting-coefficient ratio ``r_t = K_rc / K_tc`` [-]."""
        if self.tangential_cutting_N_mm2 == 0:
            return 0.0
        return self.radial_cutting_N_mm2 / self.tangential_cutting_N_mm2

    @property
    def has_edge_forces(self) -> bool:
        """True if any edge coefficient is non-zero."""
        return any(
            v != 0
            for v in (self.tangential_edge_N_mm, self.radial_edge_N_mm, self.axial_edge_N_mm)
        )

    def pressure_factor(self, mean_chip_thickness_mm: ArrayLike) -> NDArray[np.float64]:
        """Multiplier ``(h_m / h_ref)^(-x)`` of the cutting coefficients [-].

        Parameters
        ----------
        mean_chip_thickness_mm : array_like, any shape
            Mean chip thickness ``h_m`` [mm], >= 0.

        Returns
        -------
        ndarray, same shape
            1 everywhere when ``x = 0``; where ``h_m = 0`` the factor is set to 1 (the
            cutting force is zero there anyway).
        """
        h = np.asarray(mean_chip_thickness_mm, dtype=float)
        if self.chip_thickness_exponent == 0:
            return np.ones_like(h)
        safe = np.where(h > 0, h, self.reference_chip_thickness_mm)
        return (safe / self.reference_chip_thickness_mm) ** (-self.chip_thickness_exponent)


@dataclass(frozen=True)
class SlotCalibration:
    """Result of a slot-cut calibration.

    Attributes
    ----------
    coefficients : CuttingCoefficients
        Identified coefficients (``chip_thickness_exponent = 0``).
    residual_rms_N : tuple of float
        RMS of the fit residuals of ``(F_x, F_y, F_z)`` [N]; ``F_z`` is 0 without data.
    samples : int
        Number of slot cuts used.
    """

    coefficients: CuttingCoefficients
    residual_rms_N: tuple[float, float, float]
    samples: int


def _line_fit(c: NDArray[np.float64], y: NDArray[np.float64]) -> tuple[float, float, float]:
    """Least-squares ``y = intercept + slope c``; returns (slope, intercept, rms residual)."""
    design = np.column_stack([c, np.ones_like(c)])
    (slope, intercept), *_ = np.linalg.lstsq(design, y, rcond=None)
    residual = y - design @ np.array([slope, intercept])
    return float(slope), float(intercept), float(np.sqrt(np.mean(residual**2)))


def calibrate_from_slot_averages(
    feed_per_tooth_mm: ArrayLike,
    axial_depth_mm: ArrayLike,
    mean_force_x_N: ArrayLike,
    mean_force_y_N: ArrayLike,
    teeth: int,
    mean_force_z_N: ArrayLike | None = None,
) -> SlotCalibration:
    """Identify cutting and edge coefficients from average forces in slot cuts.

    Fits ``mean F / (N a) = edge term + cutting term * c`` by linear least squares
    (``numpy.linalg.lstsq``) for each component; see the module docstring for the model
    and sign convention.

    Parameters
    ----------
    feed_per_tooth_mm : array_like, shape (n,)
        Feed per tooth ``c`` of each slot cut [mm], > 0, at least two distinct values.
    axial_depth_mm : array_like, shape (n,) or scalar
        Axial depth ``a`` of each cut [mm], > 0.
    mean_force_x_N, mean_force_y_N : array_like, shape (n,)
        Average feed-direction and normal forces on the workpiece [N].
    teeth : int
        Number of teeth ``N`` of the cutter, >= 1.
    mean_force_z_N : array_like, shape (n,), optional
        Average axial force [N]; without it the axial coefficients are 0.

    Returns
    -------
    SlotCalibration
        Residual RMS values are of the forces [N] (the fit residual times ``N a``).
    """
    c = np.atleast_1d(np.asarray(feed_per_tooth_mm, dtype=float))
    n = c.shape[0]
    if c.ndim != 1:
        raise ValueError(f"feed_per_tooth_mm must be 1-D, got shape {c.shape}")
    a = np.broadcast_to(np.asarray(axial_depth_mm, dtype=float), (n,))
    if isinstance(teeth, bool) or int(teeth) != teeth or teeth < 1:
        raise ValueError(f"teeth must be a whole number >= 1, got {teeth}")
    if np.any(~np.isfinite(c)) or np.any(c <= 0):
        raise ValueError("feed_per_tooth_mm must be finite and > 0")
    if np.unique(c).size < 2:
        raise ValueError("feed_per_tooth_mm needs at least two distinct values")
    if np.any(~np.isfinite(a)) or np.any(a <= 0):
        raise ValueError("axial_depth_mm must be finite and > 0")
    scale = teeth * a
    forces = {}
    for name, value in (
        ("mean_force_x_N", mean_force_x_N),
        ("mean_force_y_N", mean_force_y_N),
        ("mean_force_z_N", mean_force_z_N),
    ):
        if value is None:
            continue
        f = np.asarray(value, dtype=float)
        if f.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {f.shape}")
        if np.any(~np.isfinite(f)):
            raise ValueError(f"{name} must be finite")
        forces[name] = f / scale

    sx, ix, rx = _line_fit(c, forces["mean_force_x_N"])
    sy, iy, ry = _line_fit(c, forces["mean_force_y_N"])
    if "mean_force_z_N" in forces:
        sz, iz, rz = _line_fit(c, forces["mean_force_z_N"])
    else:
        sz = iz = rz = 0.0
    mean_scale = float(np.sqrt(np.mean(scale**2)))
    coefficients = CuttingCoefficients(
        tangential_cutting_N_mm2=-4.0 * sy,
        radial_cutting_N_mm2=4.0 * sx,
        axial_cutting_N_mm2=math.pi * sz,
        tangential_edge_N_mm=-math.pi * iy,
        radial_edge_N_mm=math.pi * ix,
        axial_edge_N_mm=2.0 * iz,
    )
    return SlotCalibration(
        coefficients=coefficients,
        residual_rms_N=(rx * mean_scale, ry * mean_scale, rz * mean_scale),
        samples=n,
    )


def calibrate_from_slot_csv(path: str | PathLike[str], teeth: int) -> SlotCalibration:
    """Identify the coefficients from a CSV of slot-cut averages (columns: module docstring).

    Parameters
    ----------
    path : str or path-like
        CSV file with a header row.
    teeth : int
        Number of teeth of the cutter used in the slot cuts.

    Returns
    -------
    SlotCalibration
    """
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        header = reader.fieldnames or []
        missing = [col for col in SLOT_CSV_REQUIRED_COLUMNS if col not in header]
        if missing:
            raise ValueError(f"{path}: missing column(s) {', '.join(missing)}")
        columns: dict[str, list[float]] = {col: [] for col in header}
        for line, row in enumerate(reader, start=2):
            for col in SLOT_CSV_REQUIRED_COLUMNS + (SLOT_CSV_AXIAL_COLUMN,):
                if col not in header:
                    continue
                try:
                    columns[col].append(float(row[col]))
                except (TypeError, ValueError):
                    raise ValueError(
                        f"{path}: row {line}, column {col}: not a number: {row[col]!r}"
                    ) from None
    if not columns[SLOT_CSV_REQUIRED_COLUMNS[0]]:
        raise ValueError(f"{path}: no data rows")
    return calibrate_from_slot_averages(
        columns["feed_per_tooth_mm"],
        columns["axial_depth_mm"],
        columns["mean_force_x_N"],
        columns["mean_force_y_N"],
        teeth,
        columns.get(SLOT_CSV_AXIAL_COLUMN),
    )
