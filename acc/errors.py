"""Errors the command line reports in one line (exit status 2), importable without the engine.

A :class:`ScenarioError` reads ``<source>: <section.key>: <message>``: the file (or
``--set``) the bad value came from, the key, and what is wrong.  Errors built with
:meth:`ScenarioError.at` keep the three parts, so a caller that knows better where a value
came from (a ``--set`` override, a campaign's ``[set]`` table) can re-attribute it with
:meth:`ScenarioError.blame`.
"""

from __future__ import annotations


class AccError(ValueError):
    """Any error the command line reports in one line with exit status 2."""


class OutputError(AccError):
    """An output path that cannot be written (``--out``, ``--junit``), said before any work."""


class ScenarioError(AccError):
    """A scenario that cannot be run; the message names the file and key, in one line.

    Attributes
    ----------
    source : str or None
        The file or ``--set`` the value came from (None if not known separately).
    key : str or None
        ``section.key`` (or ``[section]``) the message is about.
    detail : str or None
        What is wrong, without the source and key.
    """

    def __init__(
        self,
        message: str,
        *,
        source: str | None = None,
        key: str | None = None,
        detail: str | None = None,
    ) -> None:
        super().__init__(" ".join(str(message).split()) if "\n" in str(message) else message)
        self.source = source
        self.key = key
        self.detail = detail

    @classmethod
    def at(cls, source: str, key: str | None, detail: str) -> ScenarioError:
        """``"<source>: <key>: <detail>"`` (without the key part if None)."""
        text = f"{source}: {key}: {detail}" if key else f"{source}: {detail}"
        return cls(text, source=source, key=key, detail=detail)

    def blame(self, source: str, instead_of: str | None = None) -> ScenarioError:
        """The same error attributed to ``source`` (e.g. ``--set``).

        Parameters
        ----------
        source : str
            New source.
        instead_of : str or None
            The source to replace when the error has no separate parts (its message is
            re-prefixed if it starts with ``instead_of: ``).
        """
        if self.detail is not None:
            return type(self).at(source, self.key, self.detail)
        text = str(self)
        if instead_of and text.startswith(f"{instead_of}: "):
            text = f"{source}: {text[len(instead_of) + 2:]}"
        return type(self)(text, source=source, key=self.key)


__all__ = ["AccError", "OutputError", "ScenarioError"]
