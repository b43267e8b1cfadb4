"""The whole journey, tiny: synthetic data -> baselines -> validate -> score -> leaderboard.

Uses the ``synth-retarget-tiny-v5`` edition (procedural body, ground truth by simulation, 6 test
pairs in three tracks; baselines run on its public part, scored with the private one). The generated
data go to the test cache (``$DRESSMEUP_CACHE/e2e/<edition>-<hash>``) and are reused by later
runs: the generator resumes and is deterministic, so a cached dataset is the same dataset.
"""

from __future__ import annotations

import json

import pandas as pd

from dressmeup.cli import main

EDITION = "synth-retarget-tiny-v5"


def test_synth_to_leaderboard(tmp_path, capsys, other_data):
    from dressmeup import runs
    from dressmeup.bench import load_edition
    from dressmeup.cache import cache_dir

    ed = load_edition(EDITION)
    parts = runs.build_parts(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}",
                             allow_other_data=True)
    data = parts.private
    # a machine known to generate other data scores them as a user there must: marked
    # not comparable (--allow-other-data)
    other = ["--allow-other-data"] if other_data(ed, parts.full) else []
    subs = runs.run_baselines(ed, parts.public, tmp_path / "subs",
                              methods=["rigid", "skinning"])
    assert sorted(subs) == ["rigid", "skinning"]

    results = []
    for name, sub in subs.items():
        assert main(["validate-submission", str(sub), "-e", EDITION, "-d", str(data)]) == 0
        out = tmp_path / "results" / name
        assert main(["score", str(sub), "-e", EDITION, "-d", str(data), "-o", str(out),
                     "--workers", "1", "--no-progress", *other]) == 0
        results.append(out)
        summary = json.loads((out / "summary.json").read_text())
        assert summary["counts"] == {"items": 6, "ok": 6, "failed": 0}
        assert summary["edition"]["hash"] == ed.hash
        table = pd.read_parquet(out / "per_sample.parquet")
        assert set(table["status"]) == {"ok"}
        assert table["track"].value_counts().to_dict() == {"re-pose": 2, "re-shape": 2,
                                                           "cross": 2}
    # Scoring again into the same folder is refused (exit 2), the result stays.
    assert main(["score", str(subs["rigid"]), "-e", EDITION, "-d", str(data),
                 "-o", str(results[0]), "--workers", "1"]) == 2

    board = tmp_path / "board.md"
    assert main(["leaderboard", *map(str, results), "--out", str(board)]) == 0
    lines = board.read_text().splitlines()
    assert "P2S ↓ [mm]" in lines[0]
    # Rows are ranked by the edition's primary figure, P2S on cross, recomputed here from the
    # per-item results (on tiny v5's loose bottoms `rigid` is ahead of `skinning`)
    cross = {}
    for name, r in zip(subs, results, strict=True):
        t = pd.read_parquet(r / "per_sample.parquet")
        cross[name] = float(t.loc[t["track"] == "cross", "p2s"].mean())
    first, second = sorted(cross, key=cross.get)
    if other:  # not comparable rows are listed unranked
        assert lines[2].startswith(f"| – | {first} (not comparable) |")
        assert lines[3].startswith(f"| – | {second} (not comparable) |")
    else:
        assert lines[2].startswith(f"| 1 | {first} |") and lines[3].startswith(f"| 2 | {second} |")
    capsys.readouterr()
