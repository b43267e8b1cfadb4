"""The demo's UV part runs the neural method with its shipped pretrained models as one row
of the UV leaderboard (inference only: about 2 s a mesh)."""

from __future__ import annotations

import json


def test_demo_uv_part_has_a_pretrained_neural_row(tmp_path):
    from dressmeup import demo

    run = tmp_path / "run"
    run.mkdir()
    report: dict = {"results": []}
    lines: list[str] = []
    demo._uv_part(run, tmp_path, 1, True, lines.append, report)
    names = [p.name for p in report["results"]]
    assert "neural" in names and len(names) >= 3
    sub = json.loads((run / "submissions" / demo.UV_EDITION / "neural" /
                      "submission.json").read_text())
    assert sub["method"] == "neural" and "pretrained" in sub["hyperparameters"]
    assert "| neural |" in report["uv_leaderboard"].replace("**", "")
