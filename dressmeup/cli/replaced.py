"""Options that were removed or renamed: for one release each still parses, as a usage error
that names what replaced it (``dressmeup register: error: --naked was replaced by --preset
naked``, exit status 2) instead of argparse's "unrecognized arguments".

Every such option is one row of :data:`REPLACED_OPTIONS`; :func:`add_replaced_options` adds
them to the subcommands' parsers (hidden from ``--help``). A row is deleted in the release
after the one named in its ``until``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass


@dataclass(frozen=True)
class Replaced:
    """An option of ``command`` (``"register"``, ``"edition fetch"``) that ``by`` replaced
    (text shown to the user, e.g. ``"--preset naked"``); answered until release ``until``."""

    command: str
    option: str
    by: str
    until: str


#: Removed or renamed options (CHANGELOG.md lists each under its release).
REPLACED_OPTIONS: tuple[Replaced, ...] = (
    Replaced("register", "--naked", "--preset naked", until="0.2.0"),
    Replaced("register", "--clothed", "--preset clothed", until="0.2.0"),
)


class _ReplacedAction(argparse.Action):
    """Fails the parse with "OPTION was replaced by BY" (argparse's usage error: status 2)."""

    def __init__(self, option_strings, dest, by: str, **kw):
        kw.update(nargs="?", help=argparse.SUPPRESS, default=argparse.SUPPRESS)
        super().__init__(option_strings, dest, **kw)
        self.by = by

    def __call__(self, parser, namespace, values, option_string=None):
        parser.error(f"{option_string} was replaced by {self.by}")


def _subparser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """The parser of ``command`` (words separated by spaces) below ``parser``."""
    for word in command.split():
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs or word not in subs[0].choices:
            raise RuntimeError(f"REPLACED_OPTIONS names command {command!r}, which has no "
                             f"subcommand {word!r}")
        parser = subs[0].choices[word]
    return parser


def add_replaced_options(parser: argparse.ArgumentParser,
                         rows: tuple[Replaced, ...] = REPLACED_OPTIONS) -> None:
    """Add each row of ``rows`` to its subcommand's parser below ``parser`` (the top-level
    ``dressmeup`` parser). A row whose option the subcommand still defines is refused
    (``ValueError``): the table must not shadow a live option."""
    for row in rows:
        sub = _subparser(parser, row.command)
        if row.option in sub._option_string_actions:
            raise RuntimeError(f"REPLACED_OPTIONS: {row.command} {row.option} still exists")
        sub.add_argument(row.option, dest=f"replaced_{row.option.lstrip('-')}",
                         action=_ReplacedAction, by=row.by)
