"""`leaderboard` trusts no hand-edited result: means are recomputed from
per_sample.parquet, edition.json must hash to the recorded hash, and shipped edition names
must carry the shipped hash; custom editions are allowed and marked."""

from __future__ import annotations

import json
import shutil

import pytest

from dressmeup.bench.boards.leaderboard import render
from dressmeup.errors import InputError


def _copy(scored, name, tmp_path):
    out = tmp_path / f"res-{name}"
    shutil.copytree(scored[name]["res"].path, out)
    return out


def _edit(path, fn):
    data = json.loads(path.read_text())
    fn(data)
    path.write_text(json.dumps(data))


def test_forged_mean_is_refused(scored, tmp_path):
    from dressmeup.bench.boards.leaderboard import build_leaderboard

    forged = _copy(scored, "noisy", tmp_path)
    _edit(forged / "summary.json", lambda s: s["metrics"]["p2s"].update(mean=0.0))
    with pytest.raises(InputError, match="p2s mean"):
        build_leaderboard([scored["gt"]["res"].path, forged])
    forged2 = _copy(scored, "gt", tmp_path / "b")
    _edit(forged2 / "summary.json",
          lambda s: s["per_category"]["dress"]["metrics"]["p2s"].update(mean=-1.0))
    with pytest.raises(InputError, match="per_category.dress"):
        build_leaderboard([forged2])


def test_edited_or_forged_edition_is_refused(scored, tmp_path):
    from dressmeup.bench.boards.leaderboard import build_leaderboard

    edited = _copy(scored, "noisy", tmp_path)
    _edit(edited / "edition.json", lambda e: e.update(per_category=[]))
    with pytest.raises(InputError, match="edition.json was edited"):
        build_leaderboard([edited])
    # a forged hash in both results' summaries: they now agree, but not with edition.json
    a, b = _copy(scored, "gt", tmp_path / "a"), _copy(scored, "noisy", tmp_path / "b")
    for r in (a, b):
        _edit(r / "summary.json", lambda s: s["edition"].update(hash="f" * 64))
    with pytest.raises(InputError, match="edited after scoring"):
        build_leaderboard([a, b])


def test_shipped_edition_name_must_carry_its_hash(scored, tmp_path):
    from dressmeup.bench.boards.leaderboard import build_leaderboard
    from dressmeup.bench.edition import edition_from_dict

    fake = _copy(scored, "gt", tmp_path)
    ed = json.loads((fake / "edition.json").read_text())
    ed["name"] = "synth-retarget-v2"
    (fake / "edition.json").write_text(json.dumps(ed))
    h = edition_from_dict(ed).hash
    _edit(fake / "summary.json", lambda s: s["edition"].update(name="synth-retarget-v2", hash=h))
    with pytest.raises(InputError, match="shipped edition synth-retarget-v2"):
        build_leaderboard([fake])


def test_custom_edition_is_allowed_and_marked(scored):
    from dressmeup.bench.boards.leaderboard import build_leaderboard

    board = build_leaderboard([scored["gt"]["res"].path, scored["noisy"]["res"].path])
    assert board.custom_edition
    assert "Custom edition" in render(board, "md")


def test_per_track_means_are_recomputed(scored, tmp_path):
    import pandas as pd

    from dressmeup.bench.boards.verify import check_summary
    from dressmeup.bench.scoring.results import load_result, summarise

    res = _copy(scored, "noisy", tmp_path)
    table = pd.read_parquet(res / "per_sample.parquet")
    table["track"] = ["re-pose" if i % 2 else "cross" for i in range(len(table))]
    table.to_parquet(res / "per_sample.parquet", index=False)
    metrics = list(scored["noisy"]["res"].summary["metrics"])
    honest = summarise(table, metrics, [])
    _edit(res / "summary.json", lambda s: s.update(honest))
    assert check_summary(load_result(res)) == []
    _edit(res / "summary.json",
          lambda s: s["per_track"]["cross"]["metrics"]["p2s"].update(mean=1e-9))
    problems = check_summary(load_result(res))
    assert len(problems) == 1 and "per_track.cross" in problems[0]
