"""Build hook: ship ``experiments/*.toml`` in the wheel as ``acc/examples/*.toml``.

The metadata lives in ``pyproject.toml``.  The example scenarios, campaigns and gates are kept
once, in ``experiments/`` (scripts and tests refer to them there); a wheel build copies them
flat into the package, so the relative references between them (``base = "..."``,
``campaign = "..."``) still resolve.  An editable install finds them in ``experiments/``
instead (:func:`acc.examples.directory`).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

EXAMPLES = Path(__file__).parent / "experiments"


class BuildPyWithExamples(build_py):
    """``build_py`` that also copies the example TOML files into ``acc/examples/``."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return  # the source tree's experiments/ is found at run time
        target = Path(self.build_lib) / "acc" / "examples"
        target.mkdir(parents=True, exist_ok=True)
        for source in sorted(EXAMPLES.glob("*.toml")):
            shutil.copyfile(source, target / source.name)


setup(cmdclass={"build_py": BuildPyWithExamples})
