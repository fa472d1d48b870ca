"""Validation covers what the simulation assumes: non-finite values, documented limits, and
cross-key conditions, each refused before any run in one line naming the right key."""

from __future__ import annotations

import csv
import math
import types
import typing
from pathlib import Path

import pytest

from acc.scenarios.force import SECTIONS, field_types
from tests.cli_run import GEOMETRIC, ROOT, SHIPPED, SHORT, acc, assert_one_line_error


def _numeric_keys() -> list[tuple[str, bool]]:
    """``(section.key, is_list)`` of every number-valued scenario key."""
    out = []
    for section, cls in SECTIONS.items():
        for key, tp in field_types(cls).items():
            if typing.get_origin(tp) in (typing.Union, types.UnionType):
                tp = next(a for a in typing.get_args(tp) if a is not type(None))
            if tp is float:
                out.append((f"{section}.{key}", False))
            elif typing.get_origin(tp) is tuple and typing.get_args(tp)[0] is float:
                out.append((f"{section}.{key}", True))
    return out


NUMERIC_KEYS = _numeric_keys()


def summary_is_finite(out: Path) -> None:
    """No ±inf anywhere in ``summary.csv``; a run that did not fail has finite error
    integrals, cutting time and conventional time (NaN only where documented)."""
    with (out / "summary.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert rows
    for row in rows:
        for k, v in row.items():
            assert v.lower() not in ("inf", "-inf", "infinity"), (k, v)
        if row["failed"] == "False":
            for k in ("iae_N_s", "ise_N2_s", "cutting_time_s", "conventional_time_s"):
                assert math.isfinite(float(row[k])), (k, row[k])


def test_every_numeric_key_is_listed():
    assert len(NUMERIC_KEYS) > 40
    assert ("force_process.radial_depth_mm", True) in NUMERIC_KEYS


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_no_numeric_key_accepts_a_non_finite_value(tmp_path, value):
    """Every number-valued key (none documents NaN or inf) refuses them, naming the key."""
    accepted = []
    for key, is_list in NUMERIC_KEYS:
        v = f"[{value}, 3.0, 4.0]" if is_list else value
        result = acc("run", SHIPPED, "--out", tmp_path / "o", *SHORT, "--set", f"{key}={v}")
        if result.status != 2:
            accepted.append(key)
            continue
        assert_one_line_error(result, "--set", key)
    assert not accepted, f"accepted {value}: {accepted}"
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("setting", "key"),
    [
        ("controller.reference_force_N=1e308", "controller.reference_force_N"),
        ("feed_drive.bandwidth_rad_s=5e-324", "feed_drive.bandwidth_rad_s"),
        ("force_process.gain_multiplier=5e-324", "force_process.gain_multiplier"),
        ("simulation.plant_step_s=5e-324", "simulation.plant_step_s"),
        ("simulation.control_period_s=9223372036854775807", "simulation.control_period_s"),
    ],
)
def test_absurd_magnitudes_are_refused(tmp_path, setting, key):
    result = acc("run", SHIPPED, "--out", tmp_path / "o", *SHORT, "--set", setting)
    assert_one_line_error(result, key, "magnitude")
    assert not (tmp_path / "o").exists()


def test_time_grid_beyond_the_step_limit_is_refused_with_the_count(tmp_path):
    result = acc("run", SHIPPED, "--out", tmp_path / "o", "--set", "simulation.time_limit_s=1e12")
    line = assert_one_line_error(result, "simulation.time_limit_s", "plant steps per run")
    assert "1e+15" in line and "limit 1e+08" in line  # the documented 1e8 steps per run


def test_a_time_limit_shorter_than_one_step_is_refused(tmp_path):
    result = acc("run", SHIPPED, "--out", tmp_path / "o", "--set", "simulation.time_limit_s=1e-6")
    assert_one_line_error(result, "simulation.time_limit_s", "shorter than one plant step")


def test_trace_memory_is_estimated_and_refused_before_allocating(tmp_path):
    # 1e7 steps recorded every step: about 2.3 GiB of traces, over the 2 GiB limit
    result = acc("run", SHIPPED, "--out", tmp_path / "o", "--set", "simulation.time_limit_s=1e4")
    line = assert_one_line_error(result, "simulation.time_limit_s", "GiB", "limit 2 GiB")
    assert not (tmp_path / "o").exists()
    assert "10000000 plant steps" in line


def test_current_sensing_speed_loop_limit_is_checked_with_the_scenario(tmp_path):
    """A plausible 5 ms step: bandwidth x step = 1 > 0.5, refused naming the bandwidth."""
    result = acc(
        "run", GEOMETRIC, "--out", tmp_path / "o", "--set", "simulation.plant_step_s=0.005",
        "--set", "simulation.time_limit_s=0.5",
    )
    assert_one_line_error(
        result, "--set", "current_sensing.speed_loop_bandwidth_rad_s", "0.5", "100 rad/s"
    )


@pytest.mark.parametrize(
    ("settings", "key"),
    [
        (["workpiece.axial_depth_mm=[0.0, 0.0, 0.0]"], "workpiece.axial_depth_mm"),
        (["current_sensing.identification_time_s=1e-6"], "current_sensing.identification_time_s"),
        (["controller.programmed_feed_mm_min=inf"], "controller.programmed_feed_mm_min"),
        (["controller.reference_force_N=1e-3"], "controller.reference_force_N"),
        (["geometry.tooth_passing=true", "geometry.teeth=4611686018427387904"], "geometry.teeth"),
        (["current_sensing.identification_time_s=1000"], "current_sensing.identification_time_s"),
    ],
)
def test_geometric_and_current_sensing_conditions_name_the_key(tmp_path, settings, key):
    argv = ["run", GEOMETRIC, "--out", tmp_path / "o", "--set", "simulation.time_limit_s=0.3"]
    for s in settings:
        argv += ["--set", s]
    assert_one_line_error(acc(*argv), key)


def test_nan_in_the_process_table_names_the_table_not_the_part(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        (ROOT / "experiments" / "kim_chung_2001.toml")
        .read_text()
        .replace("radial_depth_mm = [2.0, 3.0, 4.0]\nk2", "radial_depth_mm = [nan, 3.0, 4.0]\nk2")
    )
    line = assert_one_line_error(acc("run", path, "--out", tmp_path / "o"), str(path))
    assert "force_process.radial_depth_mm" in line and "workpiece" not in line


@pytest.mark.parametrize(
    "setting",
    [
        "nominal_plant.bandwidth_rad_s=1e-12",  # the PI design's root find used to fail
        "feed_drive.bandwidth_rad_s=1e-12",  # a drive that hardly moves: never finishes
        "force_process.gain_multiplier=1e-12",  # a huge safe feed
        "force_process.p2_rad_s=[-1e12, -3.75, -5.35]",  # a very fast process pole
        "feed_drive.bandwidth_rad_s=1e12",  # a very fast drive
    ],
)
def test_extreme_but_accepted_values_run_to_finite_metrics(tmp_path, recwarn, setting):
    result = acc("run", SHIPPED, "--out", tmp_path / "o", *SHORT, "--set", setting)
    assert result.status == 0, result.err
    assert "Traceback" not in result.err and "Warning" not in result.err
    numeric = [str(w.message) for w in recwarn if issubclass(w.category, RuntimeWarning)]
    assert not numeric  # no overflow on the way, e.g. in the exact discretisation
    summary_is_finite(tmp_path / "o")
