"""The registrar as data: presets, validated settings, and the plan of stages each builds."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body.registration import OptimizationRegistrar, register
from dressmeup.body.registration.config import (
    DataTerm,
    describe,
    get_config,
)
from dressmeup.body.registration.hypotheses import DEFAULT_HYPOTHESES
from dressmeup.body.registration.plan import (
    BENDS,
    BestOf,
    Branch,
    GivenStart,
    HypothesisSearch,
    KeypointStart,
    LimbSearch,
    Plan,
    Pose,
    Rates,
    RestStart,
    Rigid,
    Shape,
    ShapeSearch,
    build_plan,
)
from dressmeup.body.registration.search import Candidate, best_of
from dressmeup.errors import InputError

RATES = Rates(0.015, 0.01, 0.05)


def _default_search_plan(steps=(60, 160, 160), hyp_steps=(20, 15, 40), yaws=8, kept=3,
                         keep=3) -> Plan:
    """The default plan for a scan with nothing else given, written out stage by stage."""
    n_global, n_pose, n_shape = steps

    def limbs(far_cloth: bool, record: str) -> LimbSearch:
        return LimbSearch(aim="all", knee_bends=BENDS, elbow_bends=BENDS,
                          pose_steps=hyp_steps[2], size=True, far_cloth=far_cloth, rates=RATES,
                          record=record)

    shape = Shape(n_shape, handover=True, rates=RATES)
    return Plan(
        start=(HypothesisSearch(DEFAULT_HYPOTHESES, yaw_candidates=yaws, yaws_kept=kept,
                                keep=keep, steps=hyp_steps, rates=RATES),
               LimbSearch(aim="none", knee_bends=(0.0, 50.0, 100.0), elbow_bends=BENDS,
                          pose_steps=hyp_steps[2], size=True, far_cloth=False, rates=RATES)),
        stages=(Rigid(n_global, RATES),
                BestOf("shape", (
                    Branch("pull", (Pose(n_pose, far_cloth=False, size=True, rates=RATES),
                                    limbs(False, "limbs_after_pose"), shape)),
                    Branch("free", (Pose(n_pose, far_cloth=True, size=True, rates=RATES),
                                    limbs(True, "limbs_after_pose"), shape))),
                    record="far_cloth_branches"),
                LimbSearch(aim="all", knee_bends=BENDS, elbow_bends=BENDS,
                           pose_steps=hyp_steps[2], size=False, far_cloth=True, rates=RATES,
                           record="limbs_final", then=Shape(n_shape, False, RATES)),
                ShapeSearch(n_pose // 2, Shape(n_shape, False, RATES), RATES)),
        keypoints=1.0, keypoints_after=1.0)


def test_default_plan_lists_every_stage_with_its_settings():
    plan = build_plan(get_config())
    assert plan == _default_search_plan()
    assert plan.names() == [
        "HypothesisSearch", "LimbSearch", "Rigid",
        "BestOf[pull: Pose, LimbSearch, Shape | free: Pose, LimbSearch, Shape]",
        "LimbSearch", "ShapeSearch"]


@pytest.mark.parametrize("preset", ["default", "naked", "clothed"])
def test_presets_for_scan_kinds_share_the_default_plan(preset):
    """naked and clothed change the data term only."""
    config = get_config(preset)
    assert build_plan(config) == _default_search_plan()
    assert set(describe(config)) <= {"inside_weight", "sigma_in"}
    assert describe(get_config("naked")) == {"inside_weight": 1.0, "sigma_in": 0.15}
    assert describe(get_config("clothed")) == {"inside_weight": 0.2}


def test_fast_preset_runs_the_same_stages_with_fewer_steps_and_points():
    config = get_config("fast")
    assert build_plan(config) == _default_search_plan(steps=(30, 120, 120),
                                                      hyp_steps=(10, 8, 20), yaws=4, kept=2,
                                                      keep=2)
    assert (config.data.n_scan_points, config.data.n_body_points) == (2500, 1500)


def test_plan_of_a_fit_from_given_parameters_leaves_the_searches_out():
    """``init``: no start search, no limb or shape search, no size to hand over; the two
    far-cloth branches stay (they do not need a search)."""
    shape = Shape(160, handover=False, rates=RATES)
    assert build_plan(get_config(), "given") == Plan(
        start=(GivenStart(),),
        stages=(Rigid(60, RATES),
                BestOf("shape", (Branch("pull", (Pose(160, False, False, RATES), shape)),
                                 Branch("free", (Pose(160, True, False, RATES), shape))),
                       "far_cloth_branches")),
        keypoints=1.0, keypoints_after=1.0)


def test_plan_of_keypoint_starts():
    """Keypoints start the fit (the searches after the start stay); detected ones weigh
    ``keypoint_refine_weight`` after the start; ``auto`` lets the hypothesis search (without
    the keypoint term) and the keypoint start compete by the symmetric score."""
    default = _default_search_plan()
    kp_start = KeypointStart(DEFAULT_HYPOTHESES, pose_steps=40, rates=RATES)
    given = build_plan(get_config(), "keypoints")
    assert given.start == (kp_start,) and given.stages == default.stages
    assert (given.keypoints, given.keypoints_after) == (1.0, 1.0)
    detected = build_plan(get_config(keypoint_refine_weight=0.2), "keypoints", detected=True)
    assert (detected.keypoints, detected.keypoints_after) == (1.0, 0.2)
    auto = build_plan(get_config(), "auto", detected=True)
    assert auto.start == (BestOf("symmetric", (Branch("hypotheses", default.start,
                                                      keypoints=False),
                                               Branch("keypoints", (kp_start,))),
                                 "start_scores"),)
    assert auto.stages == default.stages
    # without hypotheses the keypoint start tries the A-pose
    assert build_plan(get_config(hypotheses=()), "keypoints").start[0].hypotheses == ("a-pose",)


def test_settings_add_and_remove_stages():
    def names(**settings):
        return build_plan(get_config(**settings)).names()

    assert names(far_cloth="pull") == ["HypothesisSearch", "LimbSearch", "Rigid", "Pose",
                                       "LimbSearch", "Shape", "LimbSearch", "ShapeSearch"]
    assert names(limb_search=False) == ["HypothesisSearch", "Rigid", "BestOf[pull: Pose, Shape "
                                        "| free: Pose, Shape]", "ShapeSearch"]
    assert names(limb_search_after_pose=False, limb_search_final=False, shape_search=False) \
        == ["HypothesisSearch", "LimbSearch", "Rigid", "BestOf[pull: Pose, Shape | free: Pose, "
            "Shape]"]
    assert names(hypotheses=()) == ["RestStart", "Rigid", names()[3], "LimbSearch",
                                    "ShapeSearch"]
    rest = build_plan(get_config(hypotheses=(), iterations=(8, 10, 10))).start
    assert rest == (RestStart(yaw_steps=5, rates=RATES),)  # at least 5 steps a yaw
    assert build_plan(get_config(hypotheses=(), iterations=(0, 10, 10))).start[0].yaw_steps == 0
    plan = build_plan(get_config(limb_aim="arms", limb_first_knee_bends=[0, 70],
                                 lr_pose=0.02))
    limbs = [plan.start[1], *plan.stages[1].branches[0].stages[1:2], plan.stages[2]]
    assert [s.aim for s in limbs] == ["none", "arms", "arms"]
    assert [s.knee_bends for s in limbs] == [(0.0, 70.0), BENDS, BENDS]  # the first only
    assert all(s.elbow_bends == BENDS and s.rates.pose == 0.02 for s in limbs)


def test_get_config_validates_overrides():
    config = get_config("naked", seed=3, iterations=[50, 100, 100], hypotheses=["a-pose"])
    assert config.runtime.seed == 3 and config.schedule.iterations == (50, 100, 100)
    assert config.start.hypotheses == ("a-pose",) and config.data.inside_weight == 1.0
    assert get_config(data=DataTerm(cloth_max=0.05)).data.cloth_max == 0.05
    assert get_config(config) is not config and get_config(config) == config
    assert OptimizationRegistrar("fast", seed=2).config == get_config("fast", seed=2)
    with pytest.raises(InputError, match="registration preset: expected one of the presets"):
        get_config("slow")
    with pytest.raises(InputError, match=r"unknown option\(s\) \['colour'\]; known: .*cloth_max"):
        get_config(colour="red")
    for name in ("loose_cloth", "lbfgs_steps", "optimize_scale"):  # retired (CHANGELOG.md)
        with pytest.raises(InputError, match=rf"unknown option\(s\) \['{name}'\]; known: "):
            register(np.zeros((20, 3)), "procedural", **{name: 1})
    with pytest.raises(InputError, match="data: expected a DataTerm"):
        get_config(data={"cloth_max": 0.05})


@pytest.mark.parametrize("setting, bad, message", [
    ("far_cloth", "loose", "far_cloth: expected one of free, pull"),
    ("init_route", "psychic", "init_route: expected one of hypotheses, keypoints, auto"),
    ("limb_aim", "legs", "limb_aim: expected one of none, arms, all"),
    ("limb_aim", True, "limbs.limb_aim: expected a string"),
    ("iterations", (60, 160), "iterations: expected three step counts"),
    ("iterations", (60, -1, 160), "iterations: expected three step counts"),
    ("hypothesis_steps", "20,15,40", "hypothesis_steps: expected three step counts"),
    ("hypotheses", ("a-pose", "moonwalk"), "hypotheses: expected a list of"),
    ("hypotheses", "a-pose", "hypotheses: expected a list of"),
    ("unseen_hit_radius", 1.5, "unseen_hit_radius: expected None or a distance"),
    ("unseen_hit_radius", "0.03", "unseen_hit_radius: expected None or a distance"),
    ("unseen_hit_radius", float("nan"), "unseen_hit_radius: expected None or a distance"),
    ("unseen_hit_radius", True, "unseen_hit_radius: expected None or a distance"),
    ("cloth_max", None, "data.cloth_max: expected a number"),
    ("cloth_max", -0.1, "cloth_max: expected a number >= 0"),
    ("n_scan_points", 0, "n_scan_points: expected a whole number >= 1"),
    ("yaw_candidates", 2.5, "start.yaw_candidates: expected an integer"),
    ("yaw_candidates", 0, "yaw_candidates: expected a whole number >= 1"),
    ("up", "w", "up: expected one of"),
    ("limb_search", 1, "limbs.limb_search: expected true or false"),
    ("num_threads", 0, "num_threads: expected None or a whole number >= 1"),
    ("seed", -1, "seed: expected a whole number >= 0"),
] + [("limb_first_knee_bends", bad, "limb_first_knee_bends: expected a non-empty list")
     for bad in ((), "0,50", 100, (0, -10), (0, 180), (0, float("nan")), (True,), ("50",),
                 {0: 1})])
def test_settings_out_of_range_name_themselves(setting, bad, message):
    with pytest.raises(InputError, match=message):
        get_config(**{setting: bad})


def test_numpy_values_are_settings_too():
    config = get_config(limb_first_knee_bends=np.array([0, 50, 100]),
                        unseen_hit_radius=np.float64(0.03), seed=np.int64(4))
    assert config.limbs.limb_first_knee_bends == (0, 50, 100)
    assert build_plan(config) == _default_search_plan()


class _Counter:
    """A stand-in problem: one number as its parameters."""

    def __init__(self) -> None:
        self.x = 0.0

    def snapshot(self) -> dict:
        return {"x": self.x}

    def restore(self, snap: dict) -> None:
        self.x = snap["x"]


def test_best_of_runs_each_candidate_from_the_start_and_keeps_the_lowest():
    p = _Counter()
    p.x = 10.0
    seen = []

    def move(to: float) -> Candidate:
        def run(q) -> dict:
            seen.append(q.x)  # every candidate starts from the same value
            q.x = to
            return {"to": to}
        return Candidate(f"to {to}", run)

    ranked = best_of(p, [move(3.0), move(-1.0), move(2.0)], lambda q, info: abs(q.x - 1.5),
                     start=p.snapshot())
    assert seen == [10.0, 10.0, 10.0]
    assert [c.name for c in ranked] == ["to 2.0", "to 3.0", "to -1.0"]
    assert [c.score for c in ranked] == [0.5, 1.5, 2.5]
    assert p.x == 2.0 and ranked[0].info == {"to": 2.0} and ranked[0].snapshot == {"x": 2.0}
    # equal scores: the earlier candidate; without a start each candidate goes on from the
    # parameters the previous one left
    ranked = best_of(p, [Candidate("a", lambda q: setattr(q, "x", q.x + 1)),
                         Candidate("b", lambda q: setattr(q, "x", q.x - 2))],
                     lambda q, _: 0.0)
    assert [c.name for c in ranked] == ["a", "b"] and p.x == 3.0
    assert best_of(p, [], lambda q, _: 0.0) == [] and p.x == 3.0
