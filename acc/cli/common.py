"""What every ``acc`` subcommand module shares: the one-line error, the result lines.

The lab modules (:mod:`acc.cli.axis`, :mod:`acc.cli.contour`) take these from here, not from
:mod:`acc.cli.main`, which imports them.
"""

from __future__ import annotations

import argparse

from acc.errors import AccError

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


class CommandError(AccError):
    """A user error that the command line reports in one line (exit status 2)."""


def say(args: argparse.Namespace, *lines: str) -> None:
    """Print result lines on stdout unless ``--quiet``."""
    if getattr(args, "verbosity", 0) >= 0:
        for line in lines:
            print(line)


__all__ = ["EXIT_INTERRUPTED", "EXIT_USAGE", "CommandError", "say"]
