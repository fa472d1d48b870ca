"""``acc examples``: the shipped scenarios, campaigns and gates; registered on import.

``acc examples`` lists them (name, what it is, the first sentence of its leading comment).
``acc examples copy [NAME ...] --out DIR`` copies the named ones (all of them if none is
named) into ``DIR``, with every file a copied campaign or gate refers to, so that
``acc run DIR/kim_chung_2001.toml --out ...`` (or ``acc sweep``, ``acc check``) runs from
there; an existing file is never overwritten (one line, exit status 2, nothing copied).

``acc run`` also takes a bare example name (``acc run kim_chung_2001 --out DIR``) when no
such file is in the current directory: see :func:`acc.examples.resolve_scenario_argument`.
"""

from __future__ import annotations

import argparse

from acc.cli.main import COMMANDS, _add_verbosity, say


def _add_args(p: argparse.ArgumentParser) -> None:
    actions = p.add_subparsers(dest="action", metavar="{list,copy}")
    actions.add_parser("list", help="list the examples (the default)",
                       description="list the examples (the default)")
    copy = actions.add_parser(
        "copy", help="copy examples into a directory",
        description="copy examples (all if none is named) and the files they refer to into "
                    "a directory; an existing file is never overwritten")
    copy.add_argument("names", nargs="*", metavar="NAME",
                      help="example name, with or without .toml (default: every example)")
    copy.add_argument("--out", required=True, help="directory to copy into (created if "
                      "missing)")
    _add_verbosity(copy, top=False)


def _what(kind: str, model: str | None) -> str:
    return f"{kind} ({model})" if model else kind


def _cmd_examples(args: argparse.Namespace) -> int:
    from acc.examples import copy_examples, directory, list_examples

    if args.action == "copy":
        written = copy_examples(args.names, args.out)
        asked = {n if n.endswith(".toml") else f"{n}.toml" for n in args.names}
        extra = [p.name for p in written if asked and p.name not in asked]
        say(args, f"copied {len(written)} example file{'s' * (len(written) != 1)} to "
                  f"{args.out}: {', '.join(p.name for p in written)}"
                  + (f" (with {', '.join(extra)}, which the others refer to)" if extra else ""))
        return 0
    examples = list_examples()
    width = max(len(e.stem) for e in examples)
    kind_width = max(len(_what(e.kind, e.model)) for e in examples)
    for e in examples:
        print(f"{e.stem:<{width}}  {_what(e.kind, e.model):<{kind_width}}  {e.description}")
    say(args, "", f"({len(examples)} examples in {directory()})",
        "copy: acc examples copy [NAME ...] --out DIR; run a scenario: acc run NAME --out DIR")
    return 0


COMMANDS["examples"] = ("list the shipped example scenarios, campaigns and gates, or copy them",
                        _add_args, _cmd_examples)
