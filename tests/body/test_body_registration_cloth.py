"""Loose cloth in clothed registration: scan points of a skirt or dress far from the body."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.registration.optimizer import OptimizationRegistrar
from dressmeup.errors import InputError


def test_loose_cloth_mask_needs_a_clear_way_to_the_body():
    from scipy.spatial import cKDTree

    from dressmeup.body.registration.problem import loose_cloth_mask

    rng = np.random.default_rng(0)
    # a sheet of cloth 20 cm over a body at z = 0, and a second sheet 10 cm over it under
    # one corner of the first (as the far side of a scan's limb that holds no body)
    sheet = np.c_[rng.uniform(-0.3, 0.3, (4000, 2)), np.full(4000, 0.2)]
    under = np.c_[rng.uniform(0.05, 0.3, (2000, 2)), np.full(2000, 0.1)]
    P = np.r_[sheet, under]
    B = P * (1, 1, 0)  # each point's nearest body point straight below it
    outside = np.ones(len(P), dtype=bool)
    tree = cKDTree(P)
    loose = loose_cloth_mask(P, B, outside, 0.06, tree)
    clear = (sheet[:, 0] < 0.0) | (sheet[:, 1] < 0.0)  # nothing between sheet and body
    blocked = (sheet[:, 0] > 0.07) & (sheet[:, 1] > 0.07)
    assert loose[:4000][clear].all() and not loose[:4000][blocked].any()
    assert loose[4000:].all()  # 10 cm off, with a clear way down: loose too
    # within cloth_max, or inside the body: never loose
    assert not loose_cloth_mask(P, B, outside, 0.12, tree)[4000:].any()
    assert not loose_cloth_mask(P, B, ~outside, 0.06, tree).any()


@pytest.fixture(scope="module")
def skirt_scan():
    """A procedural body in its rest pose whose hips and thighs are hidden under a wide
    A-line skirt (the skin under it is not in the scan, as in synth-registration-v3)."""
    from dressmeup.body.synthetic import synthetic_scan

    model = get_body_model("procedural")
    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=np.zeros((22, 3)),
                       transl=np.zeros(3))
    body = synthetic_scan(model, truth, n_points=8000, noise=0.001, seed=0)
    under = (body[:, 1] > 0.45) & (body[:, 1] < 0.92) & (np.abs(body[:, 0]) < 0.22)
    rng = np.random.default_rng(1)
    t, a = rng.uniform(0, 1, 4000), rng.uniform(0, 2 * np.pi, 4000)
    radius = 0.16 + 0.34 * t  # 16 cm at the waist to 50 cm at the hem
    skirt = np.c_[radius * np.cos(a), 0.92 - 0.47 * t, radius * np.sin(a)]
    return model, truth, np.r_[body[~under], skirt]


def _leg_poses(model):
    names = list(model.joint_names)
    out = {}
    for name, (flex, spread, knee) in {"truth": (0, 0, 0), "knees forward": (-0.6, 0, 0.8),
                                      "spread": (0, 0.3, 0),
                                      "spread, knees forward": (-0.6, 0.3, 0.8)}.items():
        p = np.zeros((len(names), 3))
        p[names.index("left_hip")] = (flex, 0, spread)
        p[names.index("right_hip")] = (flex, 0, -spread)
        p[names.index("left_knee")] = p[names.index("right_knee")] = (knee, 0, 0)
        out[name] = p
    return out


def _data_terms(model, truth, scan, **options):
    import torch

    from dressmeup.body.registration.problem import FitProblem
    from dressmeup.body.registration.scan import prepare_scan

    opts = OptimizationRegistrar(n_scan_points=6000, n_body_points=3000, verbose=False,
                                 **options)
    problem = FitProblem(opts, model, prepare_scan(scan, opts.n_scan_points, 0), None)
    out = {}
    for name, pose in _leg_poses(model).items():
        problem.set_params(shape=truth.shape, pose=pose, transl=truth.transl)
        problem.reset_correspondences()
        with torch.no_grad():
            out[name] = problem.loss("shape")[1]["data"]
    return out


@pytest.mark.parametrize("rule", ["loose", "free"])
def test_legs_under_a_skirt_are_not_pulled_into_it(skirt_scan, rule):
    model, truth, scan = skirt_scan
    cost = _data_terms(model, truth, scan, far_cloth=rule, far_cloth_from="start")
    assert min(cost, key=cost.get) == "truth", cost
    # without the mechanism, knees bent forward into the skirt's far cloth beat the truth
    # (the dress failures of synth-registration-v3)
    old = _data_terms(model, truth, scan, far_cloth="pull", far_cloth_from="start")
    assert old["knees forward"] < old["truth"], old


def test_far_cloth_rule_applies_from_its_stage(skirt_scan):
    """``far_cloth_from="shape"``: the searches and the pose stage see the pulling rule."""
    model, truth, scan = skirt_scan
    pull = _data_terms(model, truth, scan, far_cloth="pull", far_cloth_from="start")
    later = _data_terms(model, truth, scan, far_cloth="free", far_cloth_from="shape")
    assert later == pull
    with pytest.raises(InputError, match="far_cloth"):
        OptimizationRegistrar(far_cloth="loosen").fit(scan, model)
    from dressmeup.body.registration import register

    with pytest.raises(InputError, match="unknown option.*loose_cloth.*far_cloth='loose'"):
        register(scan, model, loose_cloth=True)  # the session-4 name says what replaced it


@pytest.mark.parametrize("start, expected", [("start", {"hypotheses": True, "pose": True,
                                                        "shape": True}),
                                             ("pose", {"hypotheses": False, "pose": True,
                                                       "shape": True}),
                                             ("shape", {"hypotheses": False, "pose": False,
                                                        "shape": True})])
def test_far_cloth_from_switches_the_rule_on_at_its_stage(skirt_scan, monkeypatch, start,
                                                          expected):
    """The optimizer turns ``far_cloth`` on for the stage ``far_cloth_from`` names and keeps
    it on for every later stage (the searches count as before the pose stage)."""
    import dressmeup.body.registration.optimizer as optimizer
    from dressmeup.body.registration import register

    model, _, scan = skirt_scan
    seen = {}
    real_adam, real_search = optimizer.run_adam, optimizer.hypothesis_search

    def adam(problem, stage, *args, **kwargs):
        if stage != "global":
            seen.setdefault(stage, problem.far_cloth_on)
        return real_adam(problem, stage, *args, **kwargs)

    def search(problem, *args, **kwargs):
        seen["hypotheses"] = problem.far_cloth_on
        return real_search(problem, *args, **kwargs)

    monkeypatch.setattr(optimizer, "run_adam", adam)
    monkeypatch.setattr(optimizer, "hypothesis_search", search)
    register(scan, model, far_cloth="free", far_cloth_from=start, iterations=(5, 5, 5),
             n_scan_points=1000, n_body_points=500, verbose=False, hypotheses=("a-pose",),
             hypothesis_steps=(3, 3, 3), yaw_candidates=2, hypothesis_yaws=1,
             limb_search=False)
    assert seen == expected


def test_far_cloth_branches_keep_the_lower_final_objective(skirt_scan, monkeypatch):
    """``far_cloth_branch``: pose and shape stages run with far cloth pulling in the pose
    stage and then, from the same start, with the rule throughout; both shape stages use the
    rule, and the body where that final objective is lower is the result. Off, or with
    ``far_cloth="pull"``: one pose and one shape stage."""
    import dressmeup.body.registration.optimizer as optimizer
    from dressmeup.body.registration import register
    from dressmeup.body.registration.problem import FitProblem

    model, _, scan = skirt_scan
    calls, starts, ends, finals = [], [], [], []
    real_adam, real_objective = optimizer.run_adam, FitProblem.objective

    def adam(problem, stage, *args, **kwargs):
        if stage == "pose":
            starts.append(problem.posed_numpy())
        calls.append((stage, problem.far_cloth_on))
        out = real_adam(problem, stage, *args, **kwargs)
        if stage == "shape":
            ends.append(problem.posed_numpy())
        return out

    def objective(problem, stage, far_cloth_on=True):
        finals.append((stage, far_cloth_on, real_objective(problem, stage, far_cloth_on)))
        return finals[-1][2]

    monkeypatch.setattr(optimizer, "run_adam", adam)
    monkeypatch.setattr(FitProblem, "objective", objective)
    fast = dict(iterations=(3, 8, 3), n_scan_points=1000, n_body_points=500, verbose=False,
                hypotheses=("a-pose",), hypothesis_steps=(3, 3, 3), yaw_candidates=2,
                hypothesis_yaws=1, limb_search=False, shape_search=False, return_result=True)
    res = register(scan, model, **fast)
    assert calls[1:] == [("pose", False), ("shape", True), ("pose", True), ("shape", True)]
    assert np.allclose(starts[0], starts[1])  # both branches start from the same body
    assert not np.allclose(ends[0], ends[1])
    assert [f[:2] for f in finals] == [("shape", True), ("shape", True)]
    b = res.info["far_cloth_branches"]
    assert [b["pull"], b["free"]] == [round(f[2], 4) for f in finals]
    kept = int(finals[1][2] < finals[0][2])
    assert b["kept"] == ("pull", "free")[kept]
    assert np.allclose(model.posed(res.params).vertices, ends[kept], atol=1e-5)
    for off in ({"far_cloth_branch": False}, {"far_cloth": "pull"}):
        calls.clear()
        res = register(scan, model, **fast, **off)
        assert [c[0] for c in calls[1:]] == ["pose", "shape"]
        assert "far_cloth_branches" not in res.info


def test_objective_is_the_stage_loss_with_fresh_correspondences(skirt_scan):
    """``FitProblem.objective`` equals the loss of a stage's first step, with far cloth as
    asked, and leaves the problem's far-cloth switch and parameters as they were."""
    from dressmeup.body.registration.problem import FitProblem
    from dressmeup.body.registration.scan import prepare_scan

    model, truth, scan = skirt_scan
    opts = OptimizationRegistrar(n_scan_points=1500, n_body_points=800, verbose=False)
    problem = FitProblem(opts, model, prepare_scan(scan, 1500, 0), None)
    problem.set_params(shape=truth.shape, pose=truth.pose, transl=truth.transl)
    problem.far_cloth_on = False
    before = problem.posed_numpy()
    free, pull = problem.objective("shape", True), problem.objective("shape", False)
    assert problem.far_cloth_on is False and np.array_equal(problem.posed_numpy(), before)
    for on, value in ((True, free), (False, pull)):
        problem.far_cloth_on = on
        problem.reset_correspondences()
        loss, _ = problem.loss("shape")
        assert float(loss.detach()) == pytest.approx(value, rel=1e-6)
    assert free < pull  # the skirt's far points cost only under the pull
