"""The study pages' tables are the study scripts' output, not hand copies.

Each study script in ``experiments/`` writes its page's table(s) as Markdown into
``OUT/tables/`` (or ``--tables DIR``); the committed ones live in ``docs/tables/`` and the
pages include them with MyST's ``{include}``.  These tests run every script in its quick
mode (or with a small seed count) into a temporary directory and check that what it writes
has the structure of the committed file (the comment line naming the command, every
table's header and row labels), that each committed table is included by a page that states
the command regenerating it, and, for the cheap studies, that running the page's exact
command gives the committed file byte for byte.
"""

from __future__ import annotations

import os
import re
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TABLES = ROOT / "docs" / "tables"
EXPERIMENTS = ROOT / "experiments"
PAGES = [*(ROOT / "docs").glob("labs/*.md"), *(ROOT / "docs").glob("concepts/*.md"),
         *(ROOT / "docs").glob("results/*.md")]
COMMENT = re.compile(r"^<!-- written by `(?P<command>[^`]+)`; do not edit -->$")


def run_script(script: str, *args: str, cwd: Path) -> None:
    """Run ``experiments/<script>.py`` with ``args`` from ``cwd`` as ``python`` runs a
    script (``__main__``, ``sys.argv``), in this process: the interpreter and the compiled
    loops are already loaded (about a second a script less).  Fail if it exits non-zero;
    the working directory, ``sys.argv``, ``sys.path`` and the modules it imported from
    ``experiments/`` are put back."""
    path = str(EXPERIMENTS / f"{script}.py")
    saved_argv, saved_path, saved_cwd = sys.argv[:], sys.path[:], os.getcwd()
    before = set(sys.modules)
    sys.argv = [path, *args]
    os.chdir(cwd)
    try:
        runpy.run_path(path, run_name="__main__")
        code: object = 0
    except SystemExit as exc:
        code = exc.code
    finally:
        sys.argv[:] = saved_argv
        sys.path[:] = saved_path
        os.chdir(saved_cwd)
        for name in set(sys.modules) - before:
            if str(getattr(sys.modules[name], "__file__", "") or "").startswith(str(EXPERIMENTS)):
                del sys.modules[name]
    assert code in (0, None), f"{script}.py exited with {code!r}"


def tables_of(text: str) -> list[tuple[str, list[str]]]:
    """Every Markdown table of ``text``: its header line and the first cell of each row."""
    out: list[tuple[str, list[str]]] = []
    block: list[str] = []
    for line in [*text.splitlines(), ""]:
        if line.startswith("|"):
            block.append(line)
            continue
        if block:
            assert re.fullmatch(r"\|(---\|)+", block[1]), block[:2]
            out.append((block[0], [row.split("|")[1].strip() for row in block[2:]]))
            block = []
    return out


def shape(header: str) -> str:
    """A table header with its numbers (seed and run counts) masked."""
    return re.sub(r"\d+", "#", header)


def command_of(text: str) -> str:
    """The command named in a table file's first line."""
    match = COMMENT.match(text.splitlines()[0])
    assert match, text.splitlines()[0]
    return match["command"]


#: Options that change no number of a table (where the files go, how many processes).
PLACEMENT = ("--out", "--tables", "--table-name", "--workers", "--threads")


def options(command: str) -> list[tuple[str, ...]]:
    """The options of a ``python experiments/<script>.py ...`` command line, each with its
    values, sorted, without :data:`PLACEMENT`."""
    groups: list[list[str]] = []
    for word in command.split()[2:]:
        if word.startswith("--"):
            groups.append([word])
        else:
            groups[-1].append(word)
    return sorted(tuple(g) for g in groups if g[0] not in PLACEMENT)


def committed(name: str) -> str:
    return (TABLES / name).read_text(encoding="utf-8")


def quick_campaign(tmp_path: Path, seeds: int) -> Path:
    """The disturbance study's campaign with ``seeds`` samples per grid point."""
    text = (EXPERIMENTS / "disturbance_rejection.toml").read_text(encoding="utf-8")
    text = re.sub(r"^samples_per_point = \d+$", f"samples_per_point = {seeds}", text,
                  flags=re.M)
    text = text.replace('base = "kim_chung_2001.toml"',
                        f'base = "{(EXPERIMENTS / "kim_chung_2001.toml").as_posix()}"')
    path = tmp_path / "campaign.toml"
    path.write_text(text, encoding="utf-8")
    return path


RESONANT = ("--kinds", "adaptive_pi", "--set", "controller.resonant_frequency_hz=10.0",
            "--set", "controller.resonant_gain_per_N_s=0.3",
            "--set", "controller.resonant_phase_deg=-165.0",
            "--table-name", "robust_design_resonant")

#: run id -> (script, quick arguments, the table files it writes = their committed names)
QUICK = {
    "disturbance_rejection": ("disturbance_rejection", ("--workers", "2"),
                              ("disturbance_rejection.md",)),
    "material_hardness": ("material_hardness", ("--seeds", "2"), ("material_hardness.md",)),
    "compare_controllers": ("compare_controllers", ("--seeds", "2"),
                            ("compare_controllers.md",)),
    "observer_structures": ("observer_structures", ("--seeds", "2"),
                            ("observer_structures.md",)),
    "estimator_convergence": ("estimator_convergence", ("--seeds", "1"),
                              ("estimator_convergence.md",)),
    "estimator_convergence_unmodelled": (
        "estimator_convergence",
        ("--seeds", "1", "--methods", "output_error", "--unmodelled-filter"),
        ("estimator_convergence_unmodelled.md",)),
    "breakage_under_force_control": ("breakage_under_force_control", ("--seeds", "2"),
                                     ("breakage_under_force_control.md",)),
    "adaptive_advantage": ("adaptive_advantage", ("--quick",), ("adaptive_advantage.md",)),
    "robust_design": ("robust_design", ("--quick", "--seeds", "1"), ("robust_design.md",)),
    "robust_design_resonant": ("robust_design", ("--quick", "--seeds", "1", *RESONANT),
                               ("robust_design_resonant.md",)),
}


#: The quick runs the suite makes (the others cost 25-40 s each on 2 cores: adaptive_advantage;
#: compare_controllers, whose page command is re-run whole below).
IN_SUITE = sorted(set(QUICK) - {"adaptive_advantage", "compare_controllers"})


@pytest.mark.parametrize("run", IN_SUITE)
def test_quick_run_writes_the_committed_tables_structure(run, tmp_path):
    script, args, names = QUICK[run]
    extra = (("--campaign", str(quick_campaign(tmp_path, 1)))
             if script == "disturbance_rejection" else ())
    run_script(script, "--out", str(tmp_path / "out"), *args, *extra, cwd=tmp_path)
    for name in names:
        written = (tmp_path / "out" / "tables" / name).read_text(encoding="utf-8")
        page = committed(name)
        # the same script, differing only in the arguments the quick run changed
        assert command_of(written).split()[:2] == command_of(page).split()[:2]
        quick, full = tables_of(written), tables_of(page)
        assert len(quick) == len(full) and quick, name
        for (head_q, rows_q), (head_f, rows_f) in zip(quick, full, strict=True):
            if run == "robust_design":
                # --quick has no co-design: the reference is pi and the co-designed and
                # extra-margin designs are missing; every quick design is a committed row
                assert shape(head_q) == shape(head_f.replace("pi (co-design)'s", "pi's"))
                assert set(rows_q) < set(rows_f)
            else:
                assert shape(head_q) == shape(head_f)
                assert rows_q == rows_f


def test_every_committed_table_is_included_by_a_page_that_states_its_command():
    includes = {}
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for target in re.findall(r"^```\{include\} (\S+)$", text, flags=re.M):
            path = (page.parent / target).resolve()
            if path.parent == TABLES:
                includes.setdefault(path.name, []).append((page, text))
    names = sorted(p.name for p in TABLES.glob("*.md"))
    assert names and sorted(includes) == names
    for name, pages in includes.items():
        command = command_of(committed(name))
        for page, text in pages:
            # a code span with the command's words and --tables docs/tables regenerates it
            flat = " ".join(text.split())  # a command may wrap over lines
            spans = [s for s in re.findall(r"python experiments/[^`]+", flat)
                     if "--tables docs/tables" in s and s.split()[:2] == command.split()[:2]]
            assert any(options(s) == options(command) for s in spans), (page.name, command)


@pytest.mark.parametrize("script", ["compare_controllers", "observer_structures"])
def test_the_pages_command_reproduces_the_committed_table(script, tmp_path):
    name = f"{script}.md"
    command = command_of(committed(name)).split()
    assert command[:2] == ["python", f"experiments/{script}.py"]
    run_script(script, "--out", str(tmp_path / "out"), "--tables", str(tmp_path / "tables"),
               *command[2:], cwd=ROOT)
    assert (tmp_path / "tables" / name).read_bytes() == (TABLES / name).read_bytes()


def test_robust_design_oracle_table_is_what_the_script_writes():
    # the oracle needs the co-design (minutes): re-render the committed rows with the
    # script's own writer and compare byte for byte
    sys.path.insert(0, str(EXPERIMENTS))
    try:
        from robust_design import oracle_page_table
    finally:
        sys.path.remove(str(EXPERIMENTS))
    text = committed("robust_design_oracle.md")
    lines = [ln for ln in text.splitlines() if ln.startswith("| ")][1:]
    head = text.splitlines()[2]
    reference = re.search(r"p95 / (.+)'s \(95 % CI\)", head)[1]
    rows, runs = [], set()
    for line in lines:
        design, p95, ratio, median, osc = (c.strip() for c in line.strip("|").split("|"))
        value, interval = re.fullmatch(r"(\S+) \((.+)\)", ratio).groups()
        count, total = osc.split(" / ")
        runs.add(int(total))
        rows.append({"design": design, "p95_iae_N_s": float(p95), "ratio": float(value),
                     "ratio_ci95": interval, "median_iae_N_s": float(median),
                     "oscillating_runs": int(count)})
    assert len(runs) == 1
    assert oracle_page_table(rows, reference, runs.pop(), command_of(text)) == text
