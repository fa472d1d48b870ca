"""One loader for every input: any file or ``--set`` value is read or refused in one line.

Each case is a defect class: text that is not UTF-8, a directory, deep nesting, values too
long to echo, ``--set`` values blamed on the file; for every file kind the commands read
(scenario, base scenario, campaign, gate).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli_run import SHIPPED, SHORT, acc, assert_one_line_error

LATIN1 = "# Kim & Chung caf\u00e9\n".encode("latin-1")
TINY_CAMPAIGN = f"""[campaign]
name = "tiny"
base = "{Path(SHIPPED).as_posix()}"
samples_per_point = 2
[set]
simulation.plant_step_s = 0.002
simulation.time_limit_s = 0.3
"""


def _files(tmp_path: Path, bad: bytes, which: str) -> tuple[list[str], Path]:
    """The command that reads a file of kind ``which`` whose content is ``bad``, and that
    file."""
    out = tmp_path / "out"
    if which == "scenario":
        path = tmp_path / "s.toml"
        path.write_bytes(bad)
        return ["run", str(path), "--out", str(out)], path
    if which == "base scenario":
        path = tmp_path / "base.toml"
        path.write_bytes(bad)
        camp = tmp_path / "c.toml"
        camp.write_text(TINY_CAMPAIGN.replace(Path(SHIPPED).as_posix(), "base.toml"))
        return ["sweep", str(camp), "--out", str(out), "--workers", "1", "--no-progress"], path
    if which == "campaign":
        path = tmp_path / "c.toml"
        path.write_bytes(bad)
        return ["sweep", str(path), "--out", str(out), "--workers", "1", "--no-progress"], path
    path = tmp_path / "g.toml"
    path.write_bytes(bad)
    (tmp_path / "c.toml").write_text(TINY_CAMPAIGN)
    return ["check", str(path), "--out", str(out), "--workers", "1", "--no-progress"], path


KINDS = ["scenario", "base scenario", "campaign", "gate"]


@pytest.mark.parametrize("which", KINDS)
def test_text_that_is_not_utf8_is_one_line_naming_the_file(tmp_path, which):
    argv, path = _files(tmp_path, LATIN1 + b"[campaign]\n", which)
    line = assert_one_line_error(acc(*argv), str(path), "not UTF-8")
    assert "byte" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("which", KINDS)
def test_a_directory_is_one_line_naming_it(tmp_path, which):
    argv, path = _files(tmp_path, b"", which)
    path.unlink()
    path.mkdir()
    assert_one_line_error(acc(*argv), str(path), "is a directory")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("which", KINDS)
def test_deep_nesting_is_one_line_naming_the_file(tmp_path, which):
    bad = b"[sensor]\nnoise_std_N = " + b"[" * 500 + b"]" * 500 + b"\n"
    argv, path = _files(tmp_path, bad, which)
    assert_one_line_error(acc(*argv), str(path), "nesting")


def test_deep_nesting_in_set_names_set(tmp_path):
    value = "[" * 500 + "]" * 500
    result = acc("run", SHIPPED, "--out", tmp_path / "o", "--set", f"sensor.noise_std_N={value}")
    assert_one_line_error(result, "--set", "nesting")


def test_a_value_too_long_to_echo_is_abbreviated(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[controller]\nkind = "' + "x" * 1_000_000 + '"\n')
    line = assert_one_line_error(acc("run", path, "--out", tmp_path / "o"), "controller.kind")
    assert len(line) < 1000
    assert "1000002 characters" in line or "characters)" in line


def test_a_key_too_long_to_echo_is_abbreviated(tmp_path):
    result = acc("run", SHIPPED, "--out", tmp_path / "o", "--set", f"sensor.{'k' * 100_000}=1")
    line = assert_one_line_error(result, "--set", "unknown key")
    assert len(line) < 1000


@pytest.mark.parametrize(
    ("assignment", "key"),
    [
        ("controller.reference_force_N=abc", "controller.reference_force_N"),
        ("simulation.plant_step_s=0.003", "simulation.control_period_s"),
        ("sensor.noise_std_N=nan", "sensor.noise_std_N"),
    ],
)
def test_an_error_in_a_set_value_names_set_not_the_file(tmp_path, assignment, key):
    line = assert_one_line_error(
        acc("run", SHIPPED, "--out", tmp_path / "o", *SHORT, "--set", assignment),
        "--set",
        key,
    )
    assert "kim_chung_2001.toml" not in line


def test_integers_beyond_64_bits_are_refused(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("[simulation]\nseed = 99999999999999999999999\n")
    assert_one_line_error(acc("run", path, "--out", tmp_path / "o"), str(path), "simulation.seed")
