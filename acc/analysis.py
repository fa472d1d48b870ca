"""The loop analysis for notebooks and scripts: python-control objects, margins and figures.

One import for what :mod:`acc.design.linear` (the objects), :mod:`acc.design.analysis` (the
numbers ``acc analyze`` writes) and :mod:`acc.design.loop_plots` (its figures) provide::

    import control, acc
    sc = acc.load_scenario("experiments/kim_chung_2001.toml")
    L = acc.analysis.open_loop(sc, 4.0, kind="dob_pi")    # exact-delay FRD, named signals
    control.bode_plot(L, display_margins=True)
    control.step_response(acc.analysis.sampled_loop(sc, 4.0)).plot()

Every object takes a scenario, a table depth [mm] (None: the nominal plant) and a controller
kind (None: the scenario's), or a :class:`~controllers.linear_loop.LoopSpec`.  Signals:
``reference_force_N``, ``force_error_N``, ``commanded_feed_mm_min``, ``force_N``,
``measured_force_N``, ``feed_request_mm_min``, ``disturbance_estimate_mm_min``,
``disturbance_N``, ``sensor_noise_N`` (see :mod:`acc.design.linear`).
"""

from __future__ import annotations

from acc.design.analysis import (
    GainToleranceSweep,
    LoopMargins,
    analysis_table,
    dob_robustness,
    gain_tolerance_sweep,
    is_stable,
    margins,
    max_gain_ratio,
)
from acc.design.linear import (
    CLOSED_LOOP_OUTPUTS,
    HOLD_PADE_ORDER,
    OMEGA_RAD_S,
    PADE_ORDER,
    NotAnalysableError,
    analysable_kinds,
    closed_loop,
    complementary_sensitivity,
    controller,
    loop_spec,
    nominal_model,
    observer_loop,
    open_loop,
    plant,
    sampled_loop,
    sensitivity,
    sensor,
)
from acc.design.loop_plots import (
    analysis_figure,
    comparison_figure,
    plot_bode,
    plot_gain_tolerance,
    plot_nyquist,
    plot_sensitivities,
    plot_step,
)

__all__ = [
    "CLOSED_LOOP_OUTPUTS",
    "GainToleranceSweep",
    "HOLD_PADE_ORDER",
    "LoopMargins",
    "NotAnalysableError",
    "OMEGA_RAD_S",
    "PADE_ORDER",
    "analysable_kinds",
    "analysis_figure",
    "analysis_table",
    "closed_loop",
    "comparison_figure",
    "complementary_sensitivity",
    "controller",
    "dob_robustness",
    "gain_tolerance_sweep",
    "is_stable",
    "loop_spec",
    "margins",
    "max_gain_ratio",
    "nominal_model",
    "observer_loop",
    "open_loop",
    "plant",
    "plot_bode",
    "plot_gain_tolerance",
    "plot_nyquist",
    "plot_sensitivities",
    "plot_step",
    "sampled_loop",
    "sensitivity",
    "sensor",
]
