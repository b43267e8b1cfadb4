"""The ``dressmeup`` command: one entry point with subcommands.

Each module in this package registers a group of subcommands with ``register(subparsers)``
and keeps its handlers thin: they parse arguments, call library functions and print. Heavy
imports happen inside the handlers so that ``dressmeup --help`` stays fast. Errors the user
can fix (:class:`dressmeup.errors.DressmeupError` such as ``InputError``, missing or
inaccessible files) are printed as one line and exit with status 2; any other exception is a
bug: its traceback is printed with a hint to report it (status 70). A subcommand that writes
names its output options in ``set_defaults(locks=(...))``: each is locked
(:func:`dressmeup.io.outlock.output_lock`) for the whole run, so two runs writing one output
cannot both succeed. An option removed or renamed answers for one release with what replaced
it (:mod:`dressmeup.cli.replaced`).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys
import traceback
from collections.abc import Sequence

from dressmeup import __version__
from dressmeup.cli.checks import SetLimit
from dressmeup.cli.replaced import add_replaced_options
from dressmeup.errors import DressmeupError
from dressmeup.io.outlock import output_lock

# One module per stage; each defines ``register(subparsers) -> None``.
COMMAND_MODULES = ("metrics", "body", "data", "capture", "baseline", "bench", "edition",
                   "server", "report")


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="dressmeup",
        description="3D garment datasets and benchmarks (run 'dressmeup demo' for the whole journey).",
    )
    parser.add_argument("--version", action="version", version=f"dressmeup {__version__}")
    parser.add_argument("--max", action=SetLimit, metavar="LIMIT=N",
                        help="raise (or lower) a resource limit for this run, e.g. --max "
                             "array_bytes=4G (repeatable; every limit and its default: "
                             "docs/limits.md; or set DRESSMEUP_MAX_<LIMIT>)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(f"dressmeup.cli.{name}").register(sub)
    add_replaced_options(parser)  # removed options name what replaced them (one release)
    return parser


#: Errors the user can fix: the toolkit's own (InputError & co.) and files that are missing
#: or not accessible. They print one line and exit with status 2; anything else is a bug.
USER_ERRORS = (DressmeupError, FileNotFoundError, FileExistsError, NotADirectoryError,
               IsADirectoryError, PermissionError)
#: Exit status of an internal error (EX_SOFTWARE of sysexits.h).
INTERNAL_ERROR = 70
ISSUES_URL = "https://github.com/dressmeup/dressmeup/issues"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status (0 ok, 1 command-specific failure such
    as an invalid submission, 2 user error, 70 internal error, 130 interrupted)."""
    saved = {k: v for k, v in os.environ.items() if k.startswith("DRESSMEUP_MAX_")}
    try:
        return _run(build_parser(), argv)
    finally:  # --max holds for this run only (main may be called again in one process)
        for k in [k for k in os.environ if k.startswith("DRESSMEUP_MAX_")]:
            if k not in saved:
                del os.environ[k]
        os.environ.update(saved)


def _run(parser: argparse.ArgumentParser, argv: Sequence[str] | None) -> int:
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    try:
        with contextlib.ExitStack() as held:
            for name in getattr(args, "locks", ()):
                if getattr(args, name, None):
                    held.enter_context(output_lock(getattr(args, name),
                                                   "--" + name.replace("_", "-")))
            status = args.func(args)
    except USER_ERRORS as exc:
        sys.stderr.write(f"dressmeup {args.command}: error: {_one_line(exc)}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        return 130
    except Exception:  # noqa: BLE001 - the boundary: anything else is a bug to report
        traceback.print_exc()
        sys.stderr.write(
            f"dressmeup {args.command}: internal error (a bug in dressmeup "
            f"{__version__}, not in your input). Please report it with the command line and "
            f"the traceback above at {ISSUES_URL}\n")
        return INTERNAL_ERROR
    return int(status or 0)


def _one_line(exc: BaseException) -> str:
    """The message of a user error; an OSError names its file."""
    if isinstance(exc, OSError) and not isinstance(exc, DressmeupError) and exc.filename:
        return f"{exc.strerror or exc}: {exc.filename}"
    return str(exc)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
