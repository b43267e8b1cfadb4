"""``dressmeup baseline TASK ...``: run a reference method into a scoreable submission.

Each task registers its own sub-subcommands in its own module (``baseline_retarget``,
``baseline_uvparam``), so that the two method families stay independent.
"""

from __future__ import annotations

import argparse
import importlib

TASK_MODULES = ("baseline_retarget", "baseline_uvparam")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register ``dressmeup baseline`` and each task's sub-subcommands."""
    parser = subparsers.add_parser(
        "baseline", help="run a reference baseline into a submission (retarget, uvparam)",
        description="Run a reference baseline method over a dataset/edition and write a "
                    "submission folder that 'dressmeup score' accepts.")
    tasks = parser.add_subparsers(dest="task", metavar="TASK")
    for name in TASK_MODULES:
        importlib.import_module(f"dressmeup.cli.{name}").register(tasks)
    parser.set_defaults(func=lambda args: parser.print_help() or 1)
