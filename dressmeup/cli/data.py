"""Subcommands of the data stage (owned by that stage; see docs/cli.md)."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register this stage's subcommands (none yet)."""
