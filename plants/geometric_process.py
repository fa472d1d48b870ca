"""Force process driven by the geometric end-milling model (Kim & Chung Eqs. 1-4 in the loop).

The chip-load state ``x`` [mm/min] keeps the dynamics of Eq. (7): ``dx/dt = p2 (x - v)``
with the pole ``p2`` of the ``[force_process]`` table at the segment's radial depth (the
paper identifies the pole from cutting tests; the geometry gives the gain).  The force is the
geometric model evaluated at the feed per tooth ``c = x / (N n)``:

* ``tooth_passing = false``: the tooth-period average force (:func:`average_forces`).
  With a constant cutting pressure it is affine in ``c``, so each segment stores the edge
  force ``E`` (at ``c = 0``) and the slope ``A`` per mm of chip, and a step is
  ``F = E + c A`` per component;
* ``tooth_passing = true``: the instantaneous force at the spindle angle
  ``theta_k = 2 pi n k dt / 60`` (integer clock), from :func:`instantaneous_forces`.

The loop regulates one component (``component``): ``"feed"``, ``"normal"``,
``"tangential"``, ``"axial"`` or ``"resultant_xy"``; it must grow with the feed on every
cutting segment, or the scenario is rejected (a force that falls as the feed rises cannot be
regulated through the feedrate override).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from plants.cutting_coefficients import CuttingCoefficients
from plants.end_mill_geometry import (
    FORCE_COMPONENTS,
    MILLING_MODES,
    CuttingForces,
    EndMill,
    MillingCut,
    average_forces,
    force_process_static_gain_N_per_mm_min,
    instantaneous_forces,
)

_COMPONENT_INDEX = {"feed": 0, "normal": 1, "tangential": 2, "axial": 3}


@dataclass(frozen=True)
class GeometricProcessParams:
    """The ``[geometry]`` scenario section.

    Attributes
    ----------
    enabled : bool
        Force from the geometric model (True) or from the Table 1 gain (False).
    tooth_passing : bool
        Instantaneous force with tooth passing instead of the tooth-period average.
    component : str
        Force component the loop regulates (see module docstring).
    milling_mode : {"up", "down"}
        Up- (conventional) or down- (climb) milling.
    spindle_speed_rpm : float
        Spindle speed [rev/min] (600 in Table 1).
    diameter_mm : float
        Tool diameter [mm] (16 in Table 1).
    teeth : int
        Number of teeth (4 in Table 1).
    helix_angle_deg : float
        Helix angle [deg] (not given in the paper; 30 is typical).
    """

    enabled: bool = False
    tooth_passing: bool = False
    component: str = "resultant_xy"
    milling_mode: str = "up"
    spindle_speed_rpm: float = 600.0
    diameter_mm: float = 16.0
    teeth: int = 4
    helix_angle_deg: float = 30.0

    def __post_init__(self) -> None:
        if self.component not in FORCE_COMPONENTS:
            raise ValueError(f"component must be one of {FORCE_COMPONENTS}, got {self.component!r}")
        if self.milling_mode not in MILLING_MODES:
            raise ValueError(f"milling_mode must be one of {MILLING_MODES}")
        if not self.spindle_speed_rpm > 0:
            raise ValueError(f"spindle_speed_rpm must be > 0, got {self.spindle_speed_rpm}")
        self.tool  # noqa: B018  (validates diameter, teeth, helix)

    @property
    def tool(self) -> EndMill:
        """The end mill."""
        return EndMill(self.diameter_mm, self.teeth, self.helix_angle_deg)

    @property
    def feed_per_tooth_per_feed(self) -> float:
        """Feed per tooth per feedrate ``1 / (N n)`` [mm per mm/min]."""
        return 1.0 / (self.teeth * self.spindle_speed_rpm)

    def cut(self, radial_depth_mm, axial_depth_mm, feed_per_tooth_mm) -> MillingCut:
        """A :class:`MillingCut` in this mode and spindle speed (arrays broadcast)."""
        return MillingCut(
            radial_depth_mm,
            axial_depth_mm,
            feed_per_tooth_mm,
            self.milling_mode,
            self.spindle_speed_rpm,
        )


def _component(forces: CuttingForces, name: str) -> NDArray[np.float64]:
    return np.asarray(forces.component(name), dtype=float)


def check_regulable(
    params: GeometricProcessParams,
    coefficients: CuttingCoefficients,
    radial_depth_mm: NDArray,
    axial_depth_mm: NDArray,
    feed_mm_min: float,
) -> None:
    """Raise ValueError if the regulated component does not grow with the feed on a cut.

    Parameters
    ----------
    radial_depth_mm, axial_depth_mm : ndarray, shape (segments,)
        Cutting segments' depths [mm].
    feed_mm_min : float
        Operating feed at which the gain is evaluated [mm/min].
    """
    c = feed_mm_min * params.feed_per_tooth_per_feed
    gain = force_process_static_gain_N_per_mm_min(
        params.tool, params.cut(radial_depth_mm, axial_depth_mm, c), coefficients, params.component
    )
    bad = np.asarray(gain) <= 0
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"component {params.component!r} does not grow with the feed at radial depth "
            f"{radial_depth_mm[i]:g} mm (gain {float(np.asarray(gain)[i]):.3g} N per mm/min); "
            "regulate 'feed', 'tangential' or 'resultant_xy'"
        )


class GeometricForceOutput:
    """Force of a batch from the chip-load state, by the geometric model.

    Parameters
    ----------
    params : GeometricProcessParams
        Shared by the batch.
    coefficients : CuttingCoefficients
        Shared by the batch.
    radial_depth_mm, axial_depth_mm : ndarray, shape (runs, segments + 1)
        Depths per segment (0 = air; the last column is "left the part").
    plant_step_s : float
    """

    def __init__(
        self,
        params: GeometricProcessParams,
        coefficients: CuttingCoefficients,
        radial_depth_mm: NDArray,
        axial_depth_mm: NDArray,
        plant_step_s: float,
    ) -> None:
        self.params = params
        self.coefficients = coefficients
        self.radial_depth_mm = np.asarray(radial_depth_mm, dtype=float)
        self.axial_depth_mm = np.asarray(axial_depth_mm, dtype=float)
        self.cutting = (self.radial_depth_mm > 0) & (self.axial_depth_mm > 0)
        self.plant_step_s = plant_step_s
        self.spindle_rad_per_step = 2.0 * np.pi * params.spindle_speed_rpm / 60.0 * plant_step_s
        self._rows = np.arange(self.radial_depth_mm.shape[0])
        self.affine = coefficients.chip_thickness_exponent == 0 and not params.tooth_passing
        if self.affine:
            ae = np.where(self.cutting, self.radial_depth_mm, 0.0)
            ap = np.where(self.cutting, self.axial_depth_mm, 0.0)
            f0 = average_forces(params.tool, params.cut(ae, ap, 0.0), coefficients)
            f1 = average_forces(params.tool, params.cut(ae, ap, 1.0), coefficients)
            comps = ("feed", "normal", "tangential", "axial")
            #: edge force per segment and component [N], shape (runs, segments + 1, 4)
            self.edge_N = np.stack([_component(f0, c) for c in comps], axis=-1)
            #: force per mm of feed per tooth [N/mm], shape (runs, segments + 1, 4)
            self.slope_N_mm = np.stack([_component(f1, c) for c in comps], axis=-1) - self.edge_N
            self.edge_N[~self.cutting] = 0.0
            self.slope_N_mm[~self.cutting] = 0.0

    def _from_vectors(self, fx, fy, ft, fz) -> NDArray[np.float64]:
        name = self.params.component
        if name == "resultant_xy":
            return np.hypot(fx, fy)
        return (fx, fy, ft, fz)[_COMPONENT_INDEX[name]]

    def forces(
        self, chip_load_mm_min: NDArray, segment: NDArray[np.intp], k: int
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Regulated component and feed-direction force at step ``k`` [N], each (runs,)."""
        r = self._rows
        c = np.maximum(chip_load_mm_min, 0.0) * self.params.feed_per_tooth_per_feed
        cutting = self.cutting[r, segment]
        if self.affine:
            vec = self.edge_N[r, segment] + c[:, None] * self.slope_N_mm[r, segment]
            fx, fy, ft, fz = vec.T
        else:
            ae = np.where(cutting, self.radial_depth_mm[r, segment], 0.0)
            ap = np.where(cutting, self.axial_depth_mm[r, segment], 0.0)
            cut = self.params.cut(ae, ap, c)
            if self.params.tooth_passing:
                theta = np.full(len(r), k * self.spindle_rad_per_step)
                f = instantaneous_forces(self.params.tool, cut, self.coefficients, theta)
            else:
                f = average_forces(self.params.tool, cut, self.coefficients)
            fx, fy, ft, fz = (
                np.where(cutting, np.broadcast_to(x, r.shape), 0.0)
                for x in (f.feed_N, f.normal_N, f.tangential_N, f.axial_N)
            )
        return self._from_vectors(fx, fy, ft, fz), np.asarray(fx)

    def steady_average_N(self, feed_mm_min: float, run: int, segment: int) -> float:
        """Tooth-period average of the regulated component at a constant feed [N]."""
        if not self.cutting[run, segment]:
            return 0.0
        c = feed_mm_min * self.params.feed_per_tooth_per_feed
        cut = self.params.cut(
            self.radial_depth_mm[run, segment], self.axial_depth_mm[run, segment], c
        )
        f = average_forces(self.params.tool, cut, self.coefficients)
        return float(self._from_vectors(f.feed_N, f.normal_N, f.tangential_N, f.axial_N))

    def safe_feed_mm_min(self, reference_force_N: float, run: int) -> float:
        """Largest constant feed whose average regulated force is at most the reference on
        every cutting segment [mm/min] (the force grows with the feed, checked at build)."""
        feeds = []
        for j in np.flatnonzero(self.cutting[run]):

            def excess(v: float, j: int = int(j)) -> float:
                return self.steady_average_N(v, run, j) - reference_force_N

            if excess(0.0) >= 0:
                return 0.0  # the edge force alone reaches the reference
            hi = 1.0
            while excess(hi) < 0:
                hi *= 2.0
            feeds.append(brentq(excess, 0.0, hi, xtol=1e-10, rtol=1e-13))
        return float(min(feeds))


__all__ = ["GeometricForceOutput", "GeometricProcessParams", "check_regulable"]
