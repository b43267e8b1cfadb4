"""The thesis' protocol as an edition: re-pose pairs of topwear and bottomwear, scored with
the thesis' literal P2S (garment vertices to the target body surface) beside ours."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from dressmeup.bench import load_edition
from dressmeup.bench.tasks.retarget.data import sample_pairs
from dressmeup.bench.tasks.retarget.evaluate import evaluate_pair
from dressmeup.errors import InputError


def test_the_thesis_edition_scores_re_pose_of_topwear_and_bottomwear():
    ed = load_edition("synth-retarget-thesis-v3")
    v3 = load_edition("synth-retarget-v3")
    assert ed.dataset == v3.dataset                 # the same data, another protocol
    assert ed.tracks == ("re-pose",) and "p2s_body" in ed.metrics
    assert ed.pairs["categories"] == ["topwear", "bottomwear"]
    assert ed.pairs["source_poses"] == ["P1"]


class _S:
    def __init__(self, sid, garment, subject, pose, category):
        self.sample_id, self.garment_id, self.subject_id = sid, garment, subject
        self.pose_id, self.category = pose, category


class _P:
    def __init__(self, s, t):
        self.source, self.target = s, t
        self.pair_id = f"{s.sample_id}__to__{t.sample_id}"
        self.track = "re-pose" if s.subject_id == t.subject_id else "cross"


def test_pair_sampling_keeps_the_named_categories_only():
    samples = [_S(f"{sub}-{g}-{p}", g, sub, p, cat)
               for g, cat in (("G1", "topwear"), ("G2", "dress"), ("G3", "bottomwear"))
               for sub in ("S1", "S2") for p in ("P1", "P2")]
    pairs = [_P(a, b) for a in samples for b in samples
             if a is not b and a.garment_id == b.garment_id]
    got = sample_pairs(pairs, {"seed": 0, "per_track": {"re-pose": 10},
                               "categories": ["topwear", "bottomwear"]})
    assert {p.source.category for p in got} == {"topwear", "bottomwear"}
    assert all(p.track == "re-pose" for p in got) and len(got) == 8
    held = sample_pairs(pairs, {"seed": 0, "per_track": {"re-pose": 10},
                                "source_poses": ["P1"]})
    assert {p.source.pose_id for p in held} == {"P1"} and {p.target.pose_id for p in held} \
        == {"P2"}
    assert not {p.source.sample_id for p in held} & {p.target.sample_id for p in held}


def test_a_track_the_data_has_no_pair_in_is_an_error_not_an_empty_column():
    samples = [_S(f"S1-G1-{p}", "G1", "S1", p, "topwear") for p in ("P1", "P2")]
    pairs = [_P(a, b) for a in samples for b in samples if a is not b]  # re-pose only
    assert len(sample_pairs(pairs, {"seed": 0, "per_track": {"re-pose": 5}})) == 2
    with pytest.raises(InputError, match=r"per_track names track\(s\) 'cross', but this "
                                         r"data has no pair in them"):
        sample_pairs(pairs, {"seed": 0, "per_track": {"re-pose": 1, "cross": 1}})


def test_p2s_body_is_the_distance_of_garment_vertices_to_the_body():
    """A sphere garment 5 mm outside a sphere body of the same tessellation: every garment
    vertex is 5 mm from the body (its closest body point is the body vertex below it)."""
    body = trimesh.creation.icosphere(subdivisions=3, radius=0.3)
    garment = trimesh.creation.icosphere(subdivisions=3, radius=0.305)
    V, F = np.asarray(garment.vertices), np.asarray(garment.faces, np.int64)
    B = (np.asarray(body.vertices), np.asarray(body.faces, np.int64))
    values, _ = evaluate_pair(V, F, V, F, B, ["p2s", "p2s_body", "ir"],
                              {"n_samples": 2000, "seed": 0})
    assert values["p2s_body"] == pytest.approx(0.005, abs=1e-9)
    assert values["p2s"] == pytest.approx(0.0, abs=1e-12) and values["ir"] == 0.0
    values, notes = evaluate_pair(V, F, V, F, None, ["p2s_body"], {"n_samples": 10, "seed": 0})
    assert np.isnan(values["p2s_body"]) and "no target body" in notes[0]
