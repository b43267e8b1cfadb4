"""Editions: shipped ones load, hashes are canonical, invalid files list every problem."""

from __future__ import annotations

import json

import pytest

from dressmeup.bench.edition import edition_from_dict, list_editions, load_edition
from dressmeup.errors import InputError


def test_shipped_editions_load():
    names = list_editions()
    assert "synth-retarget-v2" in names
    for name in names:
        ed = load_edition(name)
        assert ed.name == name and len(ed.hash) == 64
        assert ed.primary.metric in ed.metrics


def test_synth_retarget_defaults():
    ed = load_edition("synth-retarget-v2")
    assert ed.task == "retarget" and ed.split == "test"
    assert ed.options["n_samples"] == 100_000 and ed.options["size_limit_mb"] == 256
    assert ed.dataset.kind == "generated" and ed.dataset.seed is not None


def test_hash_is_canonical(bench_edition, tmp_path):
    ed = load_edition(bench_edition)
    d = json.loads(bench_edition.read_text())
    # Reordering keys and rewording the description keep the hash...
    d2 = dict(reversed(list(d.items())))
    d2["description"] = "another text"
    assert edition_from_dict(d2).hash == ed.hash
    # ...filling in a default explicitly too; changing any option does not.
    d3 = dict(d, options={**d["options"], "size_limit_mb": 256})
    assert edition_from_dict(d3).hash == ed.hash
    d4 = dict(d, options={**d["options"], "seed": 1})
    assert edition_from_dict(d4).hash != ed.hash
    # save -> load round trip
    ed.save(tmp_path / "e.json")
    assert load_edition(tmp_path / "e.json").hash == ed.hash


def test_invalid_edition_lists_every_problem():
    bad = {"name": "bad name", "version": 0, "task": "retarget",
           "dataset": {"kind": "generated", "generator": "x"},
           "split": "test", "metrics": ["p2s", "qce"], "options": {"n_samples": -1, "foo": 1},
           "primary_metric": "ed"}
    with pytest.raises(InputError) as info:
        edition_from_dict(bad)
    msg = str(info.value)
    for part in ("name must use", "version must be", "dataset.generator_version",
                 "dataset.seed", "'qce' is not a retarget metric", "unknown option 'foo'",
                 "'n_samples' must be a number", "primary_metric 'ed'"):
        assert part in msg, part


def test_unknown_name_lists_shipped(tmp_path):
    with pytest.raises(InputError, match="synth-retarget-v2"):
        load_edition("no-such-edition")
    with pytest.raises(InputError, match="does not exist"):
        load_edition(tmp_path / "missing.json")


def _shipped(name: str) -> dict:
    from importlib import resources

    return json.loads((resources.files("dressmeup.bench") / "editions" / f"{name}.json")
                      .read_text(encoding="utf-8"))


def test_an_edition_beyond_the_resource_policy_is_refused_naming_file_and_field(
        tmp_path, monkeypatch, capsys):
    """n_samples 2e9 (scored as 'every item failed') and pairs.per_track 10^7 (a submission
    of six items validated against it) are refused when the edition is loaded."""
    from dressmeup.cli import main

    d = _shipped("synth-retarget-tiny-v4")
    d["options"]["n_samples"] = 2e9
    d["pairs"]["per_track"]["cross"] = 10 ** 7
    path = tmp_path / "huge.json"
    path.write_text(json.dumps(d))
    with pytest.raises(InputError) as info:
        load_edition(path)
    msg = str(info.value)
    assert msg.startswith(f"edition {path} is invalid")
    assert "options.n_samples: surface samples per mesh 2,000,000,000, over the limit" in msg
    assert "pairs.per_track['cross']: pairs per source garment 10,000,000, over the limit" in msg
    # the command line refuses it as a user error, naming the file and the field
    assert main(["editions", str(path)]) == 2
    assert "options.n_samples" in capsys.readouterr().err
    # the limits are the policy's: raising them admits the edition
    monkeypatch.setenv("DRESSMEUP_MAX_SURFACE_SAMPLES", "4G")
    monkeypatch.setenv("DRESSMEUP_MAX_TABLE_ROWS", "16M")
    assert load_edition(path).options["n_samples"] == 2e9


def test_edition_sizes_of_other_tasks_and_counts_are_checked():
    corr = _shipped("synth-correspondence-v2")
    corr.setdefault("options", {}).update(max_vertices=100_000, k=2.5)
    with pytest.raises(InputError) as info:
        edition_from_dict(corr, "c.json")
    assert "options.max_vertices: geodesic distance matrix" in str(info.value)
    assert "options.k must be an integer >= 1, got 2.5" in str(info.value)
    uv = _shipped("synth-uvparam-v2")
    uv.setdefault("options", {})["overlap_resolution"] = 1_000_000
    with pytest.raises(InputError, match=r"options.overlap_resolution: overlap grid"):
        edition_from_dict(uv, "u.json")
    ret = _shipped("synth-retarget-tiny-v4")
    ret["options"]["n_samples"] = 0
    with pytest.raises(InputError, match=r"options.n_samples must be an integer >= 1"):
        edition_from_dict(ret, "r.json")
