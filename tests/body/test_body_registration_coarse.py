"""The coarse point set: subsets of a fit's full points, switched on and off by the plan."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.registration import register
from dressmeup.body.registration.config import get_config
from dressmeup.body.registration.init import symmetric_score
from dressmeup.body.registration.plan import (
    BestOf,
    Branch,
    Plan,
    Points,
    Rates,
    Shape,
    build_plan,
)
from dressmeup.body.registration.problem import FitProblem, Objective
from dressmeup.body.registration.runner import run_plan
from dressmeup.body.registration.terms import CORE_JOINTS, joint_skin_mask
from dressmeup.body.synthetic import named_pose, synthetic_scan
from dressmeup.errors import InputError


@pytest.fixture(scope="module")
def model():
    return get_body_model("procedural")


@pytest.fixture(scope="module")
def truth():
    rng = np.random.default_rng(5)
    return BodyParams("procedural", shape=rng.uniform(0.3, 0.7, 6),
                      pose=named_pose("walking", yaw=0.2), transl=np.array([0.1, 0.0, -0.2]))


def _problem(model, truth, **settings) -> FitProblem:
    P = synthetic_scan(model, truth, n_points=3000, noise=0.002, seed=5)
    config = get_config(n_body_points=1200, coarse_body_points=400, coarse_scan_points=900,
                        **settings)
    return FitProblem.from_config(config, model, P)


def test_coarse_points_are_subsets_of_the_full_points(model, truth):
    p = _problem(model, truth)
    assert p.level == "full"
    full_ids, full_P = p.body_ids.copy(), p.P.copy()
    assert len(full_ids) == 1200 and len(full_P) == 3000
    p.use_points("coarse")
    assert p.level == "coarse"
    assert len(p.body_ids) == 400 and len(p.P) == 900
    # each coarse body point is one of the full body points (a model vertex), once, sorted
    assert np.all(np.isin(p.body_ids, full_ids)) and np.all(np.diff(p.body_ids) > 0)
    # each coarse scan point is one of the full scan points
    rows = {tuple(x) for x in full_P}
    assert all(tuple(x) in rows for x in p.P) and len({tuple(x) for x in p.P}) == 900
    # what depends on the body points follows them
    W = np.asarray(model.skinning_weights)[p.body_ids]
    assert np.allclose(p.W_sub.numpy(), W, atol=1e-7)
    core = np.flatnonzero(joint_skin_mask(model, CORE_JOINTS)[p.body_ids])
    assert np.array_equal(p.core_t.numpy(), core)
    assert p.neighbourhoods.shape[0] == 400 and int(p.neighbourhoods.max()) <= 400
    p.use_points("full")
    assert np.array_equal(p.body_ids, full_ids) and np.array_equal(p.P, full_P)
    with pytest.raises(ValueError, match="level"):
        p.use_points("medium")


def test_the_full_points_do_not_depend_on_the_coarse_sizes(model, truth):
    """The coarse subsets are drawn after the full points: a fit's full points, and so the
    fits of a plan without a coarse stage, are those of a problem without a coarse level."""
    a = _problem(model, truth)
    b = FitProblem.from_config(get_config(n_body_points=1200, coarse_body_points=1000,
                                          coarse_scan_points=100), model, a.P)
    assert np.array_equal(a.body_ids, b.body_ids) and np.array_equal(a.P, b.P)


def test_the_objective_runs_on_the_points_in_use(model, truth):
    """The pairs of a step on the coarse points pair coarse body and scan points only, and
    the data term differs from the full one (sparser points lie farther apart: the coarse
    term is not an unbiased estimate of the full one, which is why the precise stages run
    on the full points)."""
    import torch

    from dressmeup.body.registration.problem import Correspondences

    p = _problem(model, truth)
    p.set_params(shape=truth.shape, pose=truth.pose, transl=truth.transl)
    objective, terms = Objective("pose"), {}
    for level, (n_body, n_scan) in (("full", (1200, 3000)), ("coarse", (400, 900))):
        p.use_points(level)
        pairs = Correspondences()
        with torch.no_grad():
            _, terms[level] = p.loss(objective, pairs)
        assert pairs.nn_b2s.shape == (n_body,) and int(pairs.nn_b2s.max()) < n_scan
        assert pairs.nn_s2b.shape == (n_scan,) and int(pairs.nn_s2b.max()) < n_body
    assert terms["coarse"]["data"] > terms["full"]["data"]
    assert terms["coarse"]["prior"] == terms["full"]["prior"]


@pytest.mark.parametrize("coarse, names", [
    ("none", ["HypothesisSearch", "LimbSearch", "Rigid",
              "BestOf[pull: Pose, LimbSearch, Shape | free: Pose, LimbSearch, Shape]",
              "LimbSearch", "ShapeSearch"]),
    ("start", ["Points(coarse)", "HypothesisSearch", "LimbSearch", "Points(full)", "Rigid",
               "BestOf[pull: Pose, LimbSearch, Shape | free: Pose, LimbSearch, Shape]",
               "LimbSearch", "ShapeSearch"]),
    ("pose", ["Points(coarse)", "HypothesisSearch", "LimbSearch", "Rigid",
              "BestOf[pull: Pose, LimbSearch, Points(full), Shape | "
              "free: Pose, LimbSearch, Points(full), Shape]", "LimbSearch", "ShapeSearch"]),
    ("all", ["Points(coarse)", "HypothesisSearch", "LimbSearch", "Rigid",
             "BestOf[pull: Pose, LimbSearch, Shape | free: Pose, LimbSearch, Shape]",
             "LimbSearch", "ShapeSearch", "Points(full)", "Shape"]),
])
def test_the_plan_names_where_the_coarse_points_are_used(coarse, names):
    plan = build_plan(get_config(coarse=coarse, refine_steps=40))
    assert plan.names() == names
    if coarse == "all":
        assert plan.stages[-1] == Shape(40, handover=False, rates=Rates(0.015, 0.01, 0.05))
    given = build_plan(get_config(coarse=coarse), "given").names()
    assert given[0] == ("GivenStart" if coarse == "none" else "Points(coarse)")


def test_coarse_settings_are_checked():
    for bad in ({"coarse": "half"}, {"coarse_body_points": 0}, {"coarse_scan_points": 2.5},
                {"refine_steps": -1}):
        with pytest.raises(InputError, match=next(iter(bad))):
            get_config(**bad)


def test_best_of_branches_start_on_the_same_points_and_the_winner_keeps_its_own(model, truth):
    """A branch that switches to the full points does not leave the next branch on them;
    the problem ends on the point set of the branch that won."""
    p = _problem(model, truth)
    p.set_params(shape=truth.shape, pose=truth.pose, transl=truth.transl + 0.03)
    scores = {}
    for level in ("full", "coarse"):
        p.use_points(level)
        scores[level] = round(symmetric_score(p), 5)
    assert scores["full"] != scores["coarse"]
    plan = Plan(start=(Points("coarse"),),
                stages=(BestOf("symmetric", (Branch("to full", (Points("full"),)),
                                             Branch("stay", ())), "levels"),))
    state = run_plan(plan, p)
    assert state.info["levels"]["to full"] == scores["full"]
    assert state.info["levels"]["stay"] == scores["coarse"]  # started on the coarse points
    won = state.info["levels"]["kept"]
    assert p.level == ("full" if won == "to full" else "coarse")


def test_a_fit_on_coarse_points_ends_on_the_full_points(model, truth):
    scan = synthetic_scan(model, truth, n_points=3000, noise=0.002, seed=6)
    res = register(scan, model, return_result=True, verbose=False, coarse="all",
                   refine_steps=3, iterations=(3, 3, 3), hypothesis_steps=(2, 2, 2),
                   yaw_candidates=2, hypotheses=("a-pose",), n_scan_points=1500,
                   n_body_points=800, coarse_scan_points=500, coarse_body_points=300,
                   shape_search=False, limb_search=False)
    assert np.isfinite(res.params.pose).all() and res.params.scale == 1.0
    assert "shape_data" in res.losses


@pytest.mark.parametrize("coarse", ["start", "pose"])
def test_a_coarse_set_as_large_as_the_full_one_gives_the_same_fit(model, truth, coarse):
    """Switching point sets changes nothing but the points: with coarse sizes equal to the
    full ones, a plan with ``Points`` stages fits exactly as the plan without them."""
    scan = synthetic_scan(model, truth, n_points=3000, noise=0.002, seed=7)
    small = dict(iterations=(4, 6, 6), hypothesis_steps=(2, 2, 3), yaw_candidates=2,
                 hypotheses=("a-pose", "t-pose"), hypothesis_keep=1, hypothesis_yaws=1,
                 n_scan_points=1200, n_body_points=700, verbose=False)
    plain = register(scan, model, coarse="none", **small)
    same = register(scan, model, coarse=coarse, coarse_scan_points=1200,
                    coarse_body_points=700, **small)
    for key in ("shape", "pose", "transl"):
        assert np.array_equal(getattr(plain, key), getattr(same, key)), key
