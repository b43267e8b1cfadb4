"""A fit as data: the stages it runs, in order, each with its settings.

:func:`build_plan` turns a configuration (:mod:`.config`) and the way a fit starts into a
:class:`Plan`; the registrar runs it stage by stage (:mod:`.runner`). For the default
configuration and a scan with nothing else given, the plan reads::

    HypothesisSearch   canonical poses x yaws, ranked by the symmetric score
    LimbSearch         each arm and leg tried along a grid, kept when the body fits better
    Rigid              root and translation on the torso, hips and head
    BestOf (shape objective)
      pull: Pose (far cloth pulling), LimbSearch (aimed), Shape (size handed over first)
      free: Pose (far-cloth rule on), LimbSearch (aimed), Shape (size handed over first)
    LimbSearch         from the finished body; a kept move runs Shape again
    ShapeSearch        stature-matched phenotype starts, the lowest shape objective kept

A plan is frozen data: print it, compare it, or build one of your own from these classes
and pass it to :meth:`~dressmeup.body.registration.optimizer.OptimizationRegistrar.fit`
(``plan=``) to try another sequence (``benchmarks/`` does so for experiments).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dressmeup.body.registration.config import RegistrationConfig


@dataclass(frozen=True)
class Rates:
    """Adam learning rates: pose (axis-angle, rad), translation (m), shape (model units)."""

    pose: float
    transl: float
    shape: float


@dataclass(frozen=True)
class GivenStart:
    """Start from the parameters passed as ``init`` (missing shape values: the average)."""


@dataclass(frozen=True)
class RestStart:
    """The rest pose placed on the scan at its size, then ``yaw_steps`` rigid steps on the
    core joints at each of 4 yaws; the best yaw goes on (no steps: placed only)."""

    yaw_steps: int
    rates: Rates


@dataclass(frozen=True)
class HypothesisSearch:
    """The multi-hypothesis start (:func:`.init.hypothesis_search`): ``yaw_candidates``
    yaws on the core joints (``steps[0]`` rigid steps each); the ``yaws_kept`` best (and
    the one opposite the best) x ``hypotheses`` get ``steps[1]`` rigid steps on the whole
    body; the ``keep`` best (and the best facing away when they all face one way) get a
    ``steps[2]``-step pose stage; the lowest symmetric score goes on."""

    hypotheses: tuple[str, ...]
    yaw_candidates: int
    yaws_kept: int
    keep: int
    steps: tuple[int, int, int]
    rates: Rates


@dataclass(frozen=True)
class KeypointStart:
    """The canonical pose that best fits the keypoints (closed-form similarity) placed on
    them, then a ``pose_steps`` pose stage on keypoints and scan together."""

    hypotheses: tuple[str, ...]
    pose_steps: int
    rates: Rates


@dataclass(frozen=True)
class Rigid:
    """``steps`` Adam steps of the root rotation and translation on the core joints."""

    steps: int
    rates: Rates


@dataclass(frozen=True)
class Pose:
    """``steps`` Adam steps of every joint, the translation, the shape (half rate) and,
    with ``size``, the temporary uniform scale; the distal joints are held for the first
    third. ``far_cloth``: the data term's far-cloth rule on."""

    steps: int
    far_cloth: bool
    size: bool
    rates: Rates


@dataclass(frozen=True)
class Shape:
    """With ``handover``, the temporary scale handed over to the shape (the unscaled rest
    body fitted to the scaled one); then ``steps`` Adam steps of shape, pose (half rate) and
    translation (half rate), the far-cloth rule on, any scale left pulled back to 1."""

    steps: int
    handover: bool
    rates: Rates


@dataclass(frozen=True)
class LimbSearch:
    """The limb-wise search (:func:`.limbs.limb_search`): for each arm and leg, upper-limb
    directions x twists x hinge bends (``elbow_bends``, ``knee_bends``; degrees) and, per
    ``aim``, configurations aimed at the unexplained scan; a moved body settles in a
    ``pose_steps`` pose stage (with ``size``: the temporary scale too; ``far_cloth``: the
    rule on) and stays if its symmetric score is lower. ``record``: the key of ``info``
    the search reports under (None: merged into ``info``). ``then``: a stage run when the
    search kept a move."""

    aim: str
    knee_bends: tuple[float, ...]
    elbow_bends: tuple[float, ...]
    pose_steps: int
    size: bool
    far_cloth: bool
    rates: Rates
    record: str | None = None
    then: Shape | None = None


@dataclass(frozen=True)
class ShapeSearch:
    """The final shape search (:func:`.shapes.shape_search`): each gender's best build at
    the fitted stature, placed in the fitted pose, gets a ``pose_steps`` pose stage and
    ``shape``; the lowest shape objective (the fitted body included) stays."""

    pose_steps: int
    shape: Shape
    rates: Rates


@dataclass(frozen=True)
class Branch:
    """A named sequence of stages, one alternative of a :class:`BestOf`. ``keypoints``:
    the keypoint term takes part (False: it is off in this branch and, if the branch wins,
    for the rest of the fit)."""

    name: str
    stages: tuple[Stage, ...]
    keypoints: bool = True


@dataclass(frozen=True)
class BestOf:
    """Every branch from the same parameters; the one whose ``objective`` is lowest goes
    on (:func:`.search.best_of`; equal values: the earlier branch). ``objective``:
    ``"symmetric"`` (the capped distance both ways, :func:`.init.symmetric_score`) or
    ``"shape"`` (the shape stage's objective, far-cloth rule on). Scores are reported in
    ``info[record]``; the kept branch's info and losses become the fit's."""

    objective: str
    branches: tuple[Branch, ...]
    record: str


Stage = (GivenStart | RestStart | HypothesisSearch | KeypointStart | Rigid | Pose | Shape
         | LimbSearch | ShapeSearch | BestOf)


@dataclass(frozen=True)
class Plan:
    """The stages of a fit, in order: ``start`` (where the fit starts, with the keypoint
    term at weight ``keypoints``), then ``stages`` (with it at ``keypoints_after``)."""

    start: tuple[Stage, ...]
    stages: tuple[Stage, ...]
    keypoints: float = 0.0
    keypoints_after: float = 0.0

    def names(self) -> list[str]:
        """The stage classes' names in order (a BestOf as ``BestOf[name: A, B | ...]``)."""
        return [_name(s) for s in self.start + self.stages]


def _name(stage: Stage) -> str:
    if isinstance(stage, BestOf):
        inner = " | ".join(f"{b.name}: " + ", ".join(_name(s) for s in b.stages)
                           for b in stage.branches)
        return f"BestOf[{inner}]"
    return type(stage).__name__


#: how a fit can start (:func:`build_plan`)
STARTS = ("given", "keypoints", "search", "auto")


def build_plan(config: RegistrationConfig, start: str = "search",
               detected: bool = False) -> Plan:
    """The stages a fit with ``config`` runs.

    Parameters
    ----------
    config : a :class:`~dressmeup.body.registration.config.RegistrationConfig`.
    start : ``"given"`` (``init`` passed: no limb or shape search, no size handover), ``"keypoints"`` (at least 4 keypoints, passed or detected),
        ``"search"`` (the multi-hypothesis search, or the rest pose when ``hypotheses`` is
        empty) or ``"auto"`` (detected keypoints compete with the search).
    detected : the keypoints were detected on the scan (their weight drops after the start
        to ``keypoint_refine_weight``).
    """
    if start not in STARTS:
        raise ValueError(f"start: expected one of {', '.join(STARTS)}, got {start!r}")
    sch, st, lim = config.schedule, config.start, config.limbs
    rates = Rates(sch.lr_pose, sch.lr_transl, sch.lr_shape)
    n_global, n_pose, n_shape = sch.iterations
    searched = start != "given"  # the limb and shape searches, the size handover
    hypotheses = st.hypotheses or ("a-pose",)
    search: tuple[Stage, ...] = (RestStart(max(n_global // 2, 5) if n_global > 0 else 0, rates),)
    if st.hypotheses:
        search = (HypothesisSearch(st.hypotheses, st.yaw_candidates, st.hypothesis_yaws,
                                   st.hypothesis_keep, st.hypothesis_steps, rates),)
        if lim.limb_search:
            search += (_limbs(config, rates, aim="none", knees=lim.limb_first_knee_bends,
                              size=True, far_cloth=False, record=None),)
    keypoint_start = KeypointStart(hypotheses, st.hypothesis_steps[2], rates)
    if start == "given":
        first: tuple[Stage, ...] = (GivenStart(),)
    elif start == "keypoints":
        first = (keypoint_start,)
    elif start == "auto":
        first = (BestOf("symmetric", (Branch("hypotheses", search, keypoints=False),
                                      Branch("keypoints", (keypoint_start,))),
                        "start_scores"),)
    else:
        first = search
    shape = Shape(n_shape, searched, rates)
    branches = []
    rules = (False, True) if config.data.far_cloth != "pull" else (False,)
    for rule in rules:
        steps: tuple[Stage, ...] = (Pose(n_pose, rule, searched, rates),)
        if searched and lim.limb_search and lim.limb_search_after_pose:
            steps += (_limbs(config, rates, aim=lim.limb_aim, size=True, far_cloth=rule,
                             record="limbs_after_pose"),)
        branches.append(Branch(config.data.far_cloth if rule else "pull", steps + (shape,)))
    stages: tuple[Stage, ...] = (Rigid(n_global, rates),)
    stages += (BestOf("shape", tuple(branches), "far_cloth_branches"),) if len(branches) > 1 \
        else branches[0].stages
    if searched and lim.limb_search and lim.limb_search_final:
        stages += (_limbs(config, rates, aim=lim.limb_aim, size=False, far_cloth=True,
                          record="limbs_final", then=Shape(n_shape, False, rates)),)
    if searched and config.shapes.shape_search:
        stages += (ShapeSearch(n_pose // 2, Shape(n_shape, False, rates), rates),)
    weight = config.priors.keypoint_weight
    return Plan(first, stages, keypoints=weight,
                keypoints_after=config.priors.keypoint_refine_weight if detected else weight)


#: knee and elbow bends (degrees) of the limb searches' grid after the first
BENDS = (0.0, 50.0, 100.0, 140.0)


def _limbs(config: RegistrationConfig, rates: Rates, aim: str, size: bool, far_cloth: bool,
           record: str | None, knees: tuple[float, ...] = BENDS,
           then: Shape | None = None) -> LimbSearch:
    return LimbSearch(aim=aim, knee_bends=tuple(float(k) for k in knees), elbow_bends=BENDS,
                      pose_steps=config.start.hypothesis_steps[2], size=size,
                      far_cloth=far_cloth, rates=rates, record=record, then=then)
