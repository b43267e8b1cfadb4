"""The ``dressmeup`` command: one entry point with subcommands.

Each module in this package registers a group of subcommands with ``register(subparsers)``
and keeps its handlers thin: they parse arguments, call library functions and print. Heavy
imports happen inside the handlers so that ``dressmeup --help`` stays fast. Errors the user
can fix (:class:`dressmeup.errors.DressmeupError`, ``ValueError``, ``FileNotFoundError``) are
printed as one line and exit with status 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from dressmeup import __version__

# One module per stage; each defines ``register(subparsers) -> None``.
COMMAND_MODULES = ("metrics", "body", "data", "capture", "baseline", "bench", "report")


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="dressmeup",
        description="3D garment datasets and benchmarks (run 'dressmeup demo' for the whole journey).",
    )
    parser.add_argument("--version", action="version", version=f"dressmeup {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(f"dressmeup.cli.{name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    from dressmeup.errors import DressmeupError

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    try:
        status = args.func(args)
    except (DressmeupError, ValueError, FileNotFoundError, PermissionError) as exc:
        sys.stderr.write(f"dressmeup {args.command}: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        return 130
    return int(status or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
