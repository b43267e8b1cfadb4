"""The CLI error boundary: only the toolkit's own errors and missing
files are one-line user errors; anything else is a bug shown with its traceback."""

from __future__ import annotations

import pytest

from dressmeup.cli import INTERNAL_ERROR, main
from dressmeup.errors import InputError


def _patch_handler(monkeypatch, exc: BaseException):
    import dressmeup.cli.bench as cli_bench

    def boom(args):
        raise exc

    monkeypatch.setattr(cli_bench, "_editions", boom)


def test_internal_value_error_shows_traceback_and_report_hint(monkeypatch, capsys):
    _patch_handler(monkeypatch, ValueError("operands could not be broadcast"))
    status = main(["editions"])
    err = capsys.readouterr().err
    assert status == INTERNAL_ERROR
    assert "Traceback" in err and "operands could not be broadcast" in err
    assert "report" in err and "internal error" in err


def test_input_error_is_one_line(monkeypatch, capsys):
    _patch_handler(monkeypatch, InputError("edition.json: field 'task' must be a string"))
    status = main(["editions"])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err
    assert err.strip() == "dressmeup editions: error: edition.json: field 'task' must be a string"


@pytest.mark.parametrize("exc", [FileNotFoundError(2, "No such file or directory", "x.ply"),
                                 PermissionError(13, "Permission denied", "out/")])
def test_missing_files_are_one_line_naming_the_file(monkeypatch, capsys, exc):
    _patch_handler(monkeypatch, exc)
    status = main(["editions"])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err and exc.filename in err


def test_cli_modules_raise_no_bare_value_error():
    from pathlib import Path

    import dressmeup.cli

    folder = Path(dressmeup.cli.__file__).parent
    offenders = [p.name for p in folder.glob("*.py") if "raise ValueError(" in p.read_text()]
    assert not offenders, f"user errors in the CLI must be InputError: {offenders}"
