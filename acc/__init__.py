"""acc: a workbench for adaptive cutting-force control in CNC end milling.

Python API::

    import acc
    scenario = acc.load_scenario("experiments/kim_chung_2001.toml")
    scenario = scenario.with_values({"controller.reference_force_N": 450})
    result = acc.simulate(scenario)
    acc.plot_force(result, ax=ax)
"""

from acc.plots import plot_depth, plot_feed, plot_force, plot_force_runs, response_figure
from acc.result import SIGNALS, SimulationResult
from acc.scenario import Scenario, ScenarioError, load_scenario, scenario_from_dict
from acc.simulator import simulate

__all__ = [
    "SIGNALS",
    "Scenario",
    "ScenarioError",
    "SimulationResult",
    "load_scenario",
    "plot_depth",
    "plot_feed",
    "plot_force",
    "plot_force_runs",
    "response_figure",
    "scenario_from_dict",
    "simulate",
]
