"""docs/cli.md documents every public command exactly as the installed parser prints it."""

from __future__ import annotations

from pathlib import Path

from dressmeup.cli import build_parser
from dressmeup.cli.reference import render_page

PAGE = Path(__file__).resolve().parents[1] / "docs" / "cli.md"


def test_cli_page_matches_the_parsers():
    text = PAGE.read_text(encoding="utf-8")
    assert text == render_page(text), (
        "docs/cli.md is out of date: run `python -m dressmeup.cli.reference docs/cli.md`")


def test_every_subcommand_has_a_section():
    text = PAGE.read_text(encoding="utf-8")
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    missing = [name for name in sub.choices if f"### `dressmeup {name}`" not in text]
    assert not missing, f"commands without a section in docs/cli.md: {missing}"
