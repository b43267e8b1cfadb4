"""Generator 2.1.0 drawing from the registration pose set, one garment per sample, scans
without the skin under the garment (the synth-registration-v3 edition): plans and
scan geometry only, plus one slow small regeneration."""

from __future__ import annotations

import hashlib
import json
from collections import Counter

import numpy as np
import pytest

from dressmeup.bench import load_edition
from dressmeup.data.synth.common import generator_params, plan_2x, wearers
from dressmeup.data.synth.poses import pose_names
from dressmeup.data.synth.scans import clothed_scan, covered_vertices
from dressmeup.errors import InputError

#: generator 2.1.0's registration data (its pose sets and wear modes exist only in 2.x)
pytestmark = pytest.mark.cpu_kernels

EDITION = "synth-registration-v3"
HARD_POSES = ["t-pose", "wide-stance", "sitting-box", "arms-crossed", "one-knee-up",
              "bending-forward"]
#: sha256 of the plans of the pinned v3 retargeting editions, computed with the code that
#: generated their pinned data (before ``pose_set`` / ``wear`` existed)
PINNED_PLANS = {
    "synth-retarget-v3": "64c9d7ff7c030b128ab0682f7c0d6dd6b9c4d1ad4f8b018fc64bd4985ff42b18",
    "synth-retarget-mini-v3": "c55ed11b2fbde01bfbcf0e520066a0062e52a11a9f37e53d8b87fcc0962ad629",
    "synth-retarget-tiny-v3": "1209020b5dc5e3a146f17e7bd1d2562934f9e4a426df7390d0c343a925d5bc5f",
}


def _plan(name: str) -> dict:
    ed = load_edition(name)
    p = ed.dataset.params
    return plan_2x(p["subjects"], p["poses"], tuple(p["garments_per_split"]), ed.dataset.seed,
                   p.get("categories"), **{k: p[k] for k in ("pose_set", "wear") if k in p})


@pytest.mark.parametrize("name", sorted(PINNED_PLANS))
def test_default_plans_are_unchanged(name):
    plan = _plan(name)
    sha = hashlib.sha256(json.dumps(plan, sort_keys=True).encode()).hexdigest()
    assert sha == PINNED_PLANS[name]
    assert all("wearers" not in g for g in plan["garments"].values())
    assert not set(plan["poses"].values()) & set(HARD_POSES)


def test_default_parameters_are_not_recorded():
    base = dict(subjects=2, poses=2, pose_steps=2)
    assert generator_params("2.1.0", **base, pose_set="generator", wear="all",
                            scan_body="whole") == {"version": "2.1.0", **base}
    rec = generator_params("2.1.0", **base, pose_set="registration", wear="rotate",
                           scan_body="uncovered")
    assert (rec["pose_set"], rec["wear"], rec["scan_body"]) == \
        ("registration", "rotate", "uncovered")


def test_registration_pose_set_draws_the_hard_poses():
    assert pose_names("registration") == HARD_POSES
    plan = plan_2x(2, 6, (0, 0, 1), 0, pose_set="registration")
    assert list(plan["poses"].values()) == HARD_POSES
    assert list(plan_2x(2, 3, (0, 0, 1), 0, pose_set="registration")["poses"].values()) == \
        HARD_POSES[:3]
    # 'all': the generator's order first, then the hard poses
    tuning = pose_names("registration-tuning")
    every = list(plan_2x(1, 16 + len(tuning), (0, 0, 1), 0, pose_set="all")["poses"].values())
    assert every[10:16] == HARD_POSES and every[:3] == ["sitting", "arms-raised", "walking"]
    assert every[16:] == tuning
    with pytest.raises(ValueError, match="poses"):
        plan_2x(2, 7, (0, 0, 1), 0, pose_set="registration")
    with pytest.raises(ValueError, match="pose_set"):
        plan_2x(2, 2, (0, 0, 1), 0, pose_set="hard")
    with pytest.raises(ValueError, match="wear"):
        plan_2x(2, 2, (0, 0, 1), 0, wear="some")


def test_edition_plan_one_garment_per_sample():
    plan = _plan(EDITION)
    assert list(plan["poses"].values()) == HARD_POSES
    assert len(plan["subjects"]) == 4
    samples = [(s, p, gid) for gid in plan["garments"] for s, p in wearers(plan, gid)]
    # every (subject, pose) once, with one garment
    assert sorted((s, p) for s, p, _ in samples) == sorted(
        (s, p) for s in plan["subjects"] for p in plan["poses"])
    cat = {gid: g["category"] for gid, g in plan["garments"].items()}
    assert Counter(cat.values()) == {"topwear": 2, "bottomwear": 2, "dress": 2}
    assert {g["split"] for g in plan["garments"].values()} == {"test"}
    for sid in plan["subjects"]:  # each subject wears each garment once
        assert sorted(g for s, _, g in samples if s == sid) == sorted(plan["garments"])
    for pid in plan["poses"]:  # every pose shows every category
        assert {cat[g] for _, p, g in samples if p == pid} == set(cat.values())


def test_registration_poses_keep_the_arms_out_of_the_body():
    """Anny in the hard poses: (almost) no face of a forearm or hand intersects the body (the
    first arms-crossed put the forearms through the belly: 400-570 such faces; sitting-box the
    hands into the thighs: 290-1000). The slim tall woman and the heavy short man."""
    import pymeshlab

    from dressmeup.body import BodyParams, get_body_model
    from dressmeup.data.synth.common import SUBJECTS
    from dressmeup.data.synth.garments import BodyFrame
    from dressmeup.data.synth.poses import pose_axis_angle

    model = get_body_model("anny")
    keep, F = model.skin()
    names = tuple(model.joint_names)
    label = np.array(names)[np.asarray(model.skinning_weights)[keep].argmax(1)]
    arm = np.array([n.startswith(("left_", "right_")) and not any(
        k in n for k in ("hip", "knee", "ankle", "foot", "toe", "shoulder", "clav", "eye",
                         "breast")) for n in label])
    arm_face = arm[F].any(1)
    frame = BodyFrame.from_joints(model.posed(model.default_params()).rest_joints, names)
    worst = {}
    for name in ("sitting-box", "arms-crossed"):
        pose = pose_axis_angle(name, names, frame, rng=None)
        for _, shape in SUBJECTS[:2]:
            V = model.posed(BodyParams(model="anny", shape=np.array(shape), pose=pose)).vertices
            ms = pymeshlab.MeshSet()
            ms.add_mesh(pymeshlab.Mesh(np.asarray(V)[keep], F.astype(np.int32)))
            ms.compute_selection_by_self_intersections_per_face()
            hit = ms.current_mesh().face_selection_array() & arm_face
            worst[name] = max(worst.get(name, 0), int(hit.sum()))
    assert max(worst.values()) <= 50, worst


def test_generator_1_refuses_the_new_parameters(tmp_path):
    from dressmeup.data.synth import generate_dataset

    for kw in ({"pose_set": "registration"}, {"wear": "rotate"}, {"scan_body": "uncovered"}):
        with pytest.raises(InputError, match="pose_set"):
            generate_dataset(tmp_path / "d", **kw)


def test_unknown_scan_body_is_refused_before_anything_is_written(tmp_path):
    from dressmeup.data.synth.generator2 import generate_2x

    with pytest.raises(ValueError, match="scan_body"):
        generate_2x(tmp_path / "d", subjects=1, poses=1, garments_per_split=(0, 0, 1),
                    body_model="procedural", scan_body="naked")
    assert not (tmp_path / "d").exists()


def _grid(n: int, z: float, x0: float = 0.0, x1: float = 1.0, y0: float = 0.0, y1: float = 1.0):
    """A sheet at height z over [x0, x1] x [y0, y1], facing +z: ((n*n, 3) vertices, faces)."""
    xs, ys = np.meshgrid(np.linspace(x0, x1, n), np.linspace(y0, y1, n), indexing="ij")
    V = np.stack([xs.ravel(), ys.ravel(), np.full(n * n, z)], axis=1)
    k = np.arange(n * n).reshape(n, n)
    a, b, c, d = k[:-1, :-1].ravel(), k[1:, :-1].ravel(), k[1:, 1:].ravel(), k[:-1, 1:].ravel()
    return V, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_covered_skin_is_under_the_garment():
    # "skin": a sheet facing +z; "garment": a sheet 5 cm above its left part only
    body_V, body_F = _grid(11, 0.0)
    g_V, g_F = _grid(5, 0.05, -0.5, 0.45, -0.5, 1.5)
    cov = covered_vertices(body_V, body_F, g_V, g_F, reach=0.3)
    assert np.array_equal(cov, body_V[:, 0] <= 0.45 + 1e-12)
    # out of reach, or the garment behind the skin: nothing is covered
    assert not covered_vertices(body_V, body_F, g_V, g_F, reach=0.04).any()
    assert not covered_vertices(body_V, body_F, g_V - [0, 0, 0.1], g_F).any()
    V, F = clothed_scan(body_V, body_F, g_V, g_F, "uncovered")
    kept = V[:-len(g_V)]
    assert len(F) == len(g_F) + (body_F.shape[0] // 10) * 5  # the 5 uncovered columns
    assert kept[:, 0].min() >= 0.5 - 1e-12 and np.all(F.max(0) < len(V))
    # "whole": every body face, as generator 2.0.0 always wrote
    V, F = clothed_scan(body_V, body_F, g_V, g_F, "whole")
    assert np.array_equal(V, np.vstack([body_V, g_V]))
    assert np.array_equal(F, np.vstack([body_F, g_F + len(body_V)]))


@pytest.mark.slow
def test_small_registration_dataset_regenerates(tmp_path):
    """Procedural body, 2 subjects x 2 hard poses, one garment each: the files, the recorded
    parameters, a valid dataset, and the same manifest from a second run."""
    from dressmeup.bench.tasks.common import manifest_sha256
    from dressmeup.body import get_body_model
    from dressmeup.data import Dataset
    from dressmeup.data.synth import generate_dataset
    from dressmeup.data.validate import validate_dataset

    kw = dict(version="2.1.0", subjects=2, poses=2, garments_per_split=(0, 0, 1),
              categories=["topwear", "bottomwear"], body_model="procedural",
              edge_length=0.05, pose_steps=1, pose_set="registration", wear="rotate",
              scan_body="uncovered")
    a = generate_dataset(tmp_path / "a", **kw)
    info = json.loads((a / "dataset.json").read_text())
    assert info["generator"]["params"]["pose_set"] == "registration"
    assert list(info["poses"].values()) == HARD_POSES[:2]
    m = Dataset(a).manifest
    assert len(m) == 4 and m.groupby(["subject_id", "pose_id"]).size().eq(1).all()
    for sid in m["sample_id"]:  # the skin under the garment is not in the scan
        smp = Dataset(a)[sid]
        assert len(smp.scan()[0]) < len(smp.garment().vertices) + 0.95 * len(
            get_body_model("procedural").posed(smp.body()).vertices)
    assert not validate_dataset(a).problems
    b = generate_dataset(tmp_path / "b", **kw, workers=2)
    assert manifest_sha256(a) == manifest_sha256(b)
