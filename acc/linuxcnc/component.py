"""The force controller as a userspace HAL component for an existing LinuxCNC machine.

``python -m acc.linuxcnc.component SCENARIO [--name acc-force]`` (what ``acc linuxcnc
export`` writes a HAL snippet for) creates the HAL component ``acc-force`` and runs the
scenario's controller (its compiled ``step``, built by the controller registry from the
scenario, as the engine builds it) every ``[simulation] control_period_s``:

============================  =====  ===================================================
pin                           dir    meaning
============================  =====  ===================================================
``acc-force.force``           in     measured cutting force [N] (dynamometer, spindle load)
``acc-force.enable``          in     bit: control on; off holds the adaptive feed at
                                     ``initial_override``, and the controller restarts
``acc-force.alarm``           in     bit: a breakage (or any) alarm: feed inhibited
``acc-force.adaptive-feed``   out    override / feed override, in [0, 1]: to
                                     ``motion.adaptive-feed`` (the program says ``M52 P1``)
``acc-force.override``        out    the controller's override [-]
``acc-force.feed-inhibit``    out    bit: overload (force above ``[metrics] force_limit_N``)
                                     or alarm; to ``motion.feed-inhibit``; latched until
                                     ``enable`` goes off
``acc-force.overload``        out    bit: the overload part of ``feed-inhibit``
============================  =====  ===================================================

A userspace component is not realtime: it reads the force when its period's timer fires
(a sleep on the monotonic clock), so its samples jitter by the scheduler's latency; on the
simulated machine :mod:`acc.linuxcnc.force_loop_component` samples every servo cycle instead.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from acc.engine.element import jit, step
from controllers.registry import controller_records
from controllers.robust_force_controller import DIAGNOSTIC_NAMES

#: The component's pins: (name, type, direction) with type "float"/"bit", dir "in"/"out".
PINS = (
    ("force", "float", "in"),
    ("enable", "bit", "in"),
    ("alarm", "bit", "in"),
    ("adaptive-feed", "float", "out"),
    ("override", "float", "out"),
    ("feed-inhibit", "bit", "out"),
    ("overload", "bit", "out"),
)


@jit(python_entry=True)
def controller_step(cp: np.ndarray, cs: np.ndarray, measured_N: float,
                    diag: np.ndarray) -> float:
    """The controller element's compiled step on run 0 of its records: the override [-]."""
    return step(cp[0], cs[0], measured_N, diag)


def controller_for(scenario: object) -> tuple[np.ndarray, np.ndarray]:
    """The controller records of ``scenario`` (as :func:`acc.engine.simulate.simulate`
    builds them; the safe feed from the part's stiffest cut)."""
    from acc.engine.metrics import safe_feed_mm_min
    from plants.workpiece import WorkpieceBatch

    s = scenario
    parts = WorkpieceBatch([s.workpiece])
    gain, _ = s.force_process.segment_parameters(parts.radial_depth_mm[0],
                                                 parts.axial_depth_mm[0])
    ref = s.controller.reference_force_N
    safe = safe_feed_mm_min(ref, np.atleast_2d(gain)[0, :parts.segments])
    return controller_records([s.controller], [s.nominal_plant], s.simulation.control_period_s,
                              np.array([safe / s.controller.programmed_feed_mm_min]),
                              [s.design])


def run_component(scenario_path: str, name: str = "acc-force",
                  feed_override: float | None = None) -> int:
    """Create the component and run the controller until the process is terminated."""
    import hal

    from acc import scenarios

    scenario = scenarios.load(scenario_path, [])
    d = scenario.feed_drive
    fo = feed_override or (d.feed_override if d.kind == "linuxcnc" else 1.0)
    period = scenario.simulation.control_period_s
    limit = scenario.metrics.force_limit_N
    initial = scenario.controller.initial_override
    comp = hal.component(name)
    for pin, kind, direction in PINS:
        comp.newpin(pin, hal.HAL_FLOAT if kind == "float" else hal.HAL_BIT,
                    hal.HAL_IN if direction == "in" else hal.HAL_OUT)
    comp["adaptive-feed"] = min(initial / fo, 1.0)
    comp["override"] = initial
    diag = np.full(len(DIAGNOSTIC_NAMES), np.nan)
    cp, cs = controller_for(scenario)
    fresh = (cp.copy(), cs.copy())
    controller_step(cp.copy(), cs.copy(), 0.0, diag)  # compile before the first period
    comp.ready()  # ``loadusr -W`` returns here: the controller is ready
    latched = False
    was_enabled = False
    next_t = time.monotonic()
    try:
        while True:
            next_t += period
            time.sleep(max(0.0, next_t - time.monotonic()))
            enabled = bool(comp["enable"])
            if not enabled:
                latched = False
                comp["overload"] = False
                comp["feed-inhibit"] = False
                comp["override"] = initial
                comp["adaptive-feed"] = min(initial / fo, 1.0)
                was_enabled = False
                continue
            if not was_enabled:
                cp, cs = fresh[0].copy(), fresh[1].copy()
                was_enabled = True
            force = float(comp["force"])
            over = limit is not None and math.isfinite(force) and force > limit
            latched = latched or over or bool(comp["alarm"])
            comp["overload"] = bool(over) or (latched and bool(comp["overload"]))
            comp["feed-inhibit"] = latched
            override = controller_step(cp, cs, force, diag)
            comp["override"] = override
            comp["adaptive-feed"] = min(max(override / fo, 0.0), 1.0)
    except KeyboardInterrupt:
        return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m acc.linuxcnc.component SCENARIO [--name NAME] [--feed-override X]``."""
    parser = argparse.ArgumentParser(prog="acc-force", description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("--name", default="acc-force")
    parser.add_argument("--feed-override", type=float, default=None)
    args = parser.parse_args(argv)
    return run_component(args.scenario, args.name, args.feed_override)


if __name__ == "__main__":
    sys.exit(main())
