"""The slow list of ``tests/conftest.py`` names tests that exist: a misspelt or renamed entry
would silently leave a slow test in the fast subset."""

from __future__ import annotations

import ast
from pathlib import Path

from tests.conftest import SLOW

TESTS = Path(__file__).resolve().parent


def _test_functions(module: Path) -> set[str]:
    """Names of the test functions defined at a module's top level."""
    tree = ast.parse(module.read_text(encoding="utf-8"))
    return {node.name for node in tree.body
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.name.startswith("test_")}


def test_every_slow_entry_is_a_test_of_its_module():
    missing = []
    for module, names in SLOW.items():
        path = TESTS / module
        assert path.is_file(), module
        defined = _test_functions(path)
        missing += [f"{module}::{name}" for name in names if name not in defined]
    assert not missing, missing
