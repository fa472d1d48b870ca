"""Property-based fuzz of every input the command line reads.

Scenario, campaign and gate files and ``--set`` values are mutated (types, non-finite and
extreme values, lengths, encodings, structure).  Whatever the mutation, a command either
succeeds (exit 0, finite metrics where a run completed) or fails with exit 2 and one line
``acc: error: <file or --set>: ...`` naming the key, and never with a traceback or a partial
output directory.

Cost control: runs are short (2 ms step, 0.3 s); the trace-memory limit is lowered to 16 MiB
for these tests so a mutated time grid is refused instead of simulated for seconds; and the
keys that size the compiled engine (dead times) are mutated with values that either are
refused or keep the default delay line, since every new delay-line size compiles the engine
anew.  Hypothesis runs derandomized (the same cases every time).
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

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import acc.engine.simulate as engine_simulate
from acc.scenarios.force import SECTIONS, field_types
from tests.cli_run import ROOT, Outcome, acc

if typing.TYPE_CHECKING:
    from collections.abc import Callable

BASE_TEXT = (ROOT / "experiments" / "kim_chung_2001.toml").read_text().replace(
    "plant_step_s = 0.001 ", "plant_step_s = 0.002 "
).replace("time_limit_s = 60.0", "time_limit_s = 0.3")

FUZZ = settings(
    max_examples=100,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def _keys() -> list[tuple[str, str, Any]]:
    out = []
    for section, cls in SECTIONS.items():
        for key, tp in field_types(cls).items():
            if typing.get_origin(tp) in (typing.Union, types.UnionType):
                tp = next(a for a in typing.get_args(tp) if a is not type(None))
            out.append((section, key, tp))
    return out


KEYS = _keys()
#: Keys whose accepted values size the compiled engine (a new size compiles it anew).
SIZING = {"feed_drive.dead_time_s", "nominal_plant.dead_time_s", "controller.kind"}
CURATED_SIZING = [0.1, 0.102, 0.0, -0.1, math.nan, math.inf, 1e300, 5e-324, 0.1001, "pi", 7]

NASTY: list[Any] = [
    math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 5e-324, 1e-13, 1e-300, 1e300,
    1.7976931348623157e308, 1e13, 2**63 - 1, -(2**63), 3, True, False, "", "x",
    "\u00e9\u4e2d\U0001f600", "y" * 200_000, [], [math.nan], [1e300, 1.0, 1.0], [[1.0]], {},
    {"a": 1}, [1.0] * 1001, ["a", "b"],
]


def values(tp: Any) -> st.SearchStrategy:
    """Values to put at a key of type ``tp``: nasty ones, and plausible ones of its type."""
    plausible: list[st.SearchStrategy] = [st.sampled_from(NASTY)]
    floats = st.floats(allow_nan=True, allow_infinity=True)
    if tp is float:
        plausible.append(floats)
    elif tp is int:
        plausible.append(st.integers(min_value=-(2**66), max_value=2**66))
    elif tp is bool:
        plausible.append(st.booleans())
    elif tp is str:
        plausible.append(st.text(max_size=12))
    else:  # a list of numbers
        plausible.append(st.lists(floats, max_size=6))
        plausible.append(st.lists(st.sampled_from([0.0, 2.0, 3.0, 4.0, 10.0, 20.0]), max_size=6))
    return st.one_of(plausible)


def to_toml(value: Any) -> str:
    """A Python value as a TOML value (inline)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        escaped = "".join(
            c if c.isprintable() and c not in '"\\' else f"\\u{ord(c):04x}"
            if ord(c) < 0x10000 else f"\\U{ord(c):08x}"
            for c in value
        )
        return f'"{escaped}"'
    if isinstance(value, list):
        return "[" + ", ".join(to_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {to_toml(v)}" for k, v in value.items()) + " }"
    raise TypeError(value)  # pragma: no cover


def with_value(text: str, section: str, key: str, value: Any) -> str:
    """``text`` with ``section.key`` set to ``value`` (replacing or adding the line)."""
    line = f"{key} = {to_toml(value)}"
    pattern = re.compile(rf"(?m)^{re.escape(key)}\s*=.*$")
    start = text.find(f"[{section}]")
    if start < 0:
        return text + f"\n[{section}]\n{line}\n"
    end = text.find("\n[", start + 1)
    end = len(text) if end < 0 else end
    body = text[start:end]
    body = pattern.sub(lambda _: line, body, count=1) if pattern.search(body) else (
        body.rstrip("\n") + f"\n{line}\n"
    )
    return text[:start] + body + text[end:]


STRUCTURE: list[Callable[[str], str | bytes]] = [
    lambda t: t + "\n[no_such_section]\na = 1\n",
    lambda t: t.replace("[sensor]", "[sensor]\nno_such_key = 1", 1),
    lambda t: t.replace("[metrics]", "metrics = 5\n[metrics_]", 1),
    lambda t: t.replace("[controller]", "[controller]\nkind = 'pi'", 1),  # duplicate key
    lambda t: t[: len(t) // 3],
    lambda t: t.replace("noise_std_N = 5.0", "noise_std_N = " + "[" * 300 + "]" * 300, 1),
    lambda t: "sensor = [1, 2]\n" + t,
    lambda t: t.encode("utf-16"),
    lambda t: t.replace("Kim", "K\u00efm").encode("latin-1", "replace"),
    lambda t: t.encode() + b"\x00\xff\xfe",
    lambda t: b"\xef\xbb\xbf" + t.encode(),
    lambda t: t.replace("[simulation]", "[[simulation]]", 1),
    lambda t: t.replace("[workpiece]", "[workpiece.sub]", 1),
]


def check_outcome(result: Outcome, out: Path, source: str, key: str | None) -> None:
    """The contract: exit 0 with a finite summary, or exit 2 in one line naming the source
    (and the mutated key when the mutation was a value), never a traceback or a partial
    output directory."""
    event(f"exit {result.status}")
    assert "Traceback" not in result.err, result.err[-3000:]
    assert result.status in (0, 2), (result.status, result.err[-3000:])
    if result.status == 2:
        lines = result.err_lines
        assert len(lines) == 1, result.err[-3000:]
        line = lines[0]
        assert line.startswith("acc: error: ") and len(line) < 1500, line[:300]
        assert source in line, (source, line[:300])
        if key is not None and "not valid TOML" not in line and "nesting" not in line:
            section = key.split(".")[0]
            assert key in line or f"[{section}]" in line or re.search(
                r"\b[a-z_]+\.[a-z_0-9]+", line
            ), line[:300]
        assert not out.exists() or not (out / "summary.csv").exists()
        return
    with (out / "summary.csv").open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert rows
    for row in rows:
        for k, v in row.items():
            assert v.lower() not in ("inf", "-inf"), (k, v)
        if row["failed"] == "False":
            for k in ("iae_N_s", "ise_N2_s", "cutting_time_s", "conventional_time_s"):
                assert math.isfinite(float(row[k])), (k, row)


@pytest.fixture(autouse=True)
def small_trace_budget(monkeypatch):
    monkeypatch.setattr(engine_simulate, "MAX_TRACE_BYTES", 16 * 1024**2)


KEY_INDEX = st.integers(min_value=0, max_value=len(KEYS) - 1)


@st.composite
def key_and_value(draw: Any) -> tuple[str, str, Any]:
    section, key, tp = KEYS[draw(KEY_INDEX)]
    if f"{section}.{key}" in SIZING:
        return section, key, draw(st.sampled_from(CURATED_SIZING))
    return section, key, draw(values(tp))


@FUZZ
@given(kv=key_and_value(), via_set=st.booleans())
def test_fuzz_scenario_values_in_the_file_or_in_set(kv, via_set):
    section, key, value = kv
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        path = d / "s.toml"
        out = d / "out"
        if via_set:
            path.write_text(BASE_TEXT, encoding="utf-8")
            argv = ["--set", f"{section}.{key}={to_toml(value)}"]
            source = "--set"
        else:
            path.write_text(with_value(BASE_TEXT, section, key, value), encoding="utf-8")
            argv, source = [], str(path)
        result = acc("run", path, "--out", out, *argv)
        check_outcome(result, out, source, f"{section}.{key}")
        if result.status == 2:
            assert sorted(p.name for p in d.iterdir()) == ["s.toml"]


@FUZZ
@given(mutation=st.integers(min_value=0, max_value=len(STRUCTURE) - 1))
def test_fuzz_scenario_structure_and_encoding(mutation):
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        path = d / "s.toml"
        content = STRUCTURE[mutation](BASE_TEXT)
        if isinstance(content, str):
            path.write_text(content, encoding="utf-8")
        else:
            path.write_bytes(content)
        out = d / "out"
        check_outcome(acc("run", path, "--out", out), out, str(path), None)


CAMPAIGN_HEAD = {
    "name": "c", "seed": 3, "samples_per_point": 2, "chunk_runs": 2, "combine": "product",
    "record_every_steps": 0,
}
DISTS = ["uniform", "loguniform", "normal", "integers", "choice", "nope"]


@st.composite
def campaign_text(draw: Any) -> tuple[str, str | None]:
    """A campaign over the short base scenario with one mutated part, and the key it names."""
    head = dict(CAMPAIGN_HEAD)
    lines_set = ["simulation.time_limit_s = 0.3", "simulation.plant_step_s = 0.002"]
    grid: list[str] = ['controller.kind = ["pi", "constant"]']
    random: list[str] = []
    part = draw(st.sampled_from(["head", "set", "grid", "random"]))
    section, key, value = draw(key_and_value())
    dotted = f"{section}.{key}"
    named: str | None = dotted
    if part == "head":
        hk = draw(st.sampled_from([*CAMPAIGN_HEAD, "bogus"]))
        head[hk] = draw(st.sampled_from([*NASTY, "../up", "a/b", ".", 10**7, 0, -1, "zip"]))
        named = f"campaign.{hk}"
    elif part == "set":
        if dotted not in SIZING:
            lines_set.append(f"{dotted} = {to_toml(value)}")
    elif part == "grid":
        if dotted not in SIZING and not dotted.startswith("simulation."):
            grid.append(f"{dotted} = {to_toml([value, value])}")
    else:
        dist = draw(st.sampled_from(DISTS))
        a = draw(st.sampled_from([*NASTY[:14], 0.5, 1.0, 2.0]))
        b = draw(st.sampled_from([*NASTY[:14], 1.0, 3.0, 2**70]))
        params = {"choice": f"values = [{to_toml(a)}, {to_toml(b)}]",
                  "normal": f"mean = {to_toml(a)}, std = {to_toml(b)}"}.get(
            dist, f"low = {to_toml(a)}, high = {to_toml(b)}"
        )
        size = draw(st.sampled_from(["", ", size = 3", ", size = 1000000000", ", quantum = 0.5"]))
        if dotted not in SIZING and not dotted.startswith("simulation."):
            random.append(f'{dotted} = {{ dist = "{dist}", {params}{size} }}')
    text = "[campaign]\n" + "\n".join(f"{k} = {to_toml(v)}" for k, v in head.items())
    text += '\nbase = "base.toml"\n[set]\n' + "\n".join(lines_set)
    text += "\n[grid]\n" + "\n".join(grid)
    if random:
        text += "\n[random]\n" + "\n".join(random)
    return text + "\n", named


@FUZZ
@given(case=campaign_text())
def test_fuzz_campaign_files(case):
    text, key = case
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "base.toml").write_text(BASE_TEXT, encoding="utf-8")
        path = d / "c.toml"
        path.write_text(text, encoding="utf-8")
        out = d / "out"
        result = acc("sweep", path, "--out", out, "--workers", "1", "--no-progress",
                     "--no-figures")
        check_outcome(result, out, str(d), key)
        if result.status == 2:
            assert sorted(p.name for p in d.iterdir()) == ["base.toml", "c.toml"]


GATE_VALUES: list[Any] = [
    *NASTY[:22], "rms_error_N", "machining_time_s", "controller", "failed", "p95", "p101",
    "failed_count", "failed_fraction", "mean", "c.toml", "nope.toml", {"controller": "pi"},
    {"controller": "PI"}, {"reference_force_N": 500}, {"nope": 1}, {"controller": [1]},
]


@st.composite
def gate_text(draw: Any) -> str:
    check = {"name": "n", "campaign": "c.toml", "metric": "rms_error_N", "statistic": "p95",
             "max": 1000.0}
    for _ in range(draw(st.sampled_from([0, 1, 1, 1, 2]))):
        k = draw(st.sampled_from([*check, "min", "where", "bogus"]))
        check[k] = draw(st.sampled_from(GATE_VALUES))
    head = ""
    if draw(st.integers(min_value=0, max_value=5)) == 0:  # a malformed head, now and then
        head = draw(st.sampled_from(["[gate]\nname = 'g'\n", "gate = 5\n", "check = [1]\n",
                                     "[gate]\nname = 3\n"]))
    return head + "[[check]]\n" + "\n".join(f"{k} = {to_toml(v)}" for k, v in check.items())


@pytest.fixture(scope="module")
def gate_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz_gate")
    (d / "base.toml").write_text(BASE_TEXT, encoding="utf-8")
    (d / "c.toml").write_text(
        "[campaign]\nname = 'c'\nbase = 'base.toml'\nsamples_per_point = 2\n"
        "[grid]\ncontroller.kind = ['pi', 'constant']\n",
        encoding="utf-8",
    )
    return d


@FUZZ
@given(text=gate_text())
def test_fuzz_gate_files(gate_dir, text):
    path = gate_dir / "g.toml"
    path.write_text(text + "\n", encoding="utf-8")
    out = gate_dir / "out"  # shared: re-running a gate into the same --out reuses its sweep
    result = acc("check", path, "--out", out, "--workers", "1", "--no-progress")
    event(f"exit {result.status}")
    assert "Traceback" not in result.err, result.err[-3000:]
    assert result.status in (0, 1, 2), result.err[-3000:]
    if result.status == 2:
        lines = result.err_lines
        assert len(lines) == 1 and lines[0].startswith("acc: error: "), result.err[-3000:]
        assert str(gate_dir) in lines[0] or "--" in lines[0], lines[0][:300]
    else:
        table = result.out.splitlines()
        assert table[0].split()[:4] == ["check", "statistic", "selected", "runs"]
        if " 0 " in table[2][: table[0].index("measured")]:  # nothing selected or used
            assert table[2].rstrip().endswith("FAIL"), result.out
