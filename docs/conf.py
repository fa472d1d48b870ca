"""Sphinx configuration of the acc documentation site.

Build it with ``python3 -m sphinx -W --keep-going -b html docs docs/_build/html`` (the tests
build it the same way).  The pages are Markdown (MyST), the API reference comes from the
numpydoc docstrings, and the scenario key reference is generated from the code's own key
tables by the local extension ``docs/_ext/scenario_keys.py``.
"""

from __future__ import annotations

import sys
import types
import typing
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(ROOT))

import acc  # noqa: E402

# ``python -m acc`` runs the command line when its module is imported.  The API pages do not
# list private modules, but autosummary imports every submodule while it walks a package:
# it gets an empty module instead of a command line reading sphinx-build's arguments.
sys.modules.setdefault("acc.__main__", types.ModuleType("acc.__main__"))

project = "acc"
author = "The acc authors"
copyright = "The acc authors, MIT License"  # noqa: A001
release = acc.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc_template_once",  # numpydoc, its template compiled once (docs/_ext)
    "scenario_keys",
    "notebook_links",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
# tables/: written by the study scripts, included by the pages (not pages themselves)
exclude_patterns = ["_build", "**/.ipynb_checkpoints", "tables"]
templates_path: list[str] = []

# --- MyST ------------------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3  # README-style links to a heading (#which-controller-to-pick)

# --- API reference ---------------------------------------------------------------------------
autosummary_generate = True  # stubs under docs/api/generated/ (ignored by git)
autosummary_imported_members = False
# a module's page documents what the module defines; a name it re-exports in ``__all__``
# is documented where it is defined (once)
autodoc_default_options = {"members": True, "ignore-module-all": True}
autodoc_typehints = "none"  # the numpydoc sections give types with units; signatures stay short
autodoc_use_type_comments = False  # annotations only: no source parse per signature (Sphinx 9)
autodoc_member_order = "bysource"
# numpydoc renders each class's Attributes/Methods sections itself; listing every member again
# as an autosummary table would describe each attribute twice (duplicate object warnings).
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# --- HTML ------------------------------------------------------------------------------------
html_theme = "alabaster"
html_title = f"acc {release}"
html_static_path: list[str] = []
html_theme_options = {
    "description": "adaptive cutting-force control workbench for CNC milling",
    "fixed_sidebar": True,
    "page_width": "1200px",
    "sidebar_width": "260px",
}


def _skip_type_aliases(app: Any, what: str, name: str, obj: Any, skip: bool,
                       options: Any) -> bool | None:
    """Leave out type aliases (``Cell = tuple[float, float]``): they are not classes."""
    if isinstance(obj, types.GenericAlias | types.UnionType) or (
        type(obj).__module__ == "typing" and typing.get_origin(obj) is not None
    ):
        return True
    return None


def _drop_empty_globs(app: Any, docname: str, source: list[str]) -> None:
    """Pages written beside this site (``python_control*``, ``linuxcnc*``, ``reproduction_*``)
    are listed in the contents by glob patterns; a pattern that matches no page yet is left
    out of the contents instead of failing the build."""
    if docname != root_doc:
        return
    kept = []
    in_toctree = False
    for line in source[0].splitlines(keepends=True):
        entry = line.strip()
        if entry.startswith("```"):
            in_toctree = entry == "```{toctree}"
        elif in_toctree and "*" in entry and not any(DOCS.glob(entry + ".md")):
            continue
        kept.append(line)
    source[0] = "".join(kept)


def setup(app: Any) -> None:
    app.connect("autodoc-skip-member", _skip_type_aliases)
    app.connect("source-read", _drop_empty_globs)
