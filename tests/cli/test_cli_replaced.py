"""Removed or renamed options answer with what replaced them (dressmeup.cli.replaced)."""

from __future__ import annotations

import argparse

import pytest

from dressmeup.cli import build_parser, main
from dressmeup.cli.replaced import REPLACED_OPTIONS, Replaced, add_replaced_options


@pytest.mark.parametrize("option, by", [("--naked", "--preset naked"),
                                        ("--clothed", "--preset clothed")])
def test_register_names_the_preset_that_replaced_an_option(option, by, capsys, tmp_path):
    scan = tmp_path / "scan.ply"
    with pytest.raises(SystemExit) as exc:
        main(["register", str(scan), "--out", str(tmp_path / "fit.npz"), option])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"dressmeup register: error: {option} was replaced by {by}" in err
    assert err.startswith("usage: dressmeup register")
    assert "unrecognized arguments" not in err
    assert not (tmp_path / "fit.npz").exists()


def test_the_answer_comes_before_other_usage_errors(capsys):
    # no scan, no --out: the replaced option is still what the user hears about
    with pytest.raises(SystemExit) as exc:
        main(["register", "--naked"])
    assert exc.value.code == 2
    assert "--naked was replaced by --preset naked" in capsys.readouterr().err


def test_every_row_is_hidden_from_help_and_names_a_live_replacement():
    parser = build_parser()
    for row in REPLACED_OPTIONS:
        sub = parser
        for word in row.command.split():
            sub = next(a for a in sub._actions
                       if isinstance(a, argparse._SubParsersAction)).choices[word]
        assert row.option not in sub.format_help()
        assert row.by.split()[0] in sub._option_string_actions, row  # the replacement exists


def test_a_row_may_not_shadow_a_live_option_or_name_an_unknown_command():
    with pytest.raises(RuntimeError, match="still exists"):
        add_replaced_options(build_parser(), (Replaced("register", "--preset", "x", "0.2.0"),))
    with pytest.raises(RuntimeError, match="no subcommand 'nope'"):
        add_replaced_options(build_parser(), (Replaced("nope", "--x", "--y", "0.2.0"),))


def test_live_options_still_parse():
    args = build_parser().parse_args(["register", "scan.ply", "--out", "f.npz",
                                      "--preset", "naked"])
    assert args.preset == "naked"
    assert not any(k.startswith("replaced_") for k in vars(args))
