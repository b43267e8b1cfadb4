"""Leaderboards escape submission metadata in every format."""

from __future__ import annotations

import csv
import io
import json
import shutil

import pytest

EVIL = '=HYPERLINK("http://evil.example","x")<script>alert(1)</script> a\\b | {c}'


@pytest.fixture
def evil_result(scored, tmp_path):
    res = tmp_path / "res-evil"
    shutil.copytree(scored["gt"]["res"].path, res)
    s = json.loads((res / "summary.json").read_text())
    s["method"]["method"] = EVIL
    s["method"]["url"] = "https://github.com/dressmeup (docs/baselines.md)"
    (res / "summary.json").write_text(json.dumps(s))
    return [res, scored["noisy"]["res"].path]


def test_markdown_has_no_raw_html_and_keeps_the_table(evil_result):
    from dressmeup.bench.leaderboard import write_leaderboard

    md = write_leaderboard(evil_result, "md")
    assert "<script>" not in md and "&lt;script&gt;" in md
    row = next(ln for ln in md.splitlines() if "HYPERLINK" in ln)
    header = md.splitlines()[0]
    assert row.count(" | ") == header.count(" | ")


def test_csv_cells_cannot_run_as_formulas(evil_result):
    from dressmeup.bench.leaderboard import write_leaderboard

    rows = list(csv.reader(io.StringIO(write_leaderboard(evil_result, "csv"))))
    methods = [r[1] for r in rows[1:]]
    assert EVIL not in methods and "'" + EVIL in methods
    assert not any(cell.startswith(("=", "+", "@")) for r in rows for cell in r)


def test_latex_escapes_backslash_once(evil_result):
    from dressmeup.bench.leaderboard import write_leaderboard

    tex = write_leaderboard(evil_result, "latex")
    assert r"a\textbackslash{}b" in tex and r"\{c\}" in tex
    assert r"\textbackslash\{\}" not in tex


def test_html_links_only_real_urls(evil_result):
    from dressmeup.bench.leaderboard import write_leaderboard

    page = write_leaderboard(evil_result, "html")
    assert "<script>alert" not in page
    assert 'href="https://github.com/dressmeup (docs' not in page


def test_escape_helpers():
    from dressmeup.bench.escape import csv_text, latex_text, md_text, safe_url

    assert csv_text("-1+2") == "'-1+2" and csv_text("isomap") == "isomap"
    assert latex_text("50%_\\") == r"50\%\_\textbackslash{}"
    assert md_text("a|b\n<i>") == "a\\|b &lt;i&gt;"
    assert safe_url("javascript:alert(1)") is None
    assert safe_url("https://example.org/x") == "https://example.org/x"
