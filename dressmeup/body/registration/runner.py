"""Running a plan: each stage of :mod:`.plan` on a fit's
:class:`~dressmeup.body.registration.problem.FitProblem`, in order.

Every stage hands the problem the objective it minimises or compares by explicitly
(:class:`~dressmeup.body.registration.problem.Objective`): the far-cloth rule as the stage
says, the keypoint term at the plan's weight for the start or for the stages after it (off
after a start without keypoints won against one with them).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.body.registration.init import (
    hypothesis_search,
    keypoint_start,
    place_on_scan,
    symmetric_score,
    yaw_search,
)
from dressmeup.body.registration.limbs import limb_search
from dressmeup.body.registration.plan import (
    BestOf,
    GivenStart,
    HypothesisSearch,
    KeypointStart,
    LimbSearch,
    Plan,
    Pose,
    RestStart,
    Rigid,
    Shape,
    ShapeSearch,
    Stage,
)
from dressmeup.body.registration.problem import FitProblem, Objective
from dressmeup.body.registration.search import Candidate, best_of
from dressmeup.body.registration.shapes import shape_search
from dressmeup.body.registration.stages import pose_stage, rigid_stage, shape_stage


@dataclass
class FitState:
    """What the stages of one fit share: the problem, the keypoint weight in force, the
    given start (``init``), and what the stages report (``info``, ``losses``)."""

    problem: FitProblem
    keypoints: float
    init: BodyParams | None = None
    verbose: bool = False
    info: dict = field(default_factory=dict)
    losses: dict = field(default_factory=dict)


def run_plan(plan: Plan, problem: FitProblem, init: BodyParams | None = None,
             keypoints: bool = True, verbose: bool = False) -> FitState:
    """Run ``plan`` on ``problem`` (``init``: the parameters a :class:`.plan.GivenStart`
    starts from; ``keypoints``: the keypoint term takes part). Returns the fit's state: the
    problem holds the result, ``info`` and ``losses`` what the stages reported."""
    state = FitState(problem, plan.keypoints if keypoints else 0.0, init, verbose)
    run_stages(plan.start, state)
    if state.keypoints > 0:
        state.keypoints = plan.keypoints_after
    run_stages(plan.stages, state)
    return state


def run_stages(stages: tuple[Stage, ...], state: FitState) -> None:
    """Run ``stages`` in order on ``state``."""
    for stage in stages:
        RUNNERS[type(stage)](stage, state)


def _given(stage: GivenStart, state: FitState) -> None:
    init, p = state.init, state.problem
    if init is None:
        raise ValueError("GivenStart: the fit was given no init parameters")
    init.check_model(p.model)
    p.set_params(shape=np.r_[init.shape, p.default_shape[init.shape.size:]], pose=init.pose,
                 transl=init.transl, scale=init.scale)
    state.info["init"] = "given"


def _start_objective(state: FitState) -> Objective:
    return Objective("pose", keypoints=state.keypoints)


def _rest(stage: RestStart, state: FitState) -> None:
    p = state.problem
    p.set_params(shape=p.default_shape)
    place_on_scan(p, size_init=p.kp is None)
    if stage.yaw_steps > 0:
        yaw_search(p, _start_objective(state), stage.yaw_steps, stage.rates,
                   verbose=state.verbose)
    state.info["init"] = "rest pose + yaw search" if stage.yaw_steps > 0 else "rest pose"


def _hypotheses(stage: HypothesisSearch, state: FitState) -> None:
    p = state.problem
    p.set_params(shape=p.default_shape)
    state.info.update(hypothesis_search(p, stage, _start_objective(state), state.verbose))


def _keypoints(stage: KeypointStart, state: FitState) -> None:
    p = state.problem
    p.set_params(shape=p.default_shape)
    state.info.update(keypoint_start(p, stage, _start_objective(state), state.verbose))


def _limbs(stage: LimbSearch, state: FitState) -> None:
    objective = Objective("pose", far_cloth=stage.far_cloth, keypoints=state.keypoints)
    found = limb_search(state.problem, stage, objective, state.verbose)
    if stage.record is None:
        state.info.update(found)
    else:
        state.info[stage.record] = found
    if stage.then is not None and found["limb_kept"]:
        sub = FitState(state.problem, state.keypoints, state.init, state.verbose)
        run_stages((stage.then,), sub)
        state.losses.update({f"final_{k}": x for k, x in sub.losses.items()})


def _rigid(stage: Rigid, state: FitState) -> None:
    terms = rigid_stage(state.problem, stage, state.keypoints, state.verbose)
    state.losses.update({f"global_{k}": x for k, x in terms.items()})


def _pose(stage: Pose, state: FitState) -> None:
    terms = pose_stage(state.problem, stage, state.keypoints, state.verbose)
    state.losses.update({f"pose_{k}": x for k, x in terms.items()})


def _shape(stage: Shape, state: FitState) -> None:
    state.losses.update(shape_stage(state.problem, stage, state.keypoints, state.verbose))


def _shape_search(stage: ShapeSearch, state: FitState) -> None:
    info, losses = shape_search(state.problem, stage, state.keypoints, state.verbose)
    if info:
        state.info["shape_search"] = info
    state.losses.update(losses)


def _best_of(stage: BestOf, state: FitState) -> None:
    """Each branch on a state of its own from the same parameters; the winner's info,
    losses and keypoint use become the fit's; the scores go to ``info[stage.record]``."""
    p = state.problem

    def branch(b) -> Candidate:
        def run(problem) -> dict:
            sub = FitState(problem, state.keypoints if b.keypoints else 0.0, state.init,
                           state.verbose)
            run_stages(b.stages, sub)
            return {"state": sub}
        return Candidate(b.name, run)

    shape = Objective("shape", far_cloth=True, keypoints=state.keypoints)
    objectives: dict[str, Callable] = {
        "symmetric": lambda problem, _: symmetric_score(problem),
        "shape": lambda problem, _: problem.objective(shape)}
    if stage.objective not in objectives:
        raise ValueError(f"BestOf.objective: expected one of {sorted(objectives)}, got "
                         f"{stage.objective!r}")
    ranked = best_of(p, [branch(b) for b in stage.branches], objectives[stage.objective],
                     start=p.snapshot())
    won = ranked[0].info["state"]
    state.info.update(won.info)
    state.losses.update(won.losses)
    state.keypoints = won.keypoints
    digits = 5 if stage.objective == "symmetric" else 4
    scores = {c.name: round(c.score, digits) for c in
              sorted(ranked, key=lambda c: [b.name for b in stage.branches].index(c.name))}
    state.info[stage.record] = {**scores, "kept": ranked[0].name}


#: the function that runs each kind of stage
RUNNERS: dict[type, Callable] = {
    GivenStart: _given, RestStart: _rest, HypothesisSearch: _hypotheses,
    KeypointStart: _keypoints, LimbSearch: _limbs, Rigid: _rigid, Pose: _pose, Shape: _shape,
    ShapeSearch: _shape_search, BestOf: _best_of,
}
