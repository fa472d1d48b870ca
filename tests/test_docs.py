"""The documentation site: it builds with warnings as errors, its scenario key reference lists
what the code accepts with the defaults a scenario really gets, the API pages come from the
docstrings, and the README's commands are the ones CI runs.
"""

from __future__ import annotations

import html
import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

from acc.scenarios import from_dict, key_problem, lab_sections
from acc.scenarios.force import SECTIONS, field_types, section_values
from plants.disturbance import Disturbance

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
MODEL_HEADINGS = {"force": "Cutting-force loop", "axis": "Axis lab",
                  "xy_contour": "Contouring lab"}


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site, built as the README says (``-W``: any warning fails the build)."""
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         str(ROOT / "docs"), str(out)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=1200,
    )
    assert done.returncode == 0, done.stderr[-4000:]
    assert "WARNING" not in done.stderr and "ERROR" not in done.stderr, done.stderr[-4000:]
    return out


class _Rows(HTMLParser):
    """The text of every cell of every ``scenario-keys`` table, row by row."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[list[str]] = []
        self._depth = 0  # inside a scenario-keys table
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "table" and "scenario-keys" in (dict(attrs).get("class") or ""):
            self._depth = 1
        elif self._depth and tag == "tr":
            self.rows.append([])
        elif self._depth and tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag == "table":
            self._depth = 0
        elif self._depth and tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append(" ".join("".join(self._cell).split()))
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def key_tables(site: Path) -> dict[str, dict[str, tuple[str, str, str]]]:
    """``{model: {section.key: (type, default, unit)}}`` as the built page shows them."""
    page = (site / "reference" / "scenario_keys.html").read_text(encoding="utf-8")
    parts = re.split(r"<h2>", page)
    out: dict[str, dict[str, tuple[str, str, str]]] = {}
    for model, heading in MODEL_HEADINGS.items():
        (part,) = [p for p in parts if html.unescape(p).startswith(heading)]
        parser = _Rows()
        parser.feed(part)
        rows = [r for r in parser.rows if r and r[0] != "key"]
        assert all(len(r) == 5 for r in rows), rows[:3]
        out[model] = {r[0]: (r[1], r[2], r[3]) for r in rows}
        assert len(out[model]) == len(rows), f"{model}: a key is listed twice"
    return out


def _shown_value(text: str) -> object:
    """A default as the page shows it, read back as TOML (``(none)``: no value)."""
    text = text.split(";")[0].strip()  # per-axis defaults follow a ';'
    return None if text == "(none)" else tomllib.loads(f"v = {text}")["v"]


def _code_value(value: object) -> object:
    return list(value) if isinstance(value, tuple) else value


def test_site_builds_with_warnings_as_errors(site):
    # every page of docs/ is in the site (a page outside the contents is a warning, so the
    # build above would have failed); the pages written beside this one appear when present
    for page in ROOT.joinpath("docs").rglob("*.md"):
        if "_build" in page.parts or "tables" in page.parts:  # tables: included by pages
            continue
        built = site / page.relative_to(ROOT / "docs").with_suffix(".html")
        assert built.is_file(), page


def test_key_reference_lists_every_key_of_every_lab(site):
    tables = key_tables(site)
    # the force loop: every key of the section table the loader checks, and of [[disturbance]]
    expected = {f"{section}.{key}" for section, cls in SECTIONS.items()
                for key in field_types(cls)}
    expected |= {f"disturbance.<name>.{key}" for key in field_types(Disturbance)}
    assert set(tables["force"]) == expected
    for model in ("axis", "xy_contour"):
        sections, _ = lab_sections(model)
        assert set(tables[model]) == {f"{section}.{key}" for section, cls in sections.items()
                                      for key in field_types(cls)}
    # and every key listed is one the labs accept
    for model, rows in tables.items():
        for dotted in rows:
            if not dotted.startswith("disturbance.<name>."):
                assert key_problem(model, dotted) is None, (model, dotted)


@pytest.mark.parametrize("model", ["force", "axis"])
def test_key_reference_defaults_are_what_a_scenario_without_keys_gets(site, model):
    shown = key_tables(site)[model]
    data = {} if model == "force" else {"simulation": {"model": model}}
    scenario = from_dict(data, "<test>")
    sections, _ = lab_sections(model)
    for section in sections:
        values = section_values(getattr(scenario, section))
        for key in field_types(sections[section]):
            value = _shown_value(shown[f"{section}.{key}"][1])
            assert value == _code_value(values.get(key)), (section, key, value, values.get(key))


def test_units_come_from_the_docstrings_or_the_key_names(site):
    force = key_tables(site)["force"]
    assert force["simulation.plant_step_s"][2] == "s"
    assert force["controller.reference_force_N"][2] == "N"
    assert force["feed_drive.bandwidth_rad_s"][2] == "rad/s"
    assert force["metrics.settling_band_pct"][2] == "% of the reference"
    # one docstring entry for two keys, one unit each: "kp_per_N, ki_per_N_s : ... [1/N], [1/(N s)]"
    assert (force["controller.kp_per_N"][2], force["controller.ki_per_N_s"][2]) == (
        "1/N", "1/(N s)")


def test_api_pages_come_from_the_docstrings(site):
    page = (site / "api" / "generated" / "acc.scenarios.force.html").read_text(encoding="utf-8")
    assert 'id="acc.scenarios.force.load_scenario"' in page
    assert 'id="acc.scenarios.force.SimulationParams"' in page
    # numpydoc rendered the class's Attributes section from its docstring
    section = page.split('id="acc.scenarios.force.SimulationParams"')[1][:6000]
    assert "Attributes" in section and "plant_step_s" in section
    for module in ("plants.feed_drive", "controllers.pi_design", "acc.analysis"):
        assert (site / "api" / "generated" / f"{module}.html").is_file(), module


def test_benchmark_tables_are_included_as_written(site):
    page = html.unescape((site / "results" / "benchmarks.html").read_text(encoding="utf-8"))
    for name in ("RESULTS.md", "RESULTS_axis.md", "RESULTS_xy.md", "RESULTS_cli.md",
                 "RESULTS_design.md", "RESULTS_sweep.md", "RESULTS_suite.md"):
        text = (ROOT / "benchmarks" / name).read_text(encoding="utf-8")
        lines = text.splitlines()
        # the first table's first row under its header and separator
        start = next(i for i, line in enumerate(lines) if line.startswith("|"))
        cells = [c.strip() for c in lines[start + 2].strip("|").split("|")]
        # its numbers, as written (other cells may hold Markdown the page renders)
        numbers = [c for c in cells if re.fullmatch(r"[-+0-9.,e ]+", c) and c.strip(", ")]
        assert numbers, (name, lines[start + 2])
        for number in numbers:
            assert f">{number}<" in page, (name, number)


def test_notebooks_are_linked_not_executed(site):
    page = (site / "labs" / "notebooks.html").read_text(encoding="utf-8")
    notebooks = sorted((ROOT / "notebooks").glob("*.ipynb"))
    for notebook in notebooks:
        assert re.search(rf'href="[^"]*_downloads/[^"]*/{re.escape(notebook.name)}"', page)
        downloaded = next((site / "_downloads").rglob(notebook.name))
        assert downloaded.read_bytes() == notebook.read_bytes()  # as committed, not run
    if not notebooks:
        assert "No notebook is in notebooks/ yet." in page


# --- the README ------------------------------------------------------------------------
def _readme() -> str:
    return (ROOT / "README.md").read_text(encoding="utf-8")


def test_readme_starts_with_the_commands_ci_runs():
    first_block = _readme().split("```bash\n", 1)[1].split("```", 1)[0].splitlines()
    install_and_run, test = first_block
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert install_and_run.startswith(
        'python3 -m pip install -e ".[test]" && acc compile && acc run ')
    # CI installs as the README says: the install, then the compile of every kind
    assert 'python3 -m pip install --quiet -e ".[test]"\npython3 -m acc compile' in ci
    assert test == "MPLBACKEND=Agg python3 -m pytest -q -n 3"
    assert "export MPLBACKEND=Agg" in ci and "\npython3 -m pytest -q -n 3\n" in ci
    # the job the first command runs is a shipped scenario
    scenario = install_and_run.split("acc run ")[1].split()[0]
    assert (ROOT / scenario).is_file()


def test_readme_links_point_inside_the_repository():
    readme = _readme()
    links = re.findall(r"\]\(([^)\s]+)\)", readme)
    assert links
    anchors = {re.sub(r"[^a-z0-9 -]", "", h.lower()).replace(" ", "-")
               for h in re.findall(r"^#+ (.+)$", readme, re.M)}
    for link in links:
        assert "://" not in link and not link.startswith(".."), link
        path, _, anchor = link.partition("#")
        if path:
            assert (ROOT / path).exists(), link
        else:
            assert anchor in anchors, link


def test_readme_builds_the_site_with_the_command_the_tests_use():
    assert "python3 -m sphinx -W --keep-going -b html docs docs/_build/html" in _readme()
