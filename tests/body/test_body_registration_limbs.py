"""Limb-wise search and unseen body points (registration out of local minima)."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.registration.plan import BENDS, LimbSearch, Rates
from dressmeup.body.registration.problem import Correspondences, Objective
from dressmeup.body.synthetic import synthetic_scan
from dressmeup.geometry import neighbors


@pytest.fixture(scope="module")
def model():
    return get_body_model("procedural")


def _problem(model, scan, **settings):
    from dressmeup.body.registration.config import get_config
    from dressmeup.body.registration.problem import FitProblem
    from dressmeup.body.registration.scan import prepare_scan

    config = get_config(n_scan_points=3000, n_body_points=2000, **settings)
    return FitProblem.from_config(config, model, prepare_scan(scan, 3000, 0))


RATES = Rates(0.015, 0.01, 0.05)


def _search(aim: str = "none", pose_steps: int = 0, knees=BENDS) -> LimbSearch:
    """A limb search stage: arms with every bend, legs with ``knees``."""
    return LimbSearch(aim=aim, knee_bends=knees, elbow_bends=BENDS, pose_steps=pose_steps,
                      size=False, far_cloth=False, rates=RATES)


def _arm_across_chest(model):
    """A-pose with the right arm folded across the chest (no canonical pose is near it)."""
    from dressmeup.body.registration.hypotheses import align_directions, canonical_pose

    names = list(model.joint_names)
    rest = model.posed(model.default_params()).joints
    pose = canonical_pose("a-pose", names, rest)
    s, e = names.index("right_shoulder"), names.index("right_elbow")
    pose[s] = align_directions(rest[e] - rest[s], np.array([-0.3, -1.0, 0.7]))
    pose[e] = (0.0, np.deg2rad(120), 0.0)
    pose[0] = (0.0, 0.6, 0.0)
    return pose


def test_limb_search_folds_an_arm_the_start_left_hanging(model):
    from dressmeup.body.registration.hypotheses import canonical_pose
    from dressmeup.body.registration.limbs import limb_search

    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=_arm_across_chest(model),
                       transl=[0.1, 0.0, 0.2])
    scan = synthetic_scan(model, truth, n_points=8000, noise=0.002, seed=0)
    problem = _problem(model, scan)
    # the start the hypotheses leave: right pose everywhere but the folded arm, which hangs
    start = truth.pose.copy()
    a_pose = canonical_pose("a-pose", model.joint_names, model.posed(model.default_params()).joints)
    names = list(model.joint_names)
    for j in ("right_shoulder", "right_elbow"):
        start[names.index(j)] = a_pose[names.index(j)]
    problem.set_params(shape=truth.shape, pose=start, transl=truth.transl)
    wrist = names.index("right_wrist")
    true_wrist = model.posed(truth).joints[wrist]

    def wrist_error():
        return float(np.linalg.norm(model.posed(problem.body_params()).joints[wrist]
                                    - true_wrist))

    before = wrist_error()
    info = limb_search(problem, _search(pose_steps=40), Objective("pose"))
    after = wrist_error()
    assert before > 0.2  # metres: the hanging hand is far from the folded one
    assert "right_shoulder" in info["limbs_moved"] and info["limb_kept"]
    assert after < 0.04, (before, after)
    assert info["limb_score"][1] < info["limb_score"][0]


def test_limb_search_keeps_a_body_it_cannot_improve(model):
    """On a scan of the body as it is, no limb moves: the search reports the start's score
    twice and leaves every parameter as it was, bit for bit."""
    from dressmeup.body.registration.limbs import limb_search

    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=_arm_across_chest(model))
    problem = _problem(model, synthetic_scan(model, truth, n_points=6000, noise=0.0, seed=3))
    problem.set_params(shape=truth.shape, pose=truth.pose)
    before = problem.snapshot()
    info = limb_search(problem, _search(knees=(0.0, 50.0)), Objective("pose"))
    assert info["limbs_moved"] == [] and not info["limb_kept"]
    assert info["limb_score"][0] == info["limb_score"][1]
    assert all(np.array_equal(before[k], v) for k, v in problem.snapshot().items())


@pytest.mark.parametrize("scan_cap", [None, 0.03])
def test_limb_scorer_matches_the_symmetric_score(model, scan_cap):
    from scipy.spatial import cKDTree

    from dressmeup.body.registration.init import symmetric_score
    from dressmeup.body.registration.limbs import LimbScorer

    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=_arm_across_chest(model))
    problem = _problem(model, synthetic_scan(model, truth, n_points=6000, seed=1))
    problem.set_params(shape=truth.shape, pose=truth.pose)
    out = model.posed(problem.body_params())
    names = list(model.joint_names)
    dom = problem.W_sub.numpy().argmax(1)
    up, lo = names.index("left_shoulder"), names.index("left_elbow")
    Vb = out.vertices[problem.body_ids]
    limb_up, limb_lo = dom == up, np.isin(dom, [lo, names.index("left_wrist")])
    scorer = LimbScorer(problem.P, problem.tree, Vb, limb_up, limb_lo, out.joints[up],
                        out.joints[lo], scan_cap=scan_cap)
    assert scorer.score(np.eye(3), np.eye(3)) == pytest.approx(
        symmetric_score(problem, scan_cap=scan_cap), rel=1e-4)
    turn = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # the arm swung away: worse
    assert scorer.score(turn, turn) > scorer.score(np.eye(3), np.eye(3)) + 0.002
    # the moved limb scored by brute force: the body's points with the limb's replaced
    V = np.r_[Vb[~(limb_up | limb_lo)], scorer.points(turn, turn)]
    cap_s = 0.1 if scan_cap is None else scan_cap
    slow = (np.minimum(cKDTree(problem.P).query(V)[0], 0.1).mean()
            + np.minimum(cKDTree(V).query(problem.P)[0], cap_s).mean())
    assert scorer.score(turn, turn) == pytest.approx(slow, rel=1e-6)
    # the score queries only the scan points the moved limb can come closer to; every scan
    # point queried gives the same value, bit for bit, on turns near and far
    from scipy.spatial.transform import Rotation

    def every_point(M_up, M_lo):
        X = scorer.points(M_up, M_lo)
        b = np.minimum(problem.tree.query(X, distance_upper_bound=0.1)[0], 0.1).sum()
        d = cKDTree(X).query(scorer.P_near, distance_upper_bound=scorer.scan_cap)[0]
        s = np.minimum(scorer.d_near, d).sum()
        return (scorer.const_body + b) / scorer.n_b + (scorer.const_scan + s) / scorer.n_p

    rng = np.random.default_rng(0)
    for k in range(40):
        spread = 0.2 if k % 2 else np.pi
        M_up, M_lo = Rotation.from_rotvec(rng.normal(0, spread, (2, 3))).as_matrix()
        full = scorer.score(M_up, M_lo)
        assert full == every_point(M_up, M_lo)
        # with a bound the score is the same, or inf when it is above the bound
        for above in (full * 0.9, full, full * 1.1, np.inf):
            bounded = scorer.score(M_up, M_lo, above)
            assert bounded == full or (bounded == np.inf and full > above), (full, above)
        assert scorer.score(M_up, M_lo, 0.5 * full) == np.inf  # far enough: skipped


@pytest.mark.skipif(neighbors._pykdtree_class() is None, reason="pykdtree not installed")
def test_fit_objective_is_the_same_on_both_nearest_point_backends(model, monkeypatch):
    """The data term's correspondences come from NearestTree: pykdtree and scipy find the
    same neighbours, so the loss, its gradient and the symmetric score agree."""
    from dressmeup.body.registration.init import symmetric_score

    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=_arm_across_chest(model))
    scan = synthetic_scan(model, truth, n_points=6000, noise=0.003, seed=2)
    out = {}
    for backend in ("scipy", "pykdtree"):
        monkeypatch.setattr(neighbors, "BACKEND", backend)
        problem = _problem(model, scan)
        problem.set_params(shape=np.full(6, 0.45), pose=truth.pose * 0.8)
        pairs = Correspondences()
        loss, _ = problem.loss(Objective("pose"), pairs)
        loss.backward()
        out[backend] = (float(loss.detach()), problem.pose.grad.numpy().copy(),
                        pairs.nn_b2s.numpy(), pairs.nn_s2b.numpy(),
                        symmetric_score(problem, scan_cap=0.03))
    a, b = out["scipy"], out["pykdtree"]
    assert a[0] == b[0] and a[4] == b[4]
    np.testing.assert_array_equal(a[1], b[1])
    np.testing.assert_array_equal(a[2], b[2])
    np.testing.assert_array_equal(a[3], b[3])


def test_symmetric_score_caps_each_direction_on_its_own(model):
    """Analytic: a scan of the body's own points plus points 5 cm off it; the scan -> body
    term pays each far point its distance up to ``scan_cap``, the body -> scan term is 0."""
    from scipy.spatial import cKDTree

    from dressmeup.body.registration.init import symmetric_score

    problem = _problem(model, synthetic_scan(model, model.default_params(), n_points=3000))
    problem.set_params(shape=np.full(6, 0.5))
    V = problem.posed_numpy()[problem.body_ids]
    far = V[:500] + np.array([0.0, 0.0, 0.05])  # 5 cm in front of 500 body points
    far = far[cKDTree(V).query(far)[0] > 0.045]  # keep those 5 cm from the whole body
    d_far = cKDTree(V).query(far)[0]
    problem.P = np.r_[V, far]
    problem.tree = cKDTree(problem.P)
    n = len(problem.P)
    for scan_cap in (0.1, 0.03):
        expected = np.minimum(d_far, scan_cap).sum() / n
        assert symmetric_score(problem, scan_cap=scan_cap) == pytest.approx(expected, abs=1e-9)
    assert symmetric_score(problem, scan_cap=0.03) == pytest.approx(0.03 * len(far) / n)


def test_unseen_body_points_carry_no_body_to_scan_cost():
    import torch

    from dressmeup.body.registration.terms import unseen_free_weights

    # a flat body: 2 front points (normal +z) and 2 back points (normal -z); the scan only
    # saw the front, so both back points' nearest scan point belongs to the front surface
    normals = torch.tensor([[0, 0, 1.0], [0, 0, 1.0], [0, 0, -1.0], [0, 0, -1.0]])
    nn_b2s = torch.tensor([0, 1, 0, 1])
    nn_s2b = torch.tensor([0, 1])
    assert unseen_free_weights(normals, nn_b2s, nn_s2b).tolist() == [1.0, 1.0, 0.0, 0.0]


def test_unseen_body_points_need_a_scan_point_nearby_with_the_hit_test():
    import torch

    from dressmeup.body.registration.terms import body_neighbourhoods, unseen_free_weights

    # five body points in a row, 1 cm apart, all facing +z; the scan's two points both map
    # to body point 0: with a 1.5 cm neighbourhood, points 0 and 1 are seen, 2-4 are not
    rest = np.c_[np.arange(5) * 0.01, np.zeros(5), np.zeros(5)]
    nbrs = body_neighbourhoods(rest, 0.015, most=4)
    assert nbrs.shape == (5, 4)
    for i in range(5):  # brute force: itself and the points within 1.5 cm, padded with 5
        near = set(np.flatnonzero(np.abs(rest[:, 0] - rest[i, 0]) <= 0.015))
        assert set(nbrs[i]) - {5} == near
    normals = torch.tensor([[0, 0, 1.0]] * 5)
    nn_b2s, nn_s2b = torch.zeros(5, dtype=torch.long), torch.tensor([0, 0])
    assert unseen_free_weights(normals, nn_b2s, nn_s2b).tolist() == [1.0] * 5
    assert unseen_free_weights(normals, nn_b2s, nn_s2b, torch.as_tensor(nbrs)).tolist() == [
        1.0, 1.0, 0.0, 0.0, 0.0]


def test_hit_test_acts_in_the_shape_stage_only(model):
    """On a scan without its front, the pose stage's data term is the same with and without
    the hit test (bit for bit: the start's searches and the pose stage need the pull of far
    body points), the shape stage's is lower with it (the freed points carry no cost)."""
    import torch

    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=np.zeros((model.n_joints, 3)))
    scan = synthetic_scan(model, truth, n_points=8000, noise=0.0, seed=3, missing_side=(0, 0, 1))
    terms = {}
    for radius in (None, 0.03):
        problem = _problem(model, scan, unseen_hit_radius=radius)
        problem.set_params(shape=truth.shape, transl=(0.0, 0.0, 0.02))
        for stage in ("pose", "shape"):
            with torch.no_grad():
                terms[radius, stage] = problem.loss(Objective(stage))[1]["data"]
    assert terms[0.03, "pose"] == terms[None, "pose"]
    assert terms[0.03, "shape"] < 0.9 * terms[None, "shape"]


def test_hit_test_frees_the_missing_side_near_the_cut_edge(model):
    """A scan without its front (the surface facing +z), the body at the truth: the facing
    test keeps body points of the missing front pulling (their nearest scan points lie on
    the cut edge, whose normals agree), the hit test frees them and keeps the seen back."""
    import torch

    from dressmeup.body.registration.terms import unseen_free_weights

    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=np.zeros((model.n_joints, 3)))
    scan = synthetic_scan(model, truth, n_points=8000, noise=0.0, seed=3, missing_side=(0, 0, 1))
    weights = {}
    for radius in (None, 0.03):
        problem = _problem(model, scan, unseen_hit_radius=radius)
        problem.set_params(shape=truth.shape)
        with torch.no_grad():
            pairs = Correspondences()
            problem.loss(Objective("pose"), pairs)
            out = model.forward(problem.shape_value()[None], problem.pose[None],
                                problem.transl[None], vertex_ids=problem.body_ids_t)
            Rb = torch.einsum("kj,jab->kab", problem.W_sub, out.transforms[0, :, :3, :3])
            Nb = (Rb @ pairs.rest_normals[..., None])[..., 0].numpy()
            weights[radius] = unseen_free_weights(torch.as_tensor(Nb), pairs.nn_b2s,
                                                  pairs.nn_s2b, problem.neighbourhoods).numpy()
    front, back = Nb[:, 2] > 0.6, Nb[:, 2] < -0.2  # missing (well inside), seen
    assert weights[None][front].mean() > 0.05  # the facing test alone keeps some pulling
    assert weights[0.03][front].mean() < 0.5 * weights[None][front].mean()
    assert weights[0.03][back].mean() > 0.95 * weights[None][back].mean()


def test_auto_route_lets_the_better_start_win(model, monkeypatch):
    # detected keypoints compete with the hypothesis search: right ones may win, keypoints
    # a metre off must lose (detection is replaced so the test needs no mediapipe)
    from dressmeup.body.registration import keypoints as kp
    from dressmeup.body.registration import register

    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=_arm_across_chest(model))
    scan = synthetic_scan(model, truth, n_points=4000, noise=0.002, seed=2)
    tiny = dict(iterations=(5, 5, 5), hypothesis_steps=(5, 5, 10), hypotheses=("a-pose",),
                yaw_candidates=4, hypothesis_yaws=1, hypothesis_keep=1, n_scan_points=1500,
                n_body_points=1000, verbose=False, init_route="auto", limb_search=False,
                shape_search=False)
    monkeypatch.setattr(kp, "keypoints_available", lambda: True)
    for offset, winner in ((0.0, None), (1.0, "hypothesis")):
        joints = model.posed(truth).joints + offset
        monkeypatch.setattr(kp, "detect_keypoints", lambda scan, model, j=joints: kp.ScanKeypoints(
            joints=j, views=8, detections=8))
        res = register(scan, model, return_result=True, **tiny)
        scores = res.info["start_scores"]
        assert set(scores) == {"hypotheses", "keypoints", "kept"}
        best = scores["kept"]
        assert best == min(("hypotheses", "keypoints"), key=scores.get)
        assert res.info["init"].startswith("keypoints" if best == "keypoints" else "hypothesis")
        if winner:
            assert res.info["init"].startswith(winner)


def _scored(entries):
    from dressmeup.body.registration.search import Scored

    return [Scored(str(k), cost, {"k": k}, {"yaw": yaw}) for cost, k, yaw in entries]


def test_kept_yaws_always_keep_the_opposite_of_the_best():
    """A torso alone hardly tells front from back: the candidate that started facing away
    from the best also goes on, whatever its core cost, without duplicates."""
    import math

    from dressmeup.body.registration.init import kept_yaws

    yaws = [2 * math.pi * k / 8 for k in range(8)]
    costs = [5.0, 1.0, 2.0, 3.0, 9.0, 8.0, 7.0, 6.0]  # best: yaw index 1, opposite: 5

    def ranked():
        return _scored(sorted(((c, k, yaws[k]) for k, c in enumerate(costs))))

    assert [c.snapshot["k"] for c in kept_yaws(ranked(), 3)] == [1, 2, 3, 5]
    assert [c.snapshot["k"] for c in kept_yaws(ranked(), 1)] == [1, 5]
    costs[5] = 1.5  # the opposite is already kept: no duplicate
    assert [c.snapshot["k"] for c in kept_yaws(ranked(), 3)] == [1, 5, 2]


def test_refined_hypotheses_add_the_best_one_facing_away_only_when_missing():
    """When the kept best all face within 90 degrees of the best, the best rigid hypothesis
    facing further away is refined too (last); yaws wrap at 360."""
    from dressmeup.body.registration.init import refined_hypotheses

    rigid = _scored([(0.10, 1, 175.0), (0.11, 2, 175.0), (0.12, 3, 250.0), (0.13, 4, 5.0),
                     (0.14, 5, -4.0)])
    assert [h.snapshot["k"] for h in refined_hypotheses(rigid, 3)] == [1, 2, 3, 4]  # 250 is
    # 75 degrees from 175: not "away"
    rigid[2].info["yaw"] = 270.0  # 95 degrees away: already among the kept
    assert [h.snapshot["k"] for h in refined_hypotheses(rigid, 3)] == [1, 2, 3]
    wrapped = _scored([(0.1, 1, 350.0), (0.2, 2, -10.0), (0.3, 3, 200.0)])
    assert [h.snapshot["k"] for h in refined_hypotheses(wrapped, 2)] == [1, 2, 3]
    assert [h.snapshot["k"] for h in refined_hypotheses(wrapped[:2], 1)] == [1]


def test_yaw_search_ranks_the_yaws_from_one_start_and_keeps_the_best(model):
    """Every yaw candidate starts from the same parameters (only the root turned), the
    ranking is by the core data cost of its last step, and the best stays in the problem:
    on a scan of a body facing +x (yaw 90 degrees), the 90-degree start wins."""
    import math

    from dressmeup.body.registration.hypotheses import canonical_pose
    from dressmeup.body.registration.init import place_on_scan, yaw_search

    rest = model.posed(model.default_params()).joints
    pose = canonical_pose("a-pose", model.joint_names, rest)
    pose[0] = (0.0, math.pi / 2, 0.0)
    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=pose)
    problem = _problem(model, synthetic_scan(model, truth, n_points=3000, noise=0.0, seed=3))
    problem.set_params(pose=canonical_pose("a-pose", model.joint_names, rest))
    place_on_scan(problem, True)
    start = problem.snapshot()
    ranked = yaw_search(problem, Objective("pose"), 4, RATES)
    assert [c.info["yaw"] for c in ranked][0] == pytest.approx(math.pi / 2)
    assert sorted(c.score for c in ranked) == [c.score for c in ranked]
    assert all(np.array_equal(c.snapshot["shape_z"], start["shape_z"]) for c in ranked)
    assert np.array_equal(problem.pose.detach().numpy(), ranked[0].snapshot["pose"].numpy())


def test_deep_bend_tilts_the_root_and_the_search_keeps_its_heading():
    """``deep-bend``: the whole body tilted 60 degrees forward (row 0 of the pose), the
    thighs near vertical and the torso about horizontal in the world, arms hanging; the
    hypothesis search turns that tilt to the yaw search's heading (tilt first, then yaw)."""
    from scipy.spatial.transform import Rotation

    from dressmeup.body.registration.hypotheses import canonical_pose
    from dressmeup.body.registration.init import compose_root

    def unit(v):
        return v / np.linalg.norm(v)

    for model in (get_body_model("procedural"), get_body_model("anny")):
        names = list(model.joint_names)
        params = model.default_params()
        pose = canonical_pose("deep-bend", names, model.posed(params).joints)
        assert np.allclose(pose[0], (np.deg2rad(60), 0, 0))
        params.pose = pose
        J = model.posed(params).joints

        def bone(a, b, J=J, names=names):
            return unit(J[names.index(b)] - J[names.index(a)])

        assert bone("spine1", "neck") @ (0, 0, 1) > 0.95, model.name  # torso ahead
        for side in ("left", "right"):
            assert bone(f"{side}_hip", f"{side}_knee") @ (0, -1, 0) > 0.95, model.name
            assert bone(f"{side}_shoulder", f"{side}_elbow") @ (0, -1, 0) > 0.95, model.name
        for name in ("a-pose", "sitting", "bending"):  # the others stay upright
            assert not canonical_pose(name, names, model.posed(params).joints)[0].any()
    heading = np.array([0.0, np.pi / 2, 0.0])  # facing +x
    root = Rotation.from_rotvec(compose_root(heading, np.array([np.deg2rad(60), 0, 0])))
    up = np.array([0.0, 1.0, 0.0])
    assert np.allclose(root.apply(up), (np.sin(np.deg2rad(60)), 0.5, 0.0), atol=1e-9)


@pytest.mark.parametrize("kept", [False, True])
def test_a_limb_search_runs_its_then_stage_only_after_a_move(model, kept):
    """The final limb search's shape stage (``then``) runs exactly when the search kept a
    move: on a scan with the right arm folded, from a start with it hanging (kept), and
    from the true pose (nothing to move); its losses are reported as ``final_``."""
    from dressmeup.body.registration.hypotheses import canonical_pose
    from dressmeup.body.registration.plan import Plan, Shape
    from dressmeup.body.registration.runner import run_plan

    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=_arm_across_chest(model))
    problem = _problem(model, synthetic_scan(model, truth, n_points=6000, noise=0.0, seed=5))
    start = truth.pose.copy()
    if kept:
        a_pose = canonical_pose("a-pose", model.joint_names,
                                model.posed(model.default_params()).joints)
        for j in ("right_shoulder", "right_elbow"):
            start[list(model.joint_names).index(j)] = a_pose[list(model.joint_names).index(j)]
    problem.set_params(shape=truth.shape, pose=start)
    search = LimbSearch(aim="none", knee_bends=(0.0,), elbow_bends=BENDS, pose_steps=5,
                        size=False, far_cloth=True, rates=RATES, record="limbs_final",
                        then=Shape(3, False, RATES))
    state = run_plan(Plan((), (search,)), problem)
    assert state.info["limbs_final"]["limb_kept"] is kept
    assert ("right_shoulder" in state.info["limbs_final"]["limbs_moved"]) is kept
    assert (set(state.losses) == {"final_shape_data", "final_shape_prior", "final_shape_shape"}
            if kept else state.losses == {})


def test_capped_distances_equal_the_capped_full_search():
    """The bounded k-d tree search gives exactly the capped nearest-neighbour distances,
    for points near the tree, far from it and at the cap."""
    from scipy.spatial import cKDTree

    from dressmeup.body.registration.init import capped_distances

    rng = np.random.default_rng(3)
    P = rng.uniform(-0.5, 0.5, (3000, 3))
    X = np.r_[rng.uniform(-0.6, 0.6, (500, 3)), rng.uniform(1.0, 2.0, (200, 3)),
              P[:5] + [0.1, 0.0, 0.0]]
    tree = cKDTree(P)
    full = np.minimum(tree.query(X, k=1)[0], 0.1)
    out = capped_distances(tree, X, 0.1)
    assert np.array_equal(out, full)
    assert (out[500:700] == 0.1).all() and (out[:500] < 0.1).any()


def test_unexplained_groups_find_the_scan_the_body_leaves_out():
    """Scan points more than the gap from the body form groups (largest first); points
    near the body and groups smaller than ``min_points`` are not reported."""
    from dressmeup.body.registration.aim import fibonacci_directions, unexplained_groups

    rng = np.random.default_rng(0)
    body = 0.2 * fibonacci_directions(2000)  # a sphere of radius 0.2 m
    near = 0.22 * fibonacci_directions(500)  # a 2 cm shell: explained
    hand = np.array([0.5, 0.1, 0.0]) + rng.normal(0, 0.01, (60, 3))
    foot = np.array([0.0, -0.6, 0.1]) + rng.normal(0, 0.01, (30, 3))
    speck = np.array([-0.5, 0.0, 0.0]) + rng.normal(0, 0.005, (5, 3))
    groups = unexplained_groups(np.r_[body, near, hand, foot, speck], body)
    assert [len(g) for g in groups] == [60, 30]
    assert np.allclose(groups[0].mean(0), hand.mean(0))
    assert np.allclose(groups[1].mean(0), foot.mean(0))
    assert unexplained_groups(np.r_[body, near], body) == []


def test_aimed_candidates_run_the_bones_through_the_group():
    """Scan points along an arm held ahead and bent: the nearest aimed candidate, posed as
    the limb search poses it (:func:`limb_rotations`), runs its bones within 2 cm of them on
    average and puts the hand within 6 cm of the true one; a group out of reach gives no
    candidate. Checked against a brute-force point-to-segment distance."""
    from scipy.spatial.transform import Rotation

    from dressmeup.body.registration.aim import aimed_candidates, segment_distances
    from dressmeup.body.registration.limbs import limb_rotations

    J_up, J_lo = np.zeros(3), np.array([0.3, 0.0, 0.0])  # an arm held sideways, 30 cm
    W_up = Rotation.from_rotvec([0.1, 0.2, 0.0]).as_matrix()
    W_lo = Rotation.from_rotvec([0.0, 0.1, 0.1]).as_matrix()  # hinge: about -y
    hand = np.array([0.55, 0.01, 0.0])
    hinge = (0.0, -1.0, 0.0)
    c_up = (J_lo - J_up) / 0.3
    # the truth: upper arm ahead and a little up, forearm bent 60 degrees
    d_true = np.array([0.2, 0.3, 0.9]) / np.linalg.norm([0.2, 0.3, 0.9])
    R_up, R_lo = limb_rotations(c_up, W_up, d_true, 0.7, np.radians(60), hinge)
    elbow = J_up + 0.3 * d_true
    tip = elbow + R_lo.apply(W_lo.T @ (hand - J_lo))
    s = np.linspace(0, 1, 40)[:, None]
    rng = np.random.default_rng(1)
    arm = np.r_[s * elbow, elbow + s * (tip - elbow)] + rng.normal(0, 0.01, (80, 3))
    out = aimed_candidates(W_up, W_lo, J_up, J_lo, hand, hinge, [arm])
    assert len(out) == 60
    d, twist, bend = out[0]
    R_up, R_lo = limb_rotations(c_up, W_up, d, twist, bend, hinge)
    e = J_up + 0.3 * R_up.apply(W_up.T @ c_up)
    t = e + R_lo.apply(W_lo.T @ (hand - J_lo))
    dist = np.minimum(segment_distances(arm, J_up, e[None]),
                      segment_distances(arm, e[None], t[None]))
    assert dist.mean() < 0.02 and np.linalg.norm(t - tip) < 0.06
    u = np.linspace(0, 1, 20001)[:, None]
    for a_, b_ in ((J_up, e), (e, t)):  # the fast distance equals a brute-force one
        brute = [np.linalg.norm(q - a_ - u * (b_ - a_), axis=1).min() for q in arm[:5]]
        assert np.allclose(segment_distances(arm[:5], a_, b_[None])[0], brute, atol=1e-5)
    assert aimed_candidates(W_up, W_lo, J_up, J_lo, hand, hinge, [arm + 2.0]) == []


def _search_from(model, truth, start, joint: str, aims, seed: int):
    """One limb search (no pose steps) per ``aims`` entry from pose ``start`` on a scan of
    ``truth``, with the cube grid replaced by each limb's current direction; returns the
    distance (m) of ``joint`` to its true position and the search's info, per aim."""
    from dressmeup.body.registration import limbs

    scan = synthetic_scan(model, truth, n_points=8000, noise=0.002, seed=seed)
    j = list(model.joint_names).index(joint)
    true_joint = model.posed(truth).joints[j]
    errors, infos = {}, {}
    for aim in aims:
        problem = _problem(model, scan)
        problem.set_params(shape=truth.shape, pose=start, transl=truth.transl)
        infos[aim] = limbs.limb_search(problem, _search(aim), Objective("pose"),
                                       grid=lambda c_up: [(c_up, 0.0, 0.0)])
        errors[aim] = float(np.linalg.norm(
            model.posed(problem.body_params()).joints[j] - true_joint))
    return errors, infos


def test_aimed_limb_search_finds_an_outstretched_arm(model):
    """An arm held out ahead, from a start with it hanging. The cube grid is replaced by
    the hanging arm alone (on real scans the right configuration's basin can be narrower
    than the grid's spacing): without aim the arm stays lost; aimed at the unexplained
    scan, the search's candidate alone (no pose steps) brings the wrist within 4 cm."""
    from dressmeup.body.registration.hypotheses import align_directions, canonical_pose

    names = list(model.joint_names)
    rest = model.posed(model.default_params()).joints
    a_pose = canonical_pose("a-pose", names, rest)
    pose = a_pose.copy()
    s, e = names.index("left_shoulder"), names.index("left_elbow")
    pose[s] = align_directions(rest[e] - rest[s], np.array([0.55, 0.2, 0.8]))
    pose[e] = (0.0, -np.deg2rad(35), 0.0)
    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=pose, transl=[0.1, 0.0, 0.2])
    errors, infos = _search_from(model, truth, a_pose, "left_wrist", ("none", "arms"), 4)
    assert errors["none"] > 0.3, errors  # the one grid candidate leaves the arm down
    assert errors["arms"] < 0.04 and "left_shoulder" in infos["arms"]["limbs_moved"], errors


def test_aimed_limb_search_finds_a_raised_knee(model):
    """One thigh raised ahead with the shin hanging from the knee (a step up), from a start
    standing on both legs. With the cube grid replaced by the standing leg alone, aiming
    only the arms leaves the leg down (42 cm off); aiming the legs too (``"all"``) brings
    the ankle within 8 cm by the search's candidate alone (no pose steps; 5.6 cm here: the
    grid's angular steps at the end of a 45 cm shin)."""
    from dressmeup.body.registration.hypotheses import align_directions, canonical_pose

    names = list(model.joint_names)
    rest = model.posed(model.default_params()).joints
    a_pose = canonical_pose("a-pose", names, rest)
    pose = a_pose.copy()
    h, k = names.index("left_hip"), names.index("left_knee")
    pose[h] = align_directions(rest[k] - rest[h], np.array([0.1, -0.4, 0.9]))
    pose[k] = (np.deg2rad(80), 0.0, 0.0)
    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=pose, transl=[0.1, 0.0, 0.2])
    errors, infos = _search_from(model, truth, a_pose, "left_ankle", ("arms", "all"), 5)
    assert errors["arms"] > 0.3, errors  # the one grid candidate leaves the leg down
    assert errors["all"] < 0.08 and "left_hip" in infos["all"]["limbs_moved"], errors
