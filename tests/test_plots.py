"""Plots draw onto the given Axes, return it, and show the result's own numbers."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from acc import plot_depth, plot_feed, plot_force, simulate  # noqa: E402
from acc.scenarios.force import Scenario  # noqa: E402


def test_plots_draw_on_the_given_axes():
    sc = Scenario().with_values({"simulation.time_limit_s": 1.0, "simulation.plant_step_s": 0.002})
    res = simulate(sc)
    fig, axes = plt.subplots(3)
    assert plot_force(res, ax=axes[0]) is axes[0]
    assert plot_feed(res, ax=axes[1]) is axes[1]
    assert plot_depth(res, ax=axes[2]) is axes[2]
    force_line = [ln for ln in axes[0].lines if ln.get_label() == "force"][0]
    assert np.array_equal(force_line.get_ydata(), res.signal("force_N")[0])
    assert np.array_equal(force_line.get_xdata(), res.time_s)
    plt.close(fig)
