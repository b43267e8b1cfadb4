"""The resource policy (dressmeup.limits): one table, errors that say how to raise a limit,
``dressmeup --max`` for one run, docs/limits.md in step with the code."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from dressmeup.errors import InputError
from dressmeup.limits import ARRAY_BYTES, LIMITS, LimitError, by_name, markdown_table

DOC = Path(__file__).resolve().parents[1] / "docs" / "limits.md"


def test_every_limit_has_a_unique_name_env_and_doc():
    names = [lim.name for lim in LIMITS]
    assert len(set(names)) == len(names)
    for lim in LIMITS:
        assert lim.env == "DRESSMEUP_MAX_" + lim.name.upper()
        assert lim.default > 0 and lim.doc and lim.what
        assert by_name(lim.name) is lim


def test_docs_table_is_the_generated_one():
    text = DOC.read_text(encoding="utf-8")
    assert markdown_table() in text, ("docs/limits.md is out of date: paste "
                                      "dressmeup.limits.markdown_table() into it")


def test_error_names_the_amount_the_limit_and_how_to_raise_it():
    with pytest.raises(LimitError) as info:
        ARRAY_BYTES.check(3 << 30, "scan.npy", "declared array size")
    msg = str(info.value)
    assert msg.startswith("scan.npy: declared array size 3,221,225,472 bytes (3 GiB)")
    assert "array_bytes" in msg and "--max array_bytes=N" in msg
    assert "DRESSMEUP_MAX_ARRAY_BYTES" in msg
    assert isinstance(info.value, InputError) and info.value.limit is ARRAY_BYTES


def test_environment_variable_sets_the_limit(monkeypatch):
    monkeypatch.setenv("DRESSMEUP_MAX_ARRAY_BYTES", "2K")
    assert ARRAY_BYTES.value() == 2048
    ARRAY_BYTES.check(2048, "x")
    with pytest.raises(LimitError):
        ARRAY_BYTES.check(2049, "x")
    for bad in ("-1", "0", "lots", "1.5G"):
        monkeypatch.setenv("DRESSMEUP_MAX_ARRAY_BYTES", bad)
        with pytest.raises(InputError, match="DRESSMEUP_MAX_ARRAY_BYTES"):
            ARRAY_BYTES.value()


def test_unknown_limit_lists_the_names():
    with pytest.raises(InputError, match=r"no limit named 'nope'.*array_bytes"):
        by_name("nope")


def test_cli_max_raises_a_limit_for_one_run_only(tmp_path, capsys, monkeypatch):
    from dressmeup.cli import main

    monkeypatch.delenv("DRESSMEUP_MAX_SURFACE_SAMPLES", raising=False)
    pred = tmp_path / "tri.ply"
    pred.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                    "property float y\nproperty float z\nelement face 1\n"
                    "property list uchar int vertex_indices\nend_header\n"
                    "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    args = ["metrics", str(pred), str(pred), "--samples", "30"]
    with pytest.raises(SystemExit) as info:  # a usage error, before any work
        main(["--max", "surface_samples=20", *args])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert re.search(r"--samples: expected an integer from 1 to 20 \(surface_samples", err)
    assert main(["--max", "surface_samples=40", *args]) == 0
    assert "DRESSMEUP_MAX_SURFACE_SAMPLES" not in os.environ  # restored after the run
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(["--max", "nope=3", *args])
    assert "no limit named 'nope'" in capsys.readouterr().err
    assert "DRESSMEUP_MAX_SURFACE_SAMPLES" not in os.environ
