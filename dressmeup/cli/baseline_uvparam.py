"""``dressmeup baseline uvparam ...`` (owned by the uvparam methods)."""

from __future__ import annotations

import argparse


def register(tasks: argparse._SubParsersAction) -> None:
    """Register this task's baseline sub-subcommands (none yet)."""
