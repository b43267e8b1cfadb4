"""Leaderboards escape submission metadata in every format."""

from __future__ import annotations

import csv
import io
import json
import shutil

import pytest

EVIL = '=HYPERLINK("http://evil.example","x")<script>alert(1)</script> a\\b | {c}'


def _renamed(scored, out, **method) -> list:
    """A copy of the ground-truth result whose method fields are ``method``, and another."""
    shutil.copytree(scored["gt"]["res"].path, out)
    s = json.loads((out / "summary.json").read_text())
    s["method"].update(method)
    (out / "summary.json").write_text(json.dumps(s))
    return [out, scored["noisy"]["res"].path]


@pytest.fixture
def evil_result(scored, tmp_path):
    return _renamed(scored, tmp_path / "res-evil", method=EVIL,
                    url="https://github.com/dressmeup (docs/baselines.md)")


def test_markdown_has_no_raw_html_and_keeps_the_table(evil_result):
    from dressmeup.bench.boards.leaderboard import write_leaderboard

    md = write_leaderboard(evil_result, "md")
    assert "<script>" not in md and "&lt;script&gt;" in md
    row = next(ln for ln in md.splitlines() if "HYPERLINK" in ln)
    header = md.splitlines()[0]
    assert row.count(" | ") == header.count(" | ")


def test_csv_cells_cannot_run_as_formulas(evil_result):
    from dressmeup.bench.boards.leaderboard import write_leaderboard

    rows = list(csv.reader(io.StringIO(write_leaderboard(evil_result, "csv"))))
    methods = [r[1] for r in rows[1:]]
    assert EVIL not in methods and "'" + EVIL in methods
    assert not any(cell.startswith(("=", "+", "@")) for r in rows for cell in r)


def test_latex_escapes_backslash_once(evil_result):
    from dressmeup.bench.boards.leaderboard import write_leaderboard

    tex = write_leaderboard(evil_result, "latex")
    assert r"a\textbackslash{}b" in tex and r"\{c\}" in tex
    assert r"\textbackslash\{\}" not in tex


def test_html_links_only_real_urls(evil_result):
    from dressmeup.bench.boards.leaderboard import write_leaderboard

    page = write_leaderboard(evil_result, "html")
    assert "<script>alert" not in page
    assert 'href="https://github.com/dressmeup (docs' not in page


def test_escape_helpers():
    from dressmeup.bench.boards.escape import csv_text, latex_text, md_text, safe_url

    assert csv_text("-1+2") == "'-1+2" and csv_text("isomap") == "isomap"
    assert latex_text("50%_\\") == r"50\%\_\textbackslash{}"
    assert md_text("a|b\n<i>") == "a\\|b &lt;i&gt;"
    assert safe_url("javascript:alert(1)") is None
    assert safe_url("https://example.org/x") == "https://example.org/x"


MULTI = "Two\n\nparagraphs\u2028and\ta\r\nname"


@pytest.fixture
def multi_line_result(scored, tmp_path):
    # results written before names had to be one line
    return _renamed(scored, tmp_path / "res-multi", method=MULTI)


def test_a_method_name_is_one_line_in_every_text_format(multi_line_result):
    from dressmeup.bench.boards.leaderboard import write_leaderboard

    one = "Two paragraphs and a name"
    tex = write_leaderboard(multi_line_result, "latex")
    assert "\n\n" not in tex.strip() and any(one in ln for ln in tex.splitlines())
    rows = list(csv.reader(io.StringIO(write_leaderboard(multi_line_result, "csv"))))
    assert one in [r[1] for r in rows[1:]]
    md = write_leaderboard(multi_line_result, "md")
    assert any(one in ln for ln in md.splitlines())


@pytest.mark.parametrize("name", ["Two\n\nparagraphs", "a\rb", "tab\there", "ls\u2028sep"])
def test_a_method_name_with_a_line_break_is_refused_at_submission(tmp_path, name):
    import numpy as np

    from dressmeup.bench.scoring.submission import info_problems, write_submission
    from dressmeup.errors import InputError

    with pytest.raises(InputError, match="method must be one line of text"):
        write_submission(tmp_path / "sub", {"a": np.zeros((3, 3))}, edition="synth-retarget-v2",
                         method=name)
    assert not (tmp_path / "sub").exists()
    info = {"task": "retarget", "edition": "synth-retarget-v2", "method": name, "authors": "",
            "url": "", "hardware": "", "runtime_per_sample_s": None}
    problems = info_problems(info)
    assert len(problems) == 1 and "'method' must be one line of text" in problems[0]
    assert info_problems({**info, "method": "Fine name"}) == []
