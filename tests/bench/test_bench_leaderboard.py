"""Leaderboards: ranking, best marks, units/arrows, formats, refusal to mix editions."""

from __future__ import annotations

import csv
import io
import json
import shutil

import pytest

from dressmeup.bench import build_leaderboard, write_leaderboard
from dressmeup.bench.boards.leaderboard import render
from dressmeup.cli import main
from dressmeup.errors import InputError


def _paths(scored):
    return [scored["noisy"]["res"].path, scored["gt"]["res"].path]


def test_rows_sorted_by_primary_metric_and_best_marked(scored):
    board = build_leaderboard(_paths(scored))
    assert [r.method for r in board.rows] == ["GT", "NOISY"]
    for key in ("p2s", "p2s_bi", "chamfer", "ed", "nc", "p2s@dress"):
        assert board.best[key] == {0}, key
    md = render(board, "md")
    head = md.splitlines()[0]
    for h in ("P2S ↓ [mm]", "Chamfer ↓ [mm²]", "ED ↓ [mm]", "NC ↑", "IR ↓ [%]",
              "P2S ↓ [mm] · topwear", "Runtime [s/sample]"):
        assert h in head
    gt_row = md.splitlines()[2]
    assert gt_row.startswith("| 1 | GT | **") and "**0.00 [" in gt_row
    # Display units: ED of 2 mm noise prints about 3.17 mm.
    assert "| 3.17 [" in md.splitlines()[3]


def test_sort_by_and_std(scored):
    board = build_leaderboard(_paths(scored), sort_by="ir", show_std=True, per_category=[])
    assert all(c.category is None for c in board.columns)
    assert "±" in render(board, "md")
    with pytest.raises(InputError, match="cannot sort by"):
        build_leaderboard(_paths(scored), sort_by="qce")


def test_csv_latex_html(scored, tmp_path):
    text = write_leaderboard(_paths(scored), "csv", tmp_path / "lb.csv")
    assert (tmp_path / "lb.csv").read_text() == text
    rows = list(csv.DictReader(io.StringIO(text)))
    assert rows[0]["method"] == "GT" and "p2s" in rows[0]["best_in"].split(";")
    assert float(rows[1]["ED ↓ [mm]"]) == pytest.approx(3.1693, abs=1e-3)
    tex = write_leaderboard(_paths(scored), "latex")
    assert r"\toprule" in tex and r"$\downarrow$" in tex and r"\textbf{" in tex
    assert r"mm$^2$" in tex and r"\%" in tex
    page = write_leaderboard(_paths(scored), "html")
    assert page.startswith("<!DOCTYPE html>") and "<style>" in page
    # self-contained: the only script is the inline sorter; nothing is fetched
    assert page.count("<script>") == 1 and "src=" not in page and "stylesheet" not in page
    assert 'class="best"' in page and "bench-fixture-v1" in page


def test_refuses_mixed_editions_and_datasets(scored, tmp_path, capsys):
    other = tmp_path / "other"
    shutil.copytree(scored["gt"]["res"].path, other)
    s = json.loads((other / "summary.json").read_text())
    s["edition"]["hash"] = "f" * 64
    (other / "summary.json").write_text(json.dumps(s))
    with pytest.raises(InputError, match="different editions"):
        build_leaderboard([scored["noisy"]["res"].path, other])
    s["edition"]["hash"] = scored["gt"]["res"].summary["edition"]["hash"]
    s["dataset"]["manifest_sha256"] = "e" * 64
    (other / "summary.json").write_text(json.dumps(s))
    with pytest.raises(InputError, match="different datasets"):
        build_leaderboard([scored["noisy"]["res"].path, other])
    status = main(["leaderboard", str(scored["noisy"]["res"].path), str(other)])
    assert status == 2 and "different datasets" in capsys.readouterr().err


def test_cli_writes_file(scored, tmp_path, capsys):
    out = tmp_path / "board.html"
    assert main(["leaderboard", *map(str, _paths(scored)), "--format", "html",
                 "--out", str(out)]) == 0
    assert out.read_text().startswith("<!DOCTYPE html>")
    assert main(["leaderboard", *map(str, _paths(scored))]) == 0
    assert "| 1 | GT |" in capsys.readouterr().out
