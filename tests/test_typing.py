"""The typed public API: ``mypy`` (configured in pyproject.toml's ``[tool.mypy]``) passes on
the modules a user calls and the ``plants``/``controllers`` modules they import, and a user's
script sees the types the documentation names (not ``Any``).

The package ships ``py.typed``, so a user's type checker reads these annotations: an
annotation that disagrees with the code (a missing ``None``, a union passed where one member
is expected) becomes the user's error.  Modules outside :data:`CLEAN` are read for the types
they export (``--follow-imports=silent``) but their own errors are not reported here.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.cli_run import ROOT

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

#: Files and packages that must pass mypy.
CLEAN: tuple[str, ...] = (
    "acc/__init__.py",
    "acc/analysis.py",
    "acc/errors.py",
    "acc/limits.py",
    "acc/inputs.py",
    "acc/output.py",
    "acc/examples",
    "acc/engine/element.py",
    "acc/engine/result.py",
    "acc/engine/rng.py",
    "acc/engine/axis_simulate.py",
    "acc/engine/xy_simulate.py",
    "acc/engine/contour_simulate.py",
    "acc/scenarios/axis.py",
    "acc/scenarios/contour.py",
    "acc/scenarios/sections.py",
    "acc/identify",
    "acc/campaigns/report.py",
    "plants",
    "controllers",
)

#: Files under the packages of :data:`CLEAN` not (yet) checked here (path regex, for
#: ``mypy --exclude``).
NOT_YET: tuple[str, ...] = (
    r"acc/identify/scenario_sections\.py",
    r"plants/feed_drive\.py",
    r"plants/linuxcnc_drive\.py",
    r"plants/axis/elastic_axis\.py",
    r"plants/axis/oscillating_axis\.py",
    r"plants/axis/servo_axis\.py",
    r"plants/axis/axis_errors\.py",
    r"controllers/contouring/plots\.py",
)


def run_mypy(*paths: str, cache: Path | None = None) -> subprocess.CompletedProcess[str]:
    """``python -m mypy`` on ``paths`` from the repository root, with the project's
    configuration and no cache written into the checkout (``cache``: mypy's incremental cache
    directory, shared by the checks of one test process; None: no cache)."""
    exclude = "^(" + "|".join(NOT_YET) + ")$"
    return subprocess.run(
        [sys.executable, "-m", "mypy", "--follow-imports=silent",
         f"--cache-dir={cache or '/dev/null'}", "--exclude", exclude, *paths],
        cwd=ROOT, capture_output=True, text=True, timeout=900,
    )


@pytest.fixture(scope="module")
def mypy_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One incremental cache for this module's checks: the user's script and the wrong
    annotation are checked against the package's modules as the first check read them
    (mypy re-reads a module whose source changed; the results are those of a cold run)."""
    return tmp_path_factory.mktemp("mypy_cache")


def test_public_modules_pass_mypy(mypy_cache: Path) -> None:
    pytest.importorskip("mypy")
    proc = run_mypy(*CLEAN, cache=mypy_cache)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Success: no issues found" in proc.stdout, proc.stdout


def test_the_configuration_reports_a_wrong_annotation(tmp_path: Path, mypy_cache: Path) -> None:
    """The same command and configuration flag a return annotated int that returns a str
    (the check is on: no ignore_errors, no module left unchecked by the configuration)."""
    pytest.importorskip("mypy")
    wrong = tmp_path / "wrong_annotation.py"
    wrong.write_text('def count() -> int:\n    return "three"\n', encoding="utf-8")
    proc = run_mypy(str(wrong), cache=mypy_cache)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "wrong_annotation.py:2: error: Incompatible return value type" in proc.stdout
    with (ROOT / "pyproject.toml").open("rb") as fh:
        config = tomllib.load(fh)["tool"]["mypy"]
    assert "ignore_errors" not in config
    assert all("ignore_errors" not in o for o in config.get("overrides", []))


#: A user's script (type-checked, never run): each call of the documented API has the type its
#: documentation names.  ``assert_type`` fails on ``Any`` too, so a lazy or unannotated name
#: is caught.
USER_SCRIPT = """
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from typing_extensions import assert_type

import acc
import acc.scenarios
from acc.campaigns.report import report_text
from acc.engine.axis_simulate import AxisResult, simulate_axis
from acc.engine.contour_simulate import ContourResult, simulate_contouring
from acc.engine.xy_simulate import XYReference, XYResult, simulate_xy
from acc.errors import AccError
from acc.examples import Example, find_example, list_examples
from acc.identify import Identification, Record, identify, read_log, record_from_arrays
from acc.inputs import read_toml
from acc.limits import shorten
from acc.output import ValidationRow, validation_report
from acc.scenarios.axis import AxisScenario
from acc.scenarios.contour import ContourScenario
from acc.scenarios.force import load_scenario
from controllers.axis.lead_lag import LeadLagParams
from controllers.axis.trajectory import TrajectoryParams
from controllers.contouring.interpolator import PathParams, PathReference, interpolate
from plants.axis.servo_axis import ServoAxisParams


def force_loop(path: Path) -> None:
    sc = acc.load_scenario(path)
    assert_type(sc, acc.Scenario)
    assert_type(load_scenario(str(path)), acc.Scenario)
    softer = sc.with_values({"force_process.gain_multiplier": 0.5})
    assert_type(softer, acc.Scenario)
    res = acc.simulate([sc, softer], record_every_steps=10)
    assert_type(res, acc.SimulationResult)
    assert_type(res.signal("force_N"), NDArray[np.float64])
    assert_type(res.summary_rows(), list[dict[str, Any]])
    assert_type(res.columns(), dict[str, NDArray[Any]])
    assert_type(res.runs, int)
    assert_type(acc.scenarios.load(path, ["controller.reference_force_N=450"]),
                acc.Scenario | AxisScenario | ContourScenario)
    assert_type(acc.scenarios.from_dict({}), acc.Scenario | AxisScenario | ContourScenario)


def labs(path: PathParams) -> None:
    axis = ServoAxisParams()
    assert_type(axis.inertia_kg_m2, float)
    run = simulate_axis(axis, LeadLagParams(), TrajectoryParams(), duration_s=0.5)
    assert_type(run, AxisResult)
    assert_type(run.signal("position_mm"), NDArray[np.float64])
    ref = interpolate(path, 1e-4)
    assert_type(ref, PathReference)
    xy = simulate_xy(axis, axis, LeadLagParams(), LeadLagParams(), XYReference.from_path(ref))
    assert_type(xy, XYResult)
    assert_type(simulate_contouring(ref, axis, axis, LeadLagParams()), ContourResult)


def tools(log: Path) -> None:
    rec = read_log(log, programmed_feed_mm_min=600.0)
    assert_type(rec, Record)
    assert_type(rec.feed_velocity_mm_min, NDArray[np.float64] | None)
    assert_type(record_from_arrays([0.0, 0.001], [1.0, 1.0]), Record)
    assert_type(identify([rec]), Identification)
    assert_type(list_examples(), list[Example])
    assert_type(find_example("kim_chung_2001"), Example | None)
    assert_type(read_toml(log), dict[str, Any])
    assert_type(shorten("text"), str)
    assert_type(validation_report([ValidationRow("a", "b", 1.0, 1.0, "N")]), str)
    assert_type(report_text("sweep", {}), str)
    try:
        pass
    except AccError as exc:
        assert_type(str(exc), str)
"""


def test_a_users_script_sees_the_documented_types(tmp_path: Path, mypy_cache: Path) -> None:
    pytest.importorskip("mypy")
    script = tmp_path / "user_script.py"
    script.write_text(USER_SCRIPT, encoding="utf-8")
    proc = run_mypy(str(script), cache=mypy_cache)
    assert proc.returncode == 0, proc.stdout + proc.stderr
