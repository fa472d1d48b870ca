"""Velocity feed-forward for Peng's servo axis, as a LinuxCNC PID (spec §6.1, §5.4 item 5).

Peng's axis (M0-1, M0-2) turns a steady velocity command ``V_c`` into the motor speed
``W = (K_1/K_3) V_c`` (the DC gain of (2.14)) and the table speed ``v = W p/(2 pi)``, so the
command that holds a feed ``v`` without a following error is ``V_c = FF1 v`` with
``FF1 = 2 pi K_3/(K_1 p)`` [V s/mm].  With it, a P loop keeps no steady following error on a
ramp of the axis it was computed for; an axis with another friction ``B`` keeps the error
of the difference (the contour error of mismatched axes is not removed by a common FF1).
"""

from __future__ import annotations

import math

from controllers.axis.lead_lag import LeadLagParams
from controllers.axis.pid import AxisPIDParams
from plants.axis.servo_axis import ServoAxisParams


def velocity_feedforward_gain_V_s_per_mm(axis: ServoAxisParams) -> float:
    """``FF1 = 2 pi K_3/(K_1 p)`` [V s/mm] of a servo axis (linear friction)."""
    k1, _, k3 = axis.velocity_loop.k123
    return 2 * math.pi * k3 / (k1 * axis.screw_pitch_mm)


def velocity_feedforward_pid(
    axis: ServoAxisParams, lead_lag: LeadLagParams | None = None
) -> AxisPIDParams:
    """P position loop with the lead-lag's DC gain plus velocity feed-forward.

    Parameters
    ----------
    axis : ServoAxisParams
        The axis the feed-forward is computed for (the controller's model of the axis).
    lead_lag : LeadLagParams, optional
        Its DC gain ``K_p K_d (1 + a)/(1 + b)`` [V/count] sets the P gain (so the loop has the
        lead-lag's velocity constant); default Peng's filter.

    Returns
    -------
    AxisPIDParams
        ``p_gain_per_mm`` [V/mm], ``ff1_s_per_mm`` [V s/mm], reading the reference velocity
        from the interpolator (``use_reference_derivative``).
    """
    ll = lead_lag or LeadLagParams()
    if ll.pole == -1.0:
        raise ValueError("lead_lag: b = -1 has no finite DC gain for a P loop")
    p_gain = ll.dac_gain_V_per_count * ll.dc_gain * axis.counts_per_mm
    return AxisPIDParams(p_gain_per_mm=p_gain,
                         ff1_s_per_mm=velocity_feedforward_gain_V_s_per_mm(axis),
                         use_reference_derivative=True)


__all__ = ["velocity_feedforward_gain_V_s_per_mm", "velocity_feedforward_pid"]
