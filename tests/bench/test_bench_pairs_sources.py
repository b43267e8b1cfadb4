"""``pairs.sources`` (the v4 editions): scored sources and targets are disjoint, every track
exists, and the choice is seeded per garment."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from dressmeup.bench.edition import edition_from_dict
from dressmeup.bench.tasks.retarget.data import sample_pairs
from dressmeup.data.dataset import RetargetPair


def _pairs(garments=("G01", "G02", "G03"), subjects=4, poses=3):
    out = []
    for g in garments:
        samples = [SimpleNamespace(sample_id=f"S{s:02d}-{g}-P{p}", garment_id=g,
                                   subject_id=f"S{s:02d}", pose_id=f"P{p}", category="dress")
                   for s in range(1, subjects + 1) for p in range(1, poses + 1)]
        out += [RetargetPair(f"{a.sample_id}__to__{b.sample_id}", a, b)
                for a in samples for b in samples if a is not b]
    return out


SPEC = {"seed": 0, "per_track": {"re-pose": 4, "re-shape": 4, "cross": 8},
        "sources": {"pose": "P3", "subjects": 2}}


def test_sources_and_targets_are_disjoint():
    chosen = sample_pairs(_pairs(), SPEC)
    sources = {p.source.sample_id for p in chosen}
    targets = {p.target.sample_id for p in chosen}
    assert not sources & targets
    assert len(chosen) == 3 * 16  # all pairs from 2 sources to the 10 other samples
    for g in ("G01", "G02", "G03"):
        mine = [p for p in chosen if p.source.garment_id == g]
        assert {p.source.pose_id for p in mine} == {"P3"}
        assert len({p.source.subject_id for p in mine}) == 2
        tracks = [p.track for p in mine]
        assert (tracks.count("re-pose"), tracks.count("re-shape"), tracks.count("cross")) == \
            (4, 4, 8)
    # seeded per garment: the same choice whatever the other garments
    alone = sample_pairs(_pairs(garments=("G02",)), SPEC)
    assert [p.pair_id for p in alone] == [p.pair_id for p in chosen
                                          if p.source.garment_id == "G02"]


def test_fewer_pairs_per_track_are_drawn_among_the_disjoint_ones():
    spec = {**SPEC, "per_track": {"re-pose": 1, "re-shape": 1, "cross": 1}}
    chosen = sample_pairs(_pairs(), spec)
    assert len(chosen) == 9
    sources = {p.source.sample_id for p in sample_pairs(_pairs(), SPEC)}
    assert {p.source.sample_id for p in chosen} <= sources


@pytest.mark.parametrize("bad", [{"pose": "P1"}, {"pose": 1, "subjects": 2},
                                 {"pose": "P1", "subjects": 0}])
def test_a_bad_sources_field_is_named(bad):
    d = {"schema": "dressmeup-edition/1", "name": "x", "version": 1, "task": "retarget",
         "dataset": {"kind": "real", "name": "x", "manifest_sha256": "0" * 64},
         "split": "test", "metrics": ["p2s"], "primary_metric": "p2s",
         "tracks": ["re-pose", "re-shape", "cross"],
         "primary": {"metric": "p2s", "track": "cross"},
         "pairs": {"seed": 0, "per_track": {"cross": 1}, "sources": bad}}
    with pytest.raises(Exception, match="pairs.sources"):
        edition_from_dict(d)
