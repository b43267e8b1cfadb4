"""The command reference in docs/cli.md, generated from the parsers themselves.

``python -m dressmeup.cli.reference docs/cli.md`` keeps the hand-written part of the page (up
to the ``## Commands`` heading) and rewrites the rest from ``dressmeup COMMAND --help`` of
every (sub)command, so the page cannot drift from the installed command line. A test checks
that the committed page equals the generated one.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from dressmeup.cli import build_parser
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text

HEADING = "## Commands\n"
WIDTH = 100


def _walk(parser: argparse.ArgumentParser, prefix: str, out: list[str]) -> None:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                full = f"{prefix} {name}"
                summary = (helps.get(name) or "").strip()
                summary = summary[:1].upper() + summary[1:]
                out.append(f"\n### `{full}`\n\n{summary}.\n")
                out.append("```text\n" + sub.format_help().rstrip() + "\n```\n")
                _walk(sub, full, out)


def command_reference() -> str:
    """Return the generated part of docs/cli.md: the top-level help and every subcommand's."""
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(WIDTH)  # argparse wraps help text to $COLUMNS
    try:
        parser = build_parser()
        out = ["```text\n" + parser.format_help().rstrip() + "\n```\n"]
        _walk(parser, "dressmeup", out)
    finally:
        if previous is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = previous
    return "\n".join(out)


def render_page(existing: str) -> str:
    """Return ``existing`` with everything after the ``## Commands`` heading regenerated."""
    if HEADING not in existing:
        raise InputError(f"the page has no '{HEADING.strip()}' heading to regenerate below")
    head = existing[: existing.index(HEADING) + len(HEADING)]
    return head + "\n" + command_reference()


def main(argv: list[str] | None = None) -> int:
    """Rewrite the page given as the only argument (default docs/cli.md)."""
    args = sys.argv[1:] if argv is None else argv
    path = Path(args[0] if args else "docs/cli.md")

    atomic_write_text(path, render_page(path.read_text(encoding="utf-8")))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
