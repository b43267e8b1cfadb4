"""Fixtures of the viz tests: the bench fixture dataset (tests/bench/conftest.py), two scored
submissions, a result whose method name is an HTML injection attempt and one whose
submission folder is gone, and the report site written from them (built once)."""

from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path

import pytest

_spec = importlib.util.spec_from_file_location(
    "bench_fixtures", Path(__file__).resolve().parents[1] / "bench" / "conftest.py")
bench_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench_fixtures)

#: A method name that would run script if a page did not escape it.
EVIL_METHOD = '<script>window.__pwned = 1</script><b>evil</b>'


def _copy_result(res: Path, dst: Path, method: str, submission_path: str | None = None) -> Path:
    shutil.copytree(res, dst)
    summary = json.loads((dst / "summary.json").read_text())
    summary["method"]["method"] = method
    if submission_path is not None:
        summary["submission"]["path"] = submission_path
    (dst / "summary.json").write_text(json.dumps(summary))
    return dst


@pytest.fixture(scope="session")
def site_inputs(tmp_path_factory) -> dict:
    """Dataset, edition, submissions and four result folders of one edition."""
    from dressmeup.bench import score_submission

    base = tmp_path_factory.mktemp("site-inputs")
    data = bench_fixtures.build_fixture_dataset(base / "data")
    edition = bench_fixtures.write_edition(base / "bench-fixture-v1.json")
    results = []
    for name, preds in (("gt", bench_fixtures.gt_predictions(data, edition)),
                        ("noisy", bench_fixtures.perturbed_predictions(data, edition))):
        sub = bench_fixtures.make_submission(base / "subs" / name, preds, edition,
                                             name.upper())
        results.append(score_submission(sub, edition, data, base / "results" / name,
                                         workers=1, show_progress=False).path)
    results.append(_copy_result(results[1], base / "results" / "evil", EVIL_METHOD))
    results.append(_copy_result(results[1], base / "results" / "gone", "GONE",
                                submission_path=str(base / "subs" / "deleted")))
    return {"data": data, "edition": edition, "results": results, "subs": base / "subs"}


@pytest.fixture(scope="session")
def site(site_inputs, tmp_path_factory):
    """The report site of :func:`site_inputs` (2 best + 2 worst pictures per method)."""
    from dressmeup.viz.site import write_site

    out = tmp_path_factory.mktemp("site") / "site"
    return write_site(site_inputs["results"], out, data_roots=[site_inputs["data"]],
                      images_per_side=2)
