"""Intervals over every factor the items share (with a coverage check by simulation), paired
separation against the leader and the next row, result schema /3, tracks, old results and
not-comparable results in every leaderboard format."""

from __future__ import annotations

import csv
import io
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dressmeup.bench import build_leaderboard
from dressmeup.bench.boards.leaderboard import render
from dressmeup.bench.edition import edition_from_dict
from dressmeup.bench.scoring.intervals import (
    bootstrap_mean,
    crossed_bootstrap,
    describe_levels,
    describe_resolution,
    distinct_resamples,
    paired_difference,
    resample_count,
)
from dressmeup.bench.scoring.results import load_result, summarise


def test_distinct_resamples_is_multiset_count():
    assert [distinct_resamples(n) for n in range(1, 8)] == [1, 3, 10, 35, 126, 462, 1716]
    # brute force for n = 3: multisets of size 3 from 3 units
    import itertools

    seen = {tuple(sorted(c)) for c in itertools.product(range(3), repeat=3)}
    assert len(seen) == distinct_resamples(3)


def test_interval_resamples_units_not_items():
    """3 garments with 20 identical pairs each: the interval reflects 3 units, not 60 items
    (an item bootstrap would be far narrower), is widened by t(2)/z for so few levels, and
    is seeded."""
    units = np.repeat(["g1", "g2", "g3"], 20)
    values = np.repeat([1.0, 2.0, 6.0], 20)
    iv = bootstrap_mean(values, units)
    assert iv.n_units == 3 and iv.n_items == 60 and iv.distinct_resamples == 10
    assert iv.df == pytest.approx(2.0)
    assert iv.lo <= iv.mean <= iv.hi and iv.mean == pytest.approx(3.0)
    # widened for 3 levels to the whole range of the item values (never beyond it)
    assert iv.lo == pytest.approx(1.0) and iv.hi == pytest.approx(6.0)
    assert bootstrap_mean(values + 0.0, units, resamples=50).lo >= values.min()
    assert bootstrap_mean(values, units) == iv
    items = bootstrap_mean(values, [str(i) for i in range(60)])
    assert items.hi - items.lo < (iv.hi - iv.lo) / 3


def _edition_like(rng, n_g=12, n_s=4, n_p=3, sd=(10.0, 6.0, 3.0), sd_e=5.0, keep=1.0):
    """Items of a crossed garment x subject x pose design with random effects (true mean 0);
    ``keep`` < 1 drops items at random (the sampled pairs of an edition)."""
    a, b, c = (rng.normal(0.0, s_, n) for s_, n in zip(sd, (n_g, n_s, n_p), strict=True))
    g, s_, p = (x.ravel() for x in np.meshgrid(np.arange(n_g), np.arange(n_s),
                                                 np.arange(n_p), indexing="ij"))
    x = a[g] + b[s_] + c[p] + rng.normal(0.0, sd_e, g.size)
    m = rng.random(g.size) < keep
    return x[m], {"garment_id": g[m], "target_subject": s_[m], "target_pose": p[m]}


def test_crossed_intervals_cover_the_true_mean():
    """1,000 simulated editions (12 garments x 4 subjects x 3 poses, garment SD 10 mm,
    subject SD 6 mm, pose SD 3 mm, item noise 5 mm, a random 60 % of the items kept): the
    nominal 95 % interval covers the true mean at least 93 % of the time. Resampling the
    garments only covers it far less often (the bodies and poses are shared)."""
    rng = np.random.default_rng(7)
    hit = hit_g = 0
    n = 1000
    for _ in range(n):
        x, factors = _edition_like(rng, keep=0.6)
        iv = crossed_bootstrap(x, factors, resamples=400, seed=int(rng.integers(1 << 30)))
        hit += iv.lo <= 0.0 <= iv.hi
        ig = crossed_bootstrap(x, {"garment_id": factors["garment_id"]}, resamples=400)
        hit_g += ig.lo <= 0.0 <= ig.hi
    assert hit / n >= 0.93, hit / n
    assert hit_g / n < 0.90, hit_g / n


def test_a_factor_without_spread_barely_widens_the_interval():
    """When subjects and poses add nothing, the crossed interval is close to the garment-only
    one (the estimator does not invent variance)."""
    rng = np.random.default_rng(3)
    x, f = _edition_like(rng, sd=(10.0, 0.0, 0.0), sd_e=0.5)
    both = crossed_bootstrap(x, f)
    g = crossed_bootstrap(x, {"garment_id": f["garment_id"]})
    assert (both.hi - both.lo) == pytest.approx(g.hi - g.lo, rel=0.25)
    assert both.levels == {"garment_id": 12, "target_subject": 4, "target_pose": 3}
    assert resample_count(both.levels) == distinct_resamples(12) * 35 * 10
    assert "allow only" not in describe_levels(both.levels)
    assert "allow only 35 distinct" in describe_levels({"garment_id": 4})


def test_single_unit_is_degenerate_and_nan_left_out():
    iv = bootstrap_mean([1.0, 2.0, np.nan], ["a", "a", "a"])
    assert iv.degenerate and iv.lo == iv.hi == iv.mean == 1.5 and iv.n_items == 2
    assert bootstrap_mean([np.nan], ["a"]) is None
    assert "degenerate" in describe_resolution(1)
    assert "allow only 10 distinct resamples" in describe_resolution(3)


def test_paired_difference_separates_a_constant_gap_not_noise():
    rng = np.random.default_rng(0)
    units = np.repeat([f"g{i}" for i in range(10)], 5)
    a = rng.normal(10.0, 3.0, 50)          # large spread between items ...
    d = paired_difference(a + 0.5, a, units)   # ... but a constant paired gap
    assert d.separated and d.lo == pytest.approx(0.5) and d.diff == pytest.approx(0.5)
    noise = paired_difference(a + rng.normal(0, 1.0, 50), a, units)
    assert not noise.separated and noise.lo < 0 < noise.hi
    assert not paired_difference([1.0, 2.0], [0.0, 0.0], ["u", "u"]).separated
    # over crossed factors: a gap that depends on the subject is not a separation when the
    # subjects disagree on its sign
    x, f = _edition_like(np.random.default_rng(1), sd_e=0.1)
    gap = np.where(f["target_subject"] < 2, 2.0, -1.0)
    d = paired_difference(x + gap, x, f)
    assert d.diff == pytest.approx(0.5, abs=1e-9) and not d.separated


def test_summary_has_intervals_per_category_and_track():
    table = pd.DataFrame({
        "sample_id": [f"p{i}" for i in range(12)],
        "category": ["topwear"] * 6 + ["dress"] * 6,
        "garment_id": ["G1", "G1", "G2", "G2", "G3", "G3", "G4", "G4", "G5", "G5", "G6",
                       "G6"],
        "track": ["cross", "re-pose"] * 6,
        "p2s": np.linspace(0.001, 0.012, 12),
        "status": ["ok"] * 11 + ["error"],
    })
    s = summarise(table, ["p2s"], [], unit_columns=("garment_id", "target_subject"))
    st = s["metrics"]["p2s"]
    assert st["n"] == 11 and st["levels"] == {"garment_id": 6} and st["distinct_resamples"] == 462
    assert st["ci95"][0] < st["mean"] < st["ci95"][1]
    assert s["bootstrap"]["factors"] == ["garment_id"] and s["bootstrap"]["seed"] == 0
    assert set(s["per_track"]) == {"cross", "re-pose"}
    assert s["per_track"]["re-pose"]["failed"] == 1
    assert s["per_track"]["cross"]["metrics"]["p2s"]["n"] == 6
    assert s["per_category"]["dress"]["metrics"]["p2s"]["levels"] == {"garment_id": 3}
    assert "per_track" not in summarise(table.drop(columns="track"), ["p2s"], [])
    assert "ci95" not in summarise(table, ["p2s"], [])["metrics"]["p2s"]


# --------------------------------------------------------------------- leaderboards
def _copy(res: Path, dst: Path, *, method: str | None = None, edit=None,
          table_edit=None) -> Path:
    shutil.copytree(res, dst)
    summary = json.loads((dst / "summary.json").read_text())
    if table_edit is not None:
        t = pd.read_parquet(dst / "per_sample.parquet")
        t = table_edit(t)
        t.to_parquet(dst / "per_sample.parquet", index=False)
        metrics = list(summary["metrics"])
        summary.update(summarise(t, metrics, ["ir_gt"], unit_columns=("garment_id",)))
    if method is not None:
        summary["method"]["method"] = method
    if edit is not None:
        edit(summary)
    (dst / "summary.json").write_text(json.dumps(summary))
    return dst


def test_scored_result_is_schema_3_with_intervals(scored):
    r = load_result(scored["noisy"]["res"].path)
    assert r.summary["schema"] == "dressmeup-result/3" and r.schema_version == 3
    assert r.comparable
    st = r.summary["metrics"]["p2s"]
    assert st["levels"]["garment_id"] == 3 and len(st["ci95"]) == 2 and not st["degenerate"]
    assert r.summary["bootstrap"]["factors"][0] == "garment_id"


def test_old_results_get_intervals_recomputed_from_their_table(scored, tmp_path):
    """Leaderboards recompute intervals from per_sample.parquet whatever the schema (a
    summary's stored intervals are never trusted)."""
    def to_v1(s):
        s["schema"] = "dressmeup-result/1"
        s.pop("schema_version", None)
        s.pop("bootstrap", None)
        for st in s["metrics"].values():
            for k in ("ci95", "levels", "df", "distinct_resamples", "degenerate"):
                st.pop(k, None)
        for cat in s["per_category"].values():
            for st in cat["metrics"].values():
                st.pop("ci95", None)

    def forged(s):
        s["metrics"]["p2s"]["ci95"] = [0.0, 0.0]

    old = _copy(scored["noisy"]["res"].path, tmp_path / "old", method="OLD", edit=to_v1)
    fake = _copy(scored["noisy"]["res"].path, tmp_path / "fake", method="FAKE", edit=forged)
    board = build_leaderboard([scored["gt"]["res"].path, old, fake])
    rows = {r.method: r for r in board.rows}
    assert rows["OLD"].ci["p2s"] == rows["FAKE"].ci["p2s"] != (0.0, 0.0)
    table = list(csv.DictReader(io.StringIO(render(board, "csv"))))
    old_csv = next(r for r in table if r["method"] == "OLD")
    assert old_csv["schema_version"] == "1" and old_csv["P2S ↓ [mm] ci95 lo"] != ""


def test_tracks_get_columns_in_every_format(scored, tmp_path):
    def add_tracks(t):
        t["track"] = np.where(np.arange(len(t)) % 2 == 0, "cross", "re-pose")
        return t

    a = _copy(scored["gt"]["res"].path, tmp_path / "a", table_edit=add_tracks)
    b = _copy(scored["noisy"]["res"].path, tmp_path / "b", table_edit=add_tracks)
    board = build_leaderboard([a, b])
    assert [c.track for c in board.columns if c.track] == ["cross", "re-pose"]
    assert "P2S ↓ [mm] · track cross" in render(board, "md").splitlines()[0]
    assert "P2S ↓ [mm] · track re-pose" in render(board, "csv").splitlines()[0]
    assert "track cross" in render(board, "latex") and "track re-pose" in render(board, "html")
    col = next(c for c in board.columns if c.track == "cross")
    assert board.rows[0].ci[col.key][0] <= board.rows[0].values[col.key][0]

    # an edition naming a primary track sorts by that track's column
    for folder in (a, b):
        ed = json.loads((folder / "edition.json").read_text())
        ed.update(tracks=["re-pose", "re-shape", "cross"],
                  primary={"metric": "p2s", "track": "cross"})
        (folder / "edition.json").write_text(json.dumps(ed))
        summary = json.loads((folder / "summary.json").read_text())
        summary["edition"]["hash"] = edition_from_dict(ed).hash     # a re-scored result
        summary["provenance"]["edition_hash"] = summary["edition"]["hash"]
        (folder / "summary.json").write_text(json.dumps(summary))
    board = build_leaderboard([b, a])
    assert board.primary == "p2s#cross" and board.rows[0].method == "GT"
    assert [c.track for c in board.columns if c.track] == ["re-pose", "cross"]   # its order
    assert "Sorted by P2S ↓ [mm] · track cross" in render(board, "md")
    # every track is shown for the primary metric even without per-category metrics
    bare = build_leaderboard([b, a], per_category=[])
    assert [c.key for c in bare.columns if c.track] == ["p2s#re-pose", "p2s#cross"]


def _six_units(t):
    t["garment_id"] = [f"U{i % 6}" for i in range(len(t))]   # 6 unit labels over 18 pairs
    return t


def test_rank_separation_marked(scored, tmp_path):
    """NOISY is worse than GT on every pair by about the noise: the paired bootstrap
    separates them even though their intervals overlap; a copy of NOISY is not separated
    from NOISY, and it says so in words beside its difference to the leader."""
    gt = _copy(scored["gt"]["res"].path, tmp_path / "gt", table_edit=_six_units)
    noisy = _copy(scored["noisy"]["res"].path, tmp_path / "noisy", table_edit=_six_units)
    twin = _copy(noisy, tmp_path / "twin", method="NOISY-TWIN")
    board = build_leaderboard([gt, noisy, twin], sort_by="ed")
    seps = {r.method: r.separated for r in board.rows}
    assert seps["GT"] is True
    assert [seps["NOISY"], seps["NOISY-TWIN"]].count(False) == 1
    assert [seps["NOISY"], seps["NOISY-TWIN"]].count(None) == 1
    assert all(r.vs_leader.separated for r in board.rows[1:])
    assert board.rows[0].vs_leader is None
    rows = list(csv.DictReader(io.StringIO(render(board, "csv"))))
    assert rows[0]["separated_from_next"] == "true" and rows[2]["separated_from_next"] == ""
    assert rows[1]["separated_from_leader"] == "true" and float(rows[1]["diff_to_leader"]) > 0
    md = render(board, "md")
    assert "Sep." in md and "vs #1" in md and "not separated" in md
    assert "Sep." in render(board, "latex")
    assert 'class="sep sep-no"' in render(board, "html")


def test_a_difference_within_the_sensitivity_is_not_a_win(scored, tmp_path):
    """An edition stating the ground truth's sensitivity never calls a smaller difference
    separated."""
    gt = _copy(scored["gt"]["res"].path, tmp_path / "gt", table_edit=_six_units)
    noisy = _copy(scored["noisy"]["res"].path, tmp_path / "noisy", table_edit=_six_units)
    board = build_leaderboard([gt, noisy], sort_by="ed")
    assert board.separated(0) == "yes"
    board.sensitivity = 10.0                       # metres: far above any difference here
    assert board.separated(0) == "not separated"
    assert "sensitivity" in render(board, "md")


def test_not_comparable_marked_in_every_format(scored, tmp_path):
    def other(s):
        s["comparable"] = False
        s["not_comparable_reason"] = "scored with --allow-other-data"
        s["dataset"]["manifest_sha256"] = "0" * 64

    nc = _copy(scored["gt"]["res"].path, tmp_path / "nc", method="ELSEWHERE", edit=other)
    board = build_leaderboard([scored["noisy"]["res"].path, nc])
    assert board.rows[-1].method == "ELSEWHERE"       # last, unranked
    md = render(board, "md")
    assert "| – | ELSEWHERE (not comparable) |" in md and "Not comparable" in md
    assert all(r.method != "ELSEWHERE" or not any(
        board.rows.index(r) in v for v in board.best.values()) for r in board.rows)
    rows = list(csv.DictReader(io.StringIO(render(board, "csv"))))
    assert rows[-1]["comparable"] == "false" and rows[-1]["rank"] == ""
    assert "ELSEWHERE (not comparable)" in render(board, "latex")
    assert ">not comparable</span>" in render(board, "html")


def test_html_escapes_method_names_and_sorts(scored, tmp_path):
    evil = _copy(scored["gt"]["res"].path, tmp_path / "evil",
                 method='<script>alert("x")</script>')
    page = render(build_leaderboard([evil, scored["noisy"]["res"].path]), "html")
    assert "<script>alert" not in page and "&lt;script&gt;alert" in page
    assert page.count("<script>") == 1 and 'data-type="num"' in page
    first_metric_cell = page.split("</td>", 2)[2]        # rank, method, then P2S
    assert math.isfinite(float(first_metric_cell.split('data-v="')[1].split('"')[0]))


def test_separation_when_the_unit_is_the_item():
    """uvparam's unit column is sample_id itself (one item per mesh): the paired bootstrap
    must still find it (it crashed the demo's UV leaderboard once)."""
    from types import SimpleNamespace

    from dressmeup.bench.boards.leaderboard import _mark_separation

    ids = [f"m{i}" for i in range(6)]
    rows, results = [], []
    for name, offset in (("A", 0.0), ("B", 1.0)):
        t = pd.DataFrame({"sample_id": ids, "qce": np.arange(6.0) + offset,
                          "status": ["ok"] * 6})
        rows.append(_row(name, schema_version=2))
        results.append(SimpleNamespace(table=t))
    _mark_separation(rows, results, "qce", ("sample_id",))
    assert rows[0].separated is True and rows[1].vs_next is None
    assert rows[1].vs_leader.separated and rows[1].vs_leader.diff == pytest.approx(1.0)


def test_one_unit_shows_degenerate_interval_and_says_why(scored, tmp_path):
    """All pairs of one garment (mini-v2's test split): the table keeps its interval
    column, prints [–] and the caption says the interval is degenerate."""
    def one_garment(t):
        t["garment_id"] = "G01"
        return t

    a = _copy(scored["gt"]["res"].path, tmp_path / "a", table_edit=one_garment)
    b = _copy(scored["noisy"]["res"].path, tmp_path / "b", table_edit=one_garment)
    board = build_leaderboard([a, b])
    md = render(board, "md")
    assert board.show_ci and "[–]" in md.splitlines()[2] and "degenerate" in md
    assert not any(r.separated for r in board.rows)
    assert board.separated(0) == "not separated"


def test_three_units_still_separate_a_consistent_gap_and_the_caption_says_why(scored):
    """The fixture's 3 garments: NOISY is worse than GT by about the same amount on every
    garment, so even the widened t(2) interval of the paired difference excludes 0; the
    caption flags the coarse groups."""
    board = build_leaderboard([scored["gt"]["res"].path, scored["noisy"]["res"].path],
                              sort_by="ed")
    assert board.separated(0) == "yes"
    lead = board.rows[1].vs_leader
    assert lead.lo > 0 and lead.hi - lead.lo > 0
    assert "allow only 10 distinct resamples" in render(board, "md")


def test_pareto_front_marked_for_uvparam():
    """uvparam editions listing QCE and seam length mark the Pareto front (◆) in every
    format (uv's request: is a low distortion bought by cutting the mesh)."""
    from types import SimpleNamespace

    from dressmeup.bench.boards.board import Column, Leaderboard
    from dressmeup.bench.boards.leaderboard import _mark_pareto
    from dressmeup.bench.edition import load_edition
    from dressmeup.bench.tasks import get_task

    ed = SimpleNamespace(task="uvparam", metrics=("qce", "seam_length", "flip"))
    rows = [_row(m, values={"qce": (q, None, 3), "seam_length": (sl, None, 3)}, items=3)
            for m, q, sl in (("few-cuts", 1.20, 0.5), ("low-qce", 1.01, 3.0),
                             ("dominated", 1.30, 4.0))]
    assert _mark_pareto(ed, rows) == ("qce", "seam_length")
    assert [r.pareto for r in rows] == [True, True, False]
    assert _mark_pareto(SimpleNamespace(task="uvparam", metrics=("qce",)), rows) == ()
    assert _mark_pareto(SimpleNamespace(task="retarget", metrics=("p2s",)), rows) == ()
    ed2 = load_edition("synth-uvparam-v2")
    specs = {sp.name: sp for sp in get_task("uvparam").metric_specs(ed2)}
    board = Leaderboard(edition=ed2, manifest_sha256=None,
                        columns=[Column(m, specs[m]) for m in ("qce", "seam_length")],
                        rows=rows, primary="qce", pareto=("qce", "seam_length"))
    assert "| few-cuts ◆ |" in render(board, "md") and "Pareto front" in render(board, "md")
    table = list(csv.DictReader(io.StringIO(render(board, "csv"))))
    assert [r["pareto"] for r in table] == ["true", "true", "false"]
    assert r"few-cuts $\diamond$" in render(board, "latex")
    assert render(board, "html").count('class="pareto"') == 2


def _row(method: str, **kw):
    """A leaderboard row with defaults for what a test does not set."""
    from dressmeup.bench.boards.board import BoardRow

    base = dict(method=method, result=method, values={}, ci={}, failed=0, items=0,
                runtime=None, url=None, authors="", comparable=True,
                not_comparable_reason=None, schema_version=1)
    return BoardRow(**{**base, **kw})


def test_a_result_edited_to_look_comparable_is_still_not(scored, tmp_path, monkeypatch):
    """Comparability is recomputed from the data pin: a summary flipped to comparable on
    other data stays unranked."""
    import dressmeup.bench.boards.leaderboard as lb

    def other(s):
        s["dataset"]["manifest_sha256"] = "f" * 64      # another dataset, claimed comparable

    odd = _copy(scored["gt"]["res"].path, tmp_path / "odd", method="ODD", edit=other)
    real = lb._edition_of

    def pinned(result):
        ed = real(result)
        import dataclasses
        pin = dataclasses.replace(ed.dataset, expected_manifest_sha256=load_result(
            scored["noisy"]["res"].path).manifest_hash)
        return dataclasses.replace(ed, dataset=pin)

    monkeypatch.setattr(lb, "_edition_of", pinned)
    board = build_leaderboard([scored["noisy"]["res"].path, odd])
    odd_row = next(r for r in board.rows if r.method == "ODD")
    assert not odd_row.comparable and "claims otherwise" in odd_row.not_comparable_reason
    assert board.rank(board.rows.index(odd_row)) == "–"


def test_result_fields_that_reach_html_are_validated(scored, tmp_path):
    """A summary whose interval bookkeeping carries markup is refused when loaded (the
    report site never sees it)."""
    from dressmeup.errors import InputError

    def evil(s):
        s["metrics"]["p2s"]["n_units"] = "<script>alert(3)</script>"

    bad = _copy(scored["gt"]["res"].path, tmp_path / "bad", edit=evil)
    with pytest.raises(InputError, match="n_units"):
        load_result(bad)

    def evil_boot(s):
        s["bootstrap"] = {"resamples": "<img src=x onerror=alert(1)>"}

    bad2 = _copy(scored["gt"]["res"].path, tmp_path / "bad2", edit=evil_boot)
    with pytest.raises(InputError, match="resamples"):
        load_result(bad2)


def test_one_track_gets_no_repeated_columns(scored, tmp_path):
    """Results whose items all carry one track: the track's columns would repeat the overall
    ones, so the board shows the overall columns only and sorts by them."""
    def one_track(t):
        t["track"] = "re-pose"
        return t

    a = _copy(scored["gt"]["res"].path, tmp_path / "a", table_edit=one_track)
    b = _copy(scored["noisy"]["res"].path, tmp_path / "b", table_edit=one_track)
    board = build_leaderboard([a, b])
    assert not [c for c in board.columns if c.track]
    assert board.primary == "p2s" and "track re-pose" not in render(board, "md")
