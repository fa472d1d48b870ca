"""Reading input files and ``--set`` values: the one loader every command goes through.

Scenario files, the base scenario of a campaign, campaign files and gate files are all
read by :func:`read_toml`; command-line overrides by :func:`parse_assignment`.  Whatever
the input, the outcome is a parsed table or :class:`InputError`, whose message is one line
naming the file (or ``--set``): a missing, unreadable or oversized file, a directory, text
that is not UTF-8 (with the byte offset), TOML syntax errors, nesting deeper than
:data:`acc.limits.MAX_NESTING`, integers outside 64 bits.  Values too long to echo are
abbreviated (:func:`acc.limits.abbreviate`).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from acc.errors import ScenarioError
from acc.limits import MAX_INPUT_BYTES, MAX_INTEGER, MAX_NESTING, abbreviate, format_bytes

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: Where ``--set`` values come from, as errors name it.
SET_SOURCE = "--set"


class InputError(ScenarioError):
    """An input file or ``--set`` value that cannot be read (one line naming it)."""


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def read_toml(path: str | Path, what: str = "input") -> dict[str, Any]:
    """Read a TOML file into nested dicts, or raise :class:`InputError` in one line.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for messages (``"scenario"``, ``"campaign"``, ``"gate"``).

    Returns
    -------
    dict
        The parsed table; nesting and integers checked (:func:`check_structure`).

    Raises
    ------
    InputError
    """
    p = Path(path)
    try:
        with p.open("rb") as fh:
            raw = fh.read(MAX_INPUT_BYTES + 1)
    except FileNotFoundError:
        raise InputError(f"{p}: no such {what} file") from None
    except IsADirectoryError:
        raise InputError(f"{p}: is a directory, not a {what} file") from None
    except PermissionError:
        raise InputError(f"{p}: cannot read the {what} file: permission denied") from None
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InputError(f"{p}: cannot read the {what} file: {reason}") from None
    if len(raw) > MAX_INPUT_BYTES:
        raise InputError(
            f"{p}: the {what} file is larger than {format_bytes(MAX_INPUT_BYTES)} (limit)"
        )
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise InputError(
            f"{p}: not UTF-8 text (byte {exc.start}, line {line}: {raw[exc.start:exc.end]!r}); "
            "save the file as UTF-8"
        ) from None
    return parse_toml(text, str(p))


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """Parse TOML text from ``source`` (checked as :func:`read_toml` does)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{source}: not valid TOML: {_one_line(exc)}") from None
    except RecursionError:
        raise InputError(
            f"{source}: nesting deeper than {MAX_NESTING} levels (limit)"
        ) from None
    check_structure(data, source)
    return data


def check_structure(value: Any, source: str, where: str = "", depth: int = 0) -> None:
    """Raise :class:`InputError` for nesting deeper than :data:`~acc.limits.MAX_NESTING`
    or an integer outside 64 bits, naming the key path (iterative, so deep input cannot
    exhaust the stack)."""
    stack = [(value, where, depth)]
    while stack:
        v, at, d = stack.pop()
        if isinstance(v, dict | list):
            if d > MAX_NESTING:
                raise InputError(
                    f"{source}: {at or 'top level'}: nesting deeper than {MAX_NESTING} "
                    "levels (limit)"
                )
            items = v.items() if isinstance(v, dict) else enumerate(v)
            for k, x in items:
                sub = f"{at}.{k}" if isinstance(v, dict) and at else (
                    str(k) if isinstance(v, dict) else f"{at}[{k}]"
                )
                stack.append((x, sub, d + 1))
        elif isinstance(v, int) and not isinstance(v, bool) and abs(v) > MAX_INTEGER:
            raise InputError(
                f"{source}: {at}: integer {abbreviate(v)} is outside 64 bits "
                f"(|n| <= {MAX_INTEGER})"
            )


def parse_assignment(text: str) -> tuple[str, Any]:
    """Parse a command-line ``section.key=value``; the value is read as TOML, else a string.

    Raises
    ------
    InputError
        Not ``section.key=value``, or a value nested too deep / an integer too large
        (the message starts with ``--set``).

    Examples
    --------
    >>> parse_assignment("controller.reference_force_N=450")
    ('controller.reference_force_N', 450)
    >>> parse_assignment("workpiece.radial_depth_mm=[2, 4]")
    ('workpiece.radial_depth_mm', [2, 4])
    """
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or "." not in key:
        raise InputError(f"{SET_SOURCE} {abbreviate(text)}: expected section.key=value")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    except RecursionError:
        raise InputError(
            f"{SET_SOURCE}: {abbreviate(key)}: nesting deeper than {MAX_NESTING} levels (limit)"
        ) from None
    check_structure(value, SET_SOURCE, key, depth=1)
    return key, value


__all__ = [
    "SET_SOURCE",
    "InputError",
    "check_structure",
    "parse_assignment",
    "parse_toml",
    "read_toml",
]
