"""``python -m acc``: the ``acc`` command line."""

from acc.cli.main import entry

entry()
