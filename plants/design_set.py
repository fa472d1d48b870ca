"""The design plant set: the range of plants a controller must be safe and good on, declared once.

A scenario's ``[design]`` section (:class:`DesignSet`) says which plants the controller is
designed for, relative to the nominal model of ``[nominal_plant]`` (Eq. 9):

* ``gain_ratio_range = [min, max]``: the force process's static gain ``G = K2 / (-p2)``
  [N/(mm/min)] over the nominal model's ``Gn``.  A table row, a harder material
  (``force_process.gain_multiplier``) and a deeper axial cut all scale it; the ratio is what
  the loop gain sees.  Default ``[0.2, 5]`` (the adaptive estimator's former projection
  bound, a factor 5 either way).
* ``dead_time_range_s = [min, max]``: the feed drive's dead time [s]; not given: the nominal
  dead time +-20 %.
* ``pole_range_rad_s = [min, max]``: the process pole ``p2`` [rad/s], both < 0; not given:
  the nominal pole scaled by ``controller.estimator_parameter_ratio_max`` either way.

Who reads it: the adaptive kinds start from the stiffest plant of the set (largest static
gain) and keep their estimate inside it (:mod:`controllers.gain_estimator`); ``acc tune``
designs over it (its flags override); ``acc analyze`` reports the margins over its corners.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Largest max/min ratio a range may span [-] (a wider one is a typo, not a design).
MAX_RANGE_SPAN = 1e4


def _check_range(name: str, value: tuple[float, ...] | None, positive: bool) -> None:
    if value is None:
        return
    if len(value) != 2:
        raise ValueError(f"{name} must be [min, max], got {len(value)} values")
    lo, hi = value
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{name} must be finite, got [{lo}, {hi}]")
    if positive and not 0 < lo <= hi:
        raise ValueError(f"{name} must satisfy 0 < min <= max, got [{lo}, {hi}]")
    if positive and hi / lo > MAX_RANGE_SPAN:
        raise ValueError(f"{name} spans {hi / lo:.3g}x (limit {MAX_RANGE_SPAN:g}x)")


@dataclass(frozen=True)
class DesignSet:
    """The ``[design]`` section: the plants a design must cover (module docstring).

    Attributes
    ----------
    gain_ratio_range : tuple of float, (min, max)
        Static process gain over the nominal model's [-], 0 < min <= max.
    dead_time_range_s : tuple of float, (min, max), or None
        Dead time [s], 0 <= min <= max; None: nominal +-20 %.
    pole_range_rad_s : tuple of float, (min, max), or None
        Process pole [rad/s], min <= max < 0; None: from the estimator's ratio bound.
    """

    gain_ratio_range: tuple[float, ...] = (0.2, 5.0)
    dead_time_range_s: tuple[float, ...] | None = None
    pole_range_rad_s: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        _check_range("gain_ratio_range", self.gain_ratio_range, positive=True)
        _check_range("dead_time_range_s", self.dead_time_range_s, positive=False)
        if self.dead_time_range_s is not None:
            lo, hi = self.dead_time_range_s
            if not 0 <= lo <= hi:
                raise ValueError(
                    f"dead_time_range_s must satisfy 0 <= min <= max, got [{lo}, {hi}]"
                )
        _check_range("pole_range_rad_s", self.pole_range_rad_s, positive=False)
        if self.pole_range_rad_s is not None:
            lo, hi = self.pole_range_rad_s
            if not lo <= hi < 0:
                raise ValueError(
                    f"pole_range_rad_s must satisfy min <= max < 0, got [{lo}, {hi}]"
                )
            if lo / hi > MAX_RANGE_SPAN:
                raise ValueError(
                    f"pole_range_rad_s spans {lo / hi:.3g}x (limit {MAX_RANGE_SPAN:g}x)"
                )

    def dead_times_s(self, nominal_dead_time_s: float) -> tuple[float, float]:
        """The dead-time range [s]: the declared one, or the nominal +-20 %."""
        if self.dead_time_range_s is not None:
            return float(self.dead_time_range_s[0]), float(self.dead_time_range_s[1])
        return 0.8 * nominal_dead_time_s, 1.2 * nominal_dead_time_s

    def poles_rad_s(self, nominal_pole_rad_s: float, ratio_max: float) -> tuple[float, float]:
        """The pole range [rad/s] (min, max; both < 0): the declared one, or the nominal pole
        scaled by ``ratio_max`` either way."""
        if self.pole_range_rad_s is not None:
            return float(self.pole_range_rad_s[0]), float(self.pole_range_rad_s[1])
        return nominal_pole_rad_s * ratio_max, nominal_pole_rad_s / ratio_max


__all__ = ["DesignSet", "MAX_RANGE_SPAN"]
