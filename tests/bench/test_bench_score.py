"""Scoring: ground truth scores perfectly, a frozen perturbed submission keeps its numbers,
failures are recorded, results are never overwritten, pool == serial."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dressmeup.bench import load_result, score_submission
from dressmeup.bench.scoring.score import InvalidSubmissionError
from dressmeup.errors import InputError
from dressmeup.executors import LocalExecutor


def test_ground_truth_scores_zero_distance_and_unit_nc(scored):
    t = scored["gt"]["res"].table
    same = t[~t["ed"].isna()]
    assert len(same) == 14 and (t["status"] == "ok").all()
    # Pairs whose ground truth keeps the source topology: exactly the ground truth.
    assert np.all(np.abs(same["p2s"]) < 1e-12)
    assert np.all(np.abs(same["p2s_bi"]) < 1e-12)
    assert np.all(same["chamfer"] == 0.0)
    assert np.all(same["ed"] == 0.0)
    np.testing.assert_allclose(same["nc"], 1.0, atol=1e-12)
    # IR equals the ground truth's own IR against the target body, and is not trivial.
    np.testing.assert_allclose(same["ir"], same["ir_gt"], atol=0)
    assert same["ir"].max() > 0.01
    # Remeshed targets (G03-P2): ED undefined, recorded as NaN with a reason.
    other = t[t["ed"].isna()]
    assert set(other["garment_id"]) == {"G03"}
    assert all("topology" in n for n in other["note"])


def test_summary_and_provenance(scored, bench_edition):
    from dressmeup.bench import load_edition, submission_hash

    res = scored["gt"]["res"]
    s = json.loads((res.path / "summary.json").read_text())
    ed = load_edition(bench_edition)
    assert s["edition"]["hash"] == ed.hash == s["provenance"]["edition_hash"]
    assert s["counts"] == {"items": 18, "ok": 18, "failed": 0}
    assert s["metrics"]["ed"]["n"] == 14
    assert set(s["per_category"]) == {"topwear", "bottomwear", "dress"}
    assert s["per_category"]["topwear"]["items"] == 6
    prov = s["provenance"]
    for key in ("toolkit_version", "manifest_sha256", "submission_sha256", "started_utc",
                "host", "duration_s"):
        assert prov[key], key
    assert prov["submission_sha256"] == submission_hash(scored["gt"]["sub"])
    assert s["method"]["method"] == "GT" and s["method"]["runtime_per_sample_s"] == 0.5
    table = pd.read_parquet(res.path / "per_sample.parquet")
    assert list(table["sample_id"]) == sorted(table["sample_id"])
    assert {"sample_id", "category", "p2s", "ed", "status", "error"} <= set(table.columns)


# Frozen regression values (tests/bench/frozen/retarget.json, changes explained in
# tests/bench/frozen/CHANGES.md): scoring GT + N(0, 2 mm) noise (seed 7) with 2,000 samples.
_FROZEN_FILE = json.loads((Path(__file__).parent / "frozen" / "retarget.json").read_text())
FROZEN = _FROZEN_FILE["metrics"]
FROZEN_CATEGORY_P2S = _FROZEN_FILE["per_category_p2s"]


def test_frozen_summary_of_perturbed_submission(scored):
    s = scored["noisy"]["res"].summary
    got = {m: s["metrics"][m]["mean"] for m in s["metrics"]}
    got_cat = {c: v["metrics"]["p2s"]["mean"] for c, v in s["per_category"].items()}
    for m, v in FROZEN.items():
        assert got[m] == pytest.approx(v, rel=1e-6, abs=1e-12), m
    for c, v in FROZEN_CATEGORY_P2S.items():
        assert got_cat[c] == pytest.approx(v, rel=1e-6, abs=1e-12), c


def test_noise_makes_every_metric_worse(scored):
    gt, noisy = scored["gt"]["res"].summary, scored["noisy"]["res"].summary
    for m in ("p2s", "p2s_bi", "chamfer", "ed"):
        assert noisy["metrics"][m]["mean"] > gt["metrics"][m]["mean"] + 1e-4 ** 2
    assert noisy["metrics"]["nc"]["mean"] < gt["metrics"]["nc"]["mean"]
    # ED of isotropic noise: mean |N(0, s^2 I3)| = s * sqrt(8/pi) ~ 3.19 mm.
    assert noisy["metrics"]["ed"]["mean"] == pytest.approx(0.002 * math.sqrt(8 / math.pi),
                                                           rel=0.05)


def test_results_are_never_overwritten(scored, bench_edition, bench_data):
    res = scored["gt"]["res"]
    before = (res.path / "summary.json").read_bytes()
    with pytest.raises(InputError, match="never overwrites"):
        score_submission(scored["gt"]["sub"], bench_edition, bench_data, res.path, workers=1)
    assert (res.path / "summary.json").read_bytes() == before


def test_invalid_submission_is_not_scored(scored, bench_edition, bench_data, tmp_path):
    import shutil

    sub = tmp_path / "sub"
    shutil.copytree(scored["gt"]["sub"], sub)
    next(sub.glob("*.npz")).unlink()
    with pytest.raises(InvalidSubmissionError) as info:
        score_submission(sub, bench_edition, bench_data, tmp_path / "res", workers=1)
    assert [p.kind for p in info.value.report.problems] == ["missing"]
    assert not (tmp_path / "res").exists()


class FlakyExecutor(LocalExecutor):
    """Runs in-process but makes one job fail, like a crashing worker would."""

    def run(self, fn, jobs):
        def flaky(job):
            if job["item_id"].startswith("S01-G02-P1__to__S01-G02-P0"):
                raise RuntimeError("simulated failure")
            return fn(job)
        yield from super().run(flaky, jobs)


def test_failing_sample_is_recorded_and_run_goes_on(scored, bench_edition, bench_data,
                                                     tmp_path):
    res = score_submission(scored["gt"]["sub"], bench_edition, bench_data, tmp_path / "r",
                           executor=FlakyExecutor(1), show_progress=False)
    t = res.table
    bad = t[t["status"] == "error"]
    assert list(bad["sample_id"]) == ["S01-G02-P1__to__S01-G02-P0"]
    assert "simulated failure" in bad["error"].iloc[0] and math.isnan(bad["p2s"].iloc[0])
    assert res.summary["counts"] == {"items": 18, "ok": 17, "failed": 1}
    assert res.summary["per_category"]["bottomwear"]["failed"] == 1
    loaded = load_result(res.path)
    assert loaded.summary["counts"]["failed"] == 1 and len(loaded.table) == 18


def test_process_pool_gives_the_serial_numbers(scored, bench_edition, bench_data, tmp_path):
    res = score_submission(scored["noisy"]["sub"], bench_edition, bench_data, tmp_path / "p",
                           workers=2, show_progress=False)
    serial = scored["noisy"]["res"]
    cols = ["p2s", "p2s_bi", "chamfer", "ed", "nc", "ir"]
    pd.testing.assert_frame_equal(res.table[["sample_id", *cols]],
                                  serial.table[["sample_id", *cols]])
    assert res.summary["provenance"]["workers"] == 2


def _crash(job):
    import os

    if job == 1:
        os._exit(3)  # a worker dies (segfault-like)
    return job * 10


def test_local_executor_reports_a_dead_worker_without_raising():
    results = dict(LocalExecutor(2).run(_crash, [0, 1, 2, 3]))
    assert sorted(results) == [0, 1, 2, 3]
    assert isinstance(results[1], BaseException)
    # Jobs that finished before the crash keep their results; the others carry the error.
    assert all(r == i * 10 or isinstance(r, BaseException) for i, r in results.items())
