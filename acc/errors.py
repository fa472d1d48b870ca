"""Errors the command line reports in one line (exit status 2), importable without the engine."""

from __future__ import annotations


class ScenarioError(ValueError):
    """A scenario that cannot be run; the message names the file and key."""


__all__ = ["ScenarioError"]
