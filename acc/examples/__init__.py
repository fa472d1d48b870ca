"""The example scenarios, campaigns and gates that ship with acc.

There is one copy of them in the source tree, ``experiments/*.toml``.  A wheel build copies
them flat into this package (``acc/examples/*.toml``, see ``setup.py``), so an installed acc
can list and copy them (``acc examples``, ``acc examples copy``) and ``acc run`` can take a
bare example name.  A campaign names its base scenario and a gate its campaign by a path
relative to itself (``base = "kim_chung_2001.toml"``); the files stay side by side wherever
they are, and :func:`copy_examples` brings along every file a copied one refers to.

Nothing here imports a numerical library: ``acc examples`` stays fast.
"""

from __future__ import annotations

import logging
import re
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

from acc.errors import AccError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = [
    "Example",
    "ExampleError",
    "copy_examples",
    "directory",
    "find_example",
    "list_examples",
    "resolve_scenario_argument",
]

log = logging.getLogger("acc")

#: Longest description shown by ``acc examples`` (characters); longer ones end in "...".
DESCRIPTION_CHARS = 80
#: Words whose full stop does not end a sentence of a leading comment.
_ABBREVIATIONS = frozenset({"Ch", "Sec", "Eq", "Eqs", "Fig", "Figs", "App", "Tab", "No", "vs",
                            "e.g", "i.e", "cf", "al"})


class ExampleError(AccError):
    """An example that does not exist, or a copy that would overwrite a file (one line)."""


@dataclass(frozen=True)
class Example:
    """One shipped example file.

    Attributes
    ----------
    name : str
        File name, e.g. ``"kim_chung_2001.toml"``.
    path : Path
        Where it is (inside the installed package, or ``experiments/`` of a checkout).
    kind : str
        ``"scenario"``, ``"campaign"`` or ``"gate"``.
    model : str or None
        The scenario's lab (``[simulation] model``, ``"force"`` if not given); None for a
        campaign or a gate.
    description : str
        The first sentence of the file's leading comment, at most
        :data:`DESCRIPTION_CHARS` characters.
    refers_to : tuple of str
        The example files this one names (a campaign's ``base``, a gate's ``campaign``).
    """

    name: str
    path: Path
    kind: str
    model: str | None
    description: str
    refers_to: tuple[str, ...]

    @property
    def stem(self) -> str:
        """The name without ``.toml`` (what ``acc run`` accepts as well)."""
        return self.name.removesuffix(".toml")


def directory() -> Path:
    """The directory that holds the example files.

    Returns
    -------
    Path
        ``acc/examples/`` of an installed wheel if the TOML files are there, else the
        ``experiments/`` directory of the source checkout this package runs from.

    Raises
    ------
    ExampleError
        If neither holds any example (a broken installation).
    """
    here = Path(__file__).resolve().parent
    if any(here.glob("*.toml")):
        return here
    checkout = here.parents[1] / "experiments"
    if any(checkout.glob("*.toml")):
        return checkout
    raise ExampleError(
        f"no example files found in {here} or {checkout}: the installation is incomplete "
        "(reinstall acc)")


def _leading_comment(text: str) -> str:
    """The comment lines at the top of a TOML file, joined into one paragraph."""
    lines = []
    for line in text.splitlines():
        stripped = line.strip()
        if not stripped.startswith("#"):
            break
        words = stripped.lstrip("#").strip()
        if words.startswith(("acc ", "python ")):  # a command line, not prose
            break
        lines.append(words)
    return " ".join(w for w in lines if w)


def _first_sentence(paragraph: str) -> str:
    """Up to the first full stop that ends a sentence (not ``Ch.``, ``Eq.``...), shortened
    to DESCRIPTION_CHARS."""
    sentence = paragraph
    for stop in re.finditer(r"\.\s+(?=[A-Z])", paragraph):
        word = paragraph[: stop.start()].rsplit(" ", 1)[-1].lstrip("(")
        if word not in _ABBREVIATIONS:
            sentence = paragraph[: stop.start() + 1]
            break
    if len(sentence) > DESCRIPTION_CHARS:
        sentence = sentence[: DESCRIPTION_CHARS - 3].rstrip(" ,;:(") + "..."
    return sentence


def _read(path: Path) -> Example:
    text = path.read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ExampleError(f"{path}: not a valid TOML file: {exc}") from None
    refers: list[str] = []
    if "gate" in data or "check" in data:
        kind, model = "gate", None
        refers = [c["campaign"] for c in data.get("check", []) if "campaign" in c]
    elif "campaign" in data:
        kind, model = "campaign", None
        if "base" in data["campaign"]:
            refers = [data["campaign"]["base"]]
    else:
        kind = "scenario"
        model = str(data.get("simulation", {}).get("model", "force"))
    return Example(
        name=path.name,
        path=path,
        kind=kind,
        model=model,
        description=_first_sentence(_leading_comment(text)),
        refers_to=tuple(dict.fromkeys(str(r) for r in refers)),
    )


def list_examples() -> list[Example]:
    """Every shipped example, sorted by name.

    Returns
    -------
    list of Example
    """
    return [_read(p) for p in sorted(directory().glob("*.toml"))]


def find_example(name: str) -> Example | None:
    """The shipped example called ``name`` (with or without ``.toml``), or None.

    Parameters
    ----------
    name : str
        A bare file name such as ``"kim_chung_2001.toml"`` or ``"kim_chung_2001"``; a name
        with a directory part is never an example.
    """
    if not name or Path(name).name != name:
        return None
    file_name = name if name.endswith(".toml") else f"{name}.toml"
    path = directory() / file_name
    return _read(path) if path.is_file() else None


def _with_references(names: list[str]) -> list[Example]:
    """The named examples and, transitively, every example they refer to (in order)."""
    chosen: dict[str, Example] = {}
    todo = list(names)
    while todo:
        name = todo.pop(0)
        example = find_example(name)
        if example is None:
            known = ", ".join(e.stem for e in list_examples())
            raise ExampleError(f"{name}: no such example (the examples are: {known})")
        if example.name not in chosen:
            chosen[example.name] = example
            todo.extend(example.refers_to)
    return list(chosen.values())


def copy_examples(names: list[str] | None, out: str | Path) -> list[Path]:
    """Copy shipped examples into ``out`` (created if missing), never overwriting a file.

    Parameters
    ----------
    names : list of str or None
        Example names (with or without ``.toml``); None or empty copies every example.
        The files a copied campaign or gate refers to are copied too, so it runs from
        ``out`` as it is.
    out : str or Path
        Target directory.

    Returns
    -------
    list of Path
        The files written, in the order copied.

    Raises
    ------
    ExampleError
        If a name is not an example, or a target file already exists (nothing is copied
        then), or ``out`` is not a directory.
    """
    examples = _with_references(list(names)) if names else list_examples()
    target = Path(out)
    if target.exists() and not target.is_dir():
        raise ExampleError(f"{target}: exists and is not a directory")
    existing = [target / e.name for e in examples if (target / e.name).exists()]
    if existing:
        more = f" (and {len(existing) - 1} more)" if len(existing) > 1 else ""
        raise ExampleError(f"{existing[0]}: already exists{more}; not overwritten (choose "
                           "another --out or remove the file)")
    target.mkdir(parents=True, exist_ok=True)
    written = []
    for example in examples:
        shutil.copyfile(example.path, target / example.name)
        written.append(target / example.name)
    return written


def resolve_scenario_argument(argument: str) -> str:
    """The scenario file ``acc run`` should read for ``argument``.

    A path that exists is taken as it is.  A bare name that is not a file in the current
    directory but is a shipped example (``kim_chung_2001.toml`` or ``kim_chung_2001``) is
    resolved to the shipped file, with a note on the ``acc`` logger; anything else is
    returned unchanged (and reported missing by the loader).

    Parameters
    ----------
    argument : str
        The command line's scenario argument.

    Returns
    -------
    str
        The path to read.
    """
    if Path(argument).exists():
        return argument
    try:
        example = find_example(argument)
    except ExampleError:  # no examples installed: the loader reports the missing file
        return argument
    if example is None:
        return argument
    log.info("%s is not a file here; running the shipped example %s (copy it with `acc "
             "examples copy %s --out DIR` to edit it)", argument, example.path, example.stem)
    return str(example.path)
