"""Body and pose samplers (dressmeup.data.synth.sampling)."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body import get_body_model
from dressmeup.body.params import BodyParams
from dressmeup.data.synth.garments import BodyFrame
from dressmeup.data.synth.sampling import (
    BODY_RANGES,
    POSE_FAMILIES,
    SelfIntersectionCheck,
    _segments_cross,
    family_rotations,
    pose_limits,
    sample_bodies,
    sample_poses,
    self_intersections,
)
from dressmeup.errors import DressmeupError, InputError


@pytest.fixture(scope="module")
def procedural():
    model = get_body_model("procedural")
    names = tuple(model.joint_names)
    frame = BodyFrame.from_joints(model.posed(model.default_params()).rest_joints, names)
    return model, names, frame


def test_bodies_in_range_and_strata_covered():
    bodies = sample_bodies(np.random.default_rng(3), 24)
    S = np.stack([b.shape for b in bodies])
    lo = np.array([r[0] for r in BODY_RANGES.values()])
    hi = np.array([r[1] for r in BODY_RANGES.values()])
    assert S.shape == (24, 6) and (S >= lo).all() and (S <= hi).all()
    # Latin hypercube: each parameter has exactly one body in each of the 24 strata
    for d in range(6):
        strata = np.floor((S[:, d] - lo[d]) / (hi[d] - lo[d]) * 24).astype(int)
        assert sorted(strata) == list(range(24))
    names = [b.name for b in bodies]
    assert len(set(names)) == 24
    for word in ("female", "male", "heavy", "light", "tall", "short"):
        assert sum(n.split("-")[0 if word.endswith("male") else None] == word
                   if word.endswith("male") else word in n.split("-") for n in names) >= 6
    years = [b.years for b in bodies]
    assert min(years) < 40 and max(years) > 75


@pytest.mark.parametrize("n", [6, 7, 11])
def test_small_draws_cover_both_halves(n):
    for seed in range(5):
        S = np.stack([b.shape for b in sample_bodies(np.random.default_rng(seed), n)])
        for name, split in [("gender", 0.5), ("age", 0.825), ("weight", 0.5),
                            ("height", 0.5)]:
            col = S[:, ["gender", "age", "muscle", "weight", "height"].index(name)]
            assert (col < split).any() and (col >= split).any(), (n, seed, name)


def test_bodies_deterministic_and_seed_dependent():
    a = sample_bodies(np.random.default_rng(5), 24)
    b = sample_bodies(np.random.default_rng(5), 24)
    c = sample_bodies(np.random.default_rng(6), 24)
    assert [x.name for x in a] == [x.name for x in b]
    assert all(np.array_equal(x.shape, y.shape) for x, y in zip(a, b, strict=True))
    assert not np.allclose(np.stack([x.shape for x in a]), np.stack([x.shape for x in c]))
    with pytest.raises(InputError, match="n must be"):
        sample_bodies(np.random.default_rng(0), 0)


def test_family_angles_within_limits():
    limits = pose_limits()
    rng = np.random.default_rng(0)
    assert len(POSE_FAMILIES) == 8
    for fam in POSE_FAMILIES:
        for _ in range(50):
            for joint, axis, deg in family_rotations(rng, fam):
                lo, hi = limits[(joint, axis)]
                assert lo <= deg <= hi, (fam, joint, axis, deg)
    # the right side mirrors the left: elbow flexion forward is about -up on the left
    assert limits[("left_elbow", "up")] == (-150.0, 0.0)
    assert limits[("right_elbow", "up")] == (0.0, 150.0)
    assert limits[("right_knee", "left")] == limits[("left_knee", "left")] == (0.0, 150.0)


def test_poses_deterministic_and_joint_caps(procedural):
    model, names, frame = procedural
    for fam in POSE_FAMILIES:
        a = sample_poses(np.random.default_rng(1), fam, names, frame)
        b = sample_poses(np.random.default_rng(1), fam, names, frame)
        c = sample_poses(np.random.default_rng(2), fam, names, frame)
        assert a.shape == (len(names), 3) and np.array_equal(a, b) and not np.allclose(a, c)
        for j in ("left_knee", "right_knee", "left_elbow", "right_elbow"):
            assert np.degrees(np.linalg.norm(a[names.index(j)])) <= 150 + 1e-9
    with pytest.raises(InputError, match="unknown family"):
        sample_poses(np.random.default_rng(0), "cartwheel", names, frame)


def test_sitting_bends_knees_and_hips(procedural):
    model, names, frame = procedural
    pose = sample_poses(np.random.default_rng(4), "sitting", names, frame)
    out = model.posed(BodyParams(model=model.name, shape=model.default_shape, pose=pose))
    J = {n: out.joints[i] for i, n in enumerate(names)}
    for side in ("left", "right"):
        thigh = J[f"{side}_knee"] - J[f"{side}_hip"]
        shin = J[f"{side}_ankle"] - J[f"{side}_knee"]
        assert thigh @ frame.forward > 0.7 * np.linalg.norm(thigh)  # thigh forward
        assert shin @ frame.up < -0.7 * np.linalg.norm(shin)  # shin down


def test_segment_triangle_crossing_against_naive():
    rng = np.random.default_rng(0)
    T = rng.normal(size=(400, 3, 3))
    P0, P1 = rng.normal(size=(400, 3)), rng.normal(size=(400, 3))
    got = _segments_cross(P0, P1, T)
    for k in range(400):  # naive: the plane crossing point inside the triangle
        a, b, c = T[k]
        n = np.cross(b - a, c - a)
        d0, d1 = (P0[k] - a) @ n, (P1[k] - a) @ n
        if d0 * d1 > 0:
            assert not got[k]
            continue
        x = P0[k] + (P1[k] - P0[k]) * d0 / (d0 - d1)
        inside = all(np.cross(q - p, x - p) @ n >= 0 for p, q in ((a, b), (b, c), (c, a)))
        assert got[k] == inside


def test_check_rejects_forearm_through_chest(procedural):
    model, names, frame = procedural
    check = SelfIntersectionCheck(model, model.default_shape, tolerance=10)
    assert check.rest_faces == 0
    ok = sample_poses(np.random.default_rng(0), "standing", names, frame)
    assert check(ok)
    # the left arm swung forward and across, the forearm folded into the chest
    bad = np.zeros((len(names), 3))
    bad[names.index("left_shoulder")] = np.radians(-140) * frame.up
    bad[names.index("left_elbow")] = np.radians(-90) * frame.up
    V = check.vertices(bad)
    total, distant = self_intersections(V, check.faces, check.face_joint, check.far)
    assert distant > check.rest_faces + 10 and total >= distant
    assert not check(bad)
    assert (check.calls, check.accepted) == (2, 1)
    with pytest.raises(DressmeupError, match="passed the check"):
        sample_poses(np.random.default_rng(0), "standing", names, frame,
                     check=lambda pose: False, max_attempts=3)


@pytest.mark.slow
def test_anny_sampled_poses_pass_the_check():
    model = get_body_model("anny")
    names = tuple(model.joint_names)
    body = sample_bodies(np.random.default_rng(0), 6)[1]
    rest = model.posed(BodyParams(model=model.name, shape=body.shape, pose=np.zeros((22, 3))))
    frame = BodyFrame.from_joints(rest.rest_joints, names)
    check = SelfIntersectionCheck(model, body.shape)
    rng = np.random.default_rng(0)
    for fam in POSE_FAMILIES:
        pose = sample_poses(rng, fam, names, frame, check=check)
        assert check.count(check.vertices(pose)) <= check.rest_faces + check.tolerance
