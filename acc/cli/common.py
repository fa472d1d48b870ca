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


def failed_title(title: str, row: dict) -> str:
    """A figure's title, with a second line ``FAILED: <reason>`` when the run's summary row
    says it failed (its traces end where the run stopped)."""
    if row.get("failed"):
        import textwrap

        from acc.limits import shorten

        reason = shorten(str(row.get("failure_reason", "")), 150)
        return f"{title}\n" + textwrap.fill(f"FAILED: {reason}", 60)
    return title


__all__ = ["EXIT_INTERRUPTED", "EXIT_USAGE", "CommandError", "failed_title", "say"]
