"""benchmarks/perf/synth_g4_figures.py on a large edition: worst samples first, breakdowns
that count failed motions apart from targets skipped for want of a source."""

from __future__ import annotations

from tests.bench.conftest import benchmark_script


def _item(i, gtype, family, inside=0.0, selfi=0, free=True, unconv=0, failed=None):
    stats = ({"failed": failed} if failed else
             {"inside_area_pct": inside, "self_intersecting_faces": selfi,
              "intersection_free": free, "unconverged_frames": unconv})
    return {"id": f"S00{i}-G001-P00{i}", "garment": {"type": gtype, "fit": "regular"},
            "family": family, "stats": stats}


def test_worst_first_and_breakdown_counts():
    f = benchmark_script("perf/synth_g4_figures")
    samples = [_item(1, "t-shirt", "sitting"), _item(2, "t-shirt", "walking", inside=0.3),
               _item(3, "skirt", "sitting", selfi=4), _item(4, "skirt", "sitting", free=False)]
    assert [s["id"][:4] for s in sorted(samples, key=f.badness)] == [
        "S002", "S003", "S004", "S001"]
    failed = [_item(5, "skirt", "sitting", failed="frame 3 of 75: over the budget"),
              _item(6, "skirt", "walking", failed="the garment has no source: ...")]
    rows = f.breakdown(samples, failed, lambda x: x["garment"]["type"])
    assert rows == ["| skirt | 2 | 1 | 1 | 0.000 / 0.000 | 0 |",
                    "| t-shirt | 2 | 0 | 0 | 0.150 / 0.300 | 0 |"]


def test_read_samples_keeps_only_the_asked_splits(tmp_path):
    """``--splits train val``: no test garment's sample or failed target is read."""
    import json

    f = benchmark_script("perf/synth_g4_figures")
    gen = tmp_path / "generator"
    for sub in ("garments", "stats", "failed"):
        (gen / sub).mkdir(parents=True)
    for gid, split in (("G001", "train"), ("G002", "val"), ("G003", "test")):
        (gen / "garments" / f"{gid}.json").write_text(json.dumps({"split": split}))
        (gen / "stats" / f"S001-{gid}-P001.json").write_text(json.dumps({"cpu_s": 1.0}))
    (gen / "failed" / "S002-G003-P001.json").write_text(json.dumps({"failed": "budget"}))
    (tmp_path / "dataset.json").write_text(json.dumps({"poses": {"P001": {"family": "a"}}}))
    _, samples, failed = f.read_samples(tmp_path, ("train", "val"))
    assert [s["gid"] for s in samples] == ["G001", "G002"] and failed == []
    _, samples, failed = f.read_samples(tmp_path)
    assert len(samples) == 3 and [x["gid"] for x in failed] == ["G003"]
