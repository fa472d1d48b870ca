"""Property-based fuzz of the lab scenario files (axis and contouring), as
:mod:`tests.test_fuzz_inputs` does for the force loop.

Every key of every lab section (the per-axis ``[section.x]`` ones too) is set to a nasty or a
plausible value, in the file or with ``--set``; the files' structure is mutated.  Whatever
the mutation, ``acc run`` either succeeds (exit 0) or fails with exit 2 and one line
``acc: error: <file or --set>: ...`` naming a key, never with a traceback or a partial
output directory; and a run that succeeds is either flagged failed (metrics NaN, a reason
given) or keeps the verdict's bounds, checked here on its traces: every axis's following
error within ``D = 100`` path sizes ``L = max(range of any reference, 1 mm)`` and every
current within ``D`` times the drive's peak (the simulated limit, else the amplifier's
rating: 30 A for Peng's servo axis, seed 000 L1780; 10 A for the elastic axis)
(:mod:`acc.engine.axis_verdicts`).

Cost control (the whole module runs in about half a minute): four short bases (a 0.2 s axis
ramp, a 0.1 s Briquez step, Peng's diamond at 900-1000 samples and 0.05 of Lacerda's
circle); the memory limit lowered to a few MiB so a mutated time grid is refused instead of
simulated; figures drawn up to their axis limits and ticks (where huge or non-finite data
break matplotlib) but not rasterised; and the keys that size the compiled engine (a
contouring path's sample count on the independent-axes loop, whose reference is a record
per sample; a lead-lag delay line) mutated with values that either are refused or keep the
base's size class, since every new size compiles the loop anew.  Every path kind and corner
of the diamond base is given the same size class.  Hypothesis runs derandomized.
"""

from __future__ import annotations

import csv
import math
import re
import tempfile
import types
import typing
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument
from matplotlib.figure import Figure

import acc.scenarios.axis as axis_scenarios
import acc.scenarios.contour as contour_scenarios
from acc.scenarios.axis import AXIS_SECTIONS
from acc.scenarios.contour import CONTOUR_SECTIONS, PER_AXIS_SECTIONS
from acc.scenarios.force import field_types
from tests.cli_run import ROOT, Outcome, acc
from tests.test_fuzz_inputs import to_toml, values, with_value

D = 100.0  # divergence factor (the labs' default)
MIN_PATH_MM = 1.0  # floor of the path size L [mm]
PENG_PEAK_A = 30.0  # Peng App. A amplifier peak (seed 000, L1780)
ELASTIC_PEAK_A = 10.0  # the elastic axis's default current limit [ASSUMED]


def _text(name: str, *replacements: tuple[str, str]) -> str:
    text = (ROOT / "experiments" / name).read_text()
    for old, new in replacements:
        assert old in text, (name, old)
        text = text.replace(old, new)
    return text


#: Short bases: (lab, file text).  The diamond's every path kind and corner lands in one
#: size class (513..1024 samples): lead-in and -out 0.45 s (900), accel/decel ramps of
#: 5 ms (+15), splines of 2 dx / f = 0.1 s (+100), a line or sinusoid of 0.9 s, a circle
#: of 0.29 turns (912).
BASES: dict[str, tuple[str, str]] = {
    "axis_servo": ("axis", _text("peng_servo_axis.toml",
                                 ("duration_s = 1.0", "duration_s = 0.2"),
                                 ("start_s = 0.5", "start_s = 0.1"))),
    "axis_oscillating": ("axis", _text("briquez_huron_axis.toml",
                                       ("duration_s = 2.0", "duration_s = 0.1"))),
    "contour_independent": ("contour", _text(
        "peng_diamond_mismatched.toml", ("lead_in_s = 0.5", "lead_in_s = 0.45"),
        ("lead_out_s = 0.5", "lead_out_s = 0.45\naccel_time_s = 0.005\nduration_s = 0.9\n"
                             "revolutions = 0.29"))),
    "contour_coupled": ("contour", _text("lacerda_circle_40.toml",
                                         ('direction = "ccw"',
                                          'direction = "ccw"\nrevolutions = 0.05'))),
}
BASE_NAMES = list(BASES)

FUZZ = settings(
    max_examples=200,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def _keys(sections: dict[str, type], per_axis: tuple[str, ...] = ()) -> list[tuple[str, str,
                                                                                  Any]]:
    out = []
    for section, cls in sections.items():
        for key, tp in field_types(cls).items():
            if typing.get_origin(tp) in (typing.Union, types.UnionType):
                tp = next(a for a in typing.get_args(tp) if a is not type(None))
            out.append((section, key, tp))
            if section in per_axis:
                out.append((f"{section}.y", key, tp))
    return out


KEYS = {"axis": _keys(AXIS_SECTIONS), "contour": _keys(CONTOUR_SECTIONS, PER_AXIS_SECTIONS)}
#: Keys whose accepted values size the compiled engine, and the values they get (refused,
#: or within the base's size class).
REFUSED = [math.nan, math.inf, -1.0, 0.0, 1e300, 5e-324, 1e-13, "x", True, [1.0]]
SIZING: dict[str, list[Any]] = {
    "lead_lag.computational_delay_samples": [0, 1, 3, 7, -1, 10**7, 2**63 - 1, 2.5, "x"],
    "lead_lag.y.computational_delay_samples": [0, 2, 7, -3, 10**9, "x"],
}
#: Further sizing keys of the independent-axes contouring base.
SIZING_INDEPENDENT: dict[str, list[Any]] = {
    "simulation.plant_step_s": [0.001, 1e-9, 0.0007, 1e-5, *REFUSED],
    "path.lead_in_s": [0.45, 0.4, 0.5, 0.3, 0.4501, 1e5, *REFUSED],
    "path.lead_out_s": [0.45, 0.35, 0.55, 0.4499, 1e6, *REFUSED],
}


#: Factors applied to a numeric key's default: mostly valid runs, some of them unstable.
FACTORS = [0.0, 0.01, 0.1, 0.5, 2.0, 5.0, 10.0, 100.0, 1e4, -1.0]


def scaled(section: str, key: str, tp: Any) -> st.SearchStrategy:
    """A numeric key's default times a factor (or, for a default of 0, a few magnitudes)."""
    sections = AXIS_SECTIONS | CONTOUR_SECTIONS
    default = sections[section.split(".")[0]].__dataclass_fields__[key].default
    if tp not in (int, float) or isinstance(default, bool):
        return values(tp)
    if not default:
        return st.sampled_from([0.1, 1.0, 10.0, 1e3])
    return st.sampled_from([tp(default * f) for f in FACTORS])


#: The coupled base's path size (no size class there: its reference is one array), from a
#: sample or two (refused as too short) to far beyond any limit (refused before allocation).
SIZING_COUPLED: dict[str, list[Any]] = {
    "simulation.plant_step_s": [1e-4, 5e-5, 1e-12, 1e-15, 3e-5, *REFUSED],
    "path.revolutions": [0.05, 0.03, 1e-9, 1e-4, 1e9, 1e15, *REFUSED],
}


@st.composite
def key_and_value(draw: Any) -> tuple[str, str, str, Any]:
    base = draw(st.sampled_from(BASE_NAMES))
    keys = KEYS[BASES[base][0]]
    section, key, tp = keys[draw(st.integers(min_value=0, max_value=len(keys) - 1))]
    dotted = f"{section}.{key}"
    curated = SIZING.get(dotted)
    if base == "contour_independent":
        curated = SIZING_INDEPENDENT.get(dotted, curated)
    elif base == "contour_coupled":
        curated = SIZING_COUPLED.get(dotted, curated)
    if curated:
        value = draw(st.sampled_from(curated))
    elif draw(st.integers(min_value=0, max_value=2)):  # two in three: near the default
        value = draw(scaled(section, key, tp))
    else:
        value = draw(values(tp))
    return base, section, key, value


@pytest.fixture(autouse=True)
def small_budget(monkeypatch):
    """A few MiB of traces per run, and figures drawn to their limits and ticks only."""
    monkeypatch.setattr(axis_scenarios, "MAX_TRACE_BYTES", 4 * 1024**2)
    monkeypatch.setattr(contour_scenarios, "MAX_TRACE_BYTES", 4 * 1024**2)

    def ticks_only(fig: Figure, path: Any, **kwargs: Any) -> None:
        for ax in fig.axes:  # autoscale and the tick locators: where bad data breaks a plot
            ax.xaxis.get_majorticklocs()
            ax.yaxis.get_majorticklocs()
        Path(path).write_bytes(b"png")

    monkeypatch.setattr(Figure, "savefig", ticks_only)


def _peak_current_A(axis: Any) -> float:
    """The drive's peak current [A] by the stated rule (module docstring)."""
    limit = getattr(axis, "current_limit_A", None)
    if limit is None:
        return math.inf  # a speed-commanded axis has no current
    if limit > 0:
        return limit
    return ELASTIC_PEAK_A if hasattr(axis, "carriage_mass_kg") else PENG_PEAK_A


def _check_bounds(out: Path, scenario: Any, lab: str) -> None:
    """A run not flagged failed keeps the bounds on every traced sample."""
    tr = np.load(out / "traces.npz")
    if lab == "axis":
        refs = [tr["x_ref_mm"]]
        errors = [tr["following_error_mm"]]
        currents = [tr["current_A"]] if "current_A" in tr else []
        peak = _peak_current_A(scenario.axis_params)
    else:
        refs = [tr["x_ref_mm"], tr["y_ref_mm"]]
        errors = [tr["x_ref_mm"] - tr["x_mm"], tr["y_ref_mm"] - tr["y_mm"]]
        currents = [tr[k] for k in ("current_x_A", "current_y_A") if k in tr]
        peak = max(_peak_current_A(scenario.axis_x), _peak_current_A(scenario.axis_y))
    size = max(MIN_PATH_MM, *(float(np.ptp(r)) for r in refs))
    for e in errors:
        assert np.isfinite(e).all()
        assert np.abs(e).max() <= D * size, (np.abs(e).max(), D * size)
    for i in currents:
        assert np.abs(i).max() <= D * peak, (np.abs(i).max(), D * peak)


def _event(text: str) -> None:
    """A Hypothesis event (statistics), when inside a Hypothesis test."""
    try:
        event(text)
    except InvalidArgument:
        pass


def check_outcome(result: Outcome, out: Path, source: str, key: str | None,
                  lab: str, scenario_file: Path, overrides: list[str]) -> None:
    """The contract (module docstring)."""
    _event(f"exit {result.status}")
    assert "Traceback" not in result.err, result.err[-3000:]
    assert result.status in (0, 2), (result.status, result.err[-3000:])
    if result.status == 2:
        lines = result.err_lines
        assert len(lines) == 1, result.err[-3000:]
        line = lines[0]
        assert line.startswith("acc: error: ") and len(line) < 1500, line[:300]
        assert source in line, (source, line[:300])
        if key is not None and "not valid TOML" not in line and "nesting" not in line:
            assert re.search(r"\b[a-z_]+\.[a-z_0-9.]+|\[[a-z_.]+\]", line), line[:300]
        assert "simulation failed" not in line, line[:300]  # validation should catch it
        _event(re.sub(r"^acc: error: \S+ ", "", line)[:50])
        assert not out.exists() or not (out / "summary.csv").exists()
        return
    assert not result.err_lines, result.err[-3000:]  # a run that works says nothing on stderr
    with (out / "summary.csv").open(newline="", encoding="utf-8") as fh:
        (row,) = list(csv.DictReader(fh))
    for k, v in row.items():
        assert v.lower() not in ("inf", "-inf"), (k, v)
    assert row["failed"] in ("True", "False"), row
    if row["failed"] == "True":
        _event("flagged failed")
        assert row["failure_reason"], row
        metric = "max_abs_following_error_mm" if lab == "axis" else "max_abs_contour_error_mm"
        assert math.isnan(float(row[metric])), row
        assert f"[FAILED: {row['failure_reason']}]" in result.out
        return
    from acc import scenarios

    _check_bounds(out, scenarios.load(scenario_file, overrides), lab)


@FUZZ
@given(case=key_and_value(), via_set=st.booleans())
def test_fuzz_lab_values_in_the_file_or_in_set(case, via_set):
    base, section, key, value = case
    lab, text = BASES[base]
    event(base)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        path = d / "s.toml"
        out = d / "out"
        if via_set:
            path.write_text(text, encoding="utf-8")
            argv = ["--set", f"{section}.{key}={to_toml(value)}"]
            source = "--set"
        else:
            path.write_text(with_value(text, section, key, value), encoding="utf-8")
            argv, source = [], str(path)
        result = acc("run", path, "--out", out, *argv)
        check_outcome(result, out, source, f"{section}.{key}", lab, path, argv[1:])
        if result.status == 2:
            assert sorted(p.name for p in d.iterdir()) == ["s.toml"]


STRUCTURE = [
    lambda t: t + "\n[no_such_section]\na = 1\n",
    lambda t: t.replace("[simulation]", "[simulation]\nno_such_key = 1", 1),
    lambda t: t.replace("[simulation]", "[simulation]\nmodel = 'force'", 1),  # duplicate key
    lambda t: t.replace('model = "axis"', 'model = "contour"').replace(
        'model = "xy_contour"', 'model = "xy"'),
    lambda t: t.replace('model = "axis"', 'model = "@"').replace(
        'model = "xy_contour"', 'model = "axis"').replace('model = "@"',
                                                          'model = "xy_contour"'),  # swapped
    lambda t: t[: len(t) // 2],
    lambda t: "simulation = [1, 2]\n" + t,
    lambda t: t.replace("[simulation]", "[[simulation]]", 1),
    lambda t: t.replace("[position_controller]", "[position_controller.sub]", 1),
    lambda t: t + "\n[lead_lag.z]\ngain = 1.0\n",
    lambda t: t + "\n[lead_lag]\nx = 5\n",
    lambda t: t + "\n[servo_axis]\ny = [1, 2]\n",
    lambda t: t.encode("utf-16"),
    lambda t: t.encode() + b"\x00\xff\xfe",
]


@settings(FUZZ, max_examples=24)
@given(base=st.sampled_from(BASE_NAMES),
       mutation=st.integers(min_value=0, max_value=len(STRUCTURE) - 1))
def test_fuzz_lab_structure_and_encoding(base, mutation):
    lab, text = BASES[base]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        path = d / "s.toml"
        content = STRUCTURE[mutation](text)
        if isinstance(content, str):
            path.write_text(content, encoding="utf-8")
        else:
            path.write_bytes(content)
        out = d / "out"
        result = acc("run", path, "--out", out)
        check_outcome(result, out, str(path), None, lab, path, [])


def test_every_base_runs_unflagged(tmp_path):
    """The bases themselves are valid, stable runs (what the mutations start from)."""
    for name, (lab, text) in BASES.items():
        path = tmp_path / f"{name}.toml"
        path.write_text(text, encoding="utf-8")
        out = tmp_path / name
        result = acc("run", path, "--out", out)
        assert result.status == 0, (name, result.err)
        check_outcome(result, out, str(path), None, lab, path, [])
        with (out / "summary.csv").open(newline="", encoding="utf-8") as fh:
            assert next(csv.DictReader(fh))["failed"] == "False", name
