"""The ``optimization`` registrar: initialisation, then global, pose and shape stages."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from numbers import Real
from typing import ClassVar

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.body.registration.hypotheses import (
    CANONICAL_POSES,
    DEFAULT_HYPOTHESES,
    UPRIGHT_HYPOTHESES,
)
from dressmeup.body.registration.init import (
    hypothesis_search,
    keypoint_start,
    place_on_scan,
    symmetric_score,
    yaw_search,
)
from dressmeup.body.registration.keypoints import detect_keypoints, keypoints_available
from dressmeup.body.registration.limbs import FIRST_KNEE_BENDS, limb_search
from dressmeup.body.registration.problem import FitProblem
from dressmeup.body.registration.scan import (
    check_upright,
    keypoint_arrays,
    prepare_scan,
    rotate_keypoints,
    rotate_scan,
    up_rotation,
)
from dressmeup.body.registration.shapes import (
    BUILD_GRID,
    DEFAULT_BUILD,
    GENDERS,
    I_BUILD,
    I_GENDER,
    I_HEIGHT,
    stature_matched_shapes,
)
from dressmeup.body.registration.stages import run_adam, run_lbfgs
from dressmeup.body.registration.support import remove_support, scan_without_support
from dressmeup.body.rigid import rotate_params
from dressmeup.errors import InputError

logger = logging.getLogger(__name__)


@dataclass
class RegistrationResult:
    """What a fit returns besides the parameters: per-stage losses, timing (s) and
    ``info`` about the start (``info["init"]``: the chosen start, e.g. ``"hypothesis
    t-pose (yaw 90 deg)"``; the ranked hypotheses; keypoint views found; ``info["support"]``:
    the support surfaces left out of the scan). ``supports``: those surfaces
    (:class:`~dressmeup.body.registration.support.SupportPlane`; empty when none), so
    the scan can be measured without them (``support_mask``)."""

    params: BodyParams
    seconds: float
    losses: dict[str, float] = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    supports: list = field(default_factory=list)


@dataclass
class OptimizationRegistrar:
    """Fit by optimisation (see :mod:`dressmeup.body.registration`). Keyword options.

    Parameters
    ----------
    iterations : steps for the (global, pose, shape) stages.
    shape_in_pose_stage : let the shape move (at half rate) already in the pose stage, so
        limb lengths adapt before the pose settles (avoids tip-toe / bent-leg minima).
    refine_rounds, lbfgs_steps : optional final ICP-like L-BFGS rounds (0: off).
    inside_weight : weight of body-inside-scan residuals (1 for naked scans gives a
        symmetric term; the default 0.5 with the saturating ``sigma_in`` suits clothes too).
    sigma_out, sigma_in : Geman-McClure scales (m) of outside / inside residuals.
    point_weight : weight of the point-to-point term.
    cloth_max : inside gaps (m) beyond which a residual is not clothing and costs again
        (None: inside residuals always saturate, as before).
    far_cloth : how scan points farther than ``cloth_max`` outside the body pull it:
        ``"pull"`` (the excess over ``cloth_max`` costs like an outside residual, so a scan
        limb far from the body's brings it over); ``"loose"``: those with no other scan
        surface between them and the body are loose cloth over it (skirts, dresses) and do
        not pull (:func:`~dressmeup.body.registration.problem.loose_cloth_mask`);
        ``"free"``: none pulls more than one ``cloth_max`` away does (no excess, the
        point-to-point term capped).
    far_cloth_from : the stage from which ``far_cloth`` applies (before it, ``"pull"``):
        ``"start"`` (the whole fit, searches included), ``"pose"`` (after the start),
        ``"shape"`` (the shape stage only, once the pose has settled).
    far_cloth_branch : with ``far_cloth_from="shape"`` and a ``far_cloth`` other than
        ``"pull"``, everything after the global stage (pose stage, second limb search, size
        handover, shape stage) runs twice from the same start, once with far cloth pulling
        in the pose stage and once with ``far_cloth`` throughout; both end in the same shape
        stage, and the body where its objective is lower goes on: the pull brings misplaced
        limbs back, the free rule keeps legs out of a skirt; the final objective tells which
        mattered on this scan (one pose stage, limb search and shape stage more CPU).
    hand_weight : data weight of hand vertices (skinned to the wrists); < 1 keeps the many
        hand vertices from pulling the arm.
    skip_unseen : leave out body -> scan pairs whose scan point lies on a surface of the body
        facing the other way (the scan did not see that part: a missing side, a hole);
        without it such points are pulled through the body onto the far side's scan.
    unseen_hit_radius : a distance (m; default 0.03, about 1.5 times the spacing of the 5,000
        body points, set a priori) or None (off): with ``skip_unseen``, a body point also
        carries no body -> scan cost unless some scan point's nearest body point lies within
        this distance of it (on the rest body), in the shape stage only (once the pose has
        settled: earlier, the pull of far body points is what brings a misplaced limb or
        torso to its scan). The facing test alone keeps the body points of a missing side
        near the scan's cut edge pulling towards that edge (their normals still agree with
        the edge's), which flattens the body on partial scans.
    pose_prior_weight, limit_weight, shape_weight, keypoint_weight : prior weights.
    n_scan_points, n_body_points : points used by the data term.
    correspondence_every : recompute scan-to-body nearest neighbours every this many steps.
    yaw_search : try 4 root yaw angles when no ``init`` is given; each gets
        ``n_global // 2`` rigid steps fitting the torso, hips and head, the best goes on.
    hypotheses : canonical starting poses (:mod:`.hypotheses`) tried when no ``init`` is
        given; empty: start from the rest pose (yaw search only).
    hypothesis_steps : steps (yaw, rigid, pose) of the hypothesis search: each of the
        ``yaw_candidates`` yaws gets the first count on the core joints, each (pose, kept yaw) the second on the
        whole body, the ``hypothesis_keep`` best the third as a short pose stage.
    hypothesis_keep, hypothesis_yaws : hypotheses refined, yaws kept after the yaw search.
    yaw_candidates : yaws tried by the hypothesis search's yaw stage (evenly spaced).
    keep_opposite_yaw : besides the ``hypothesis_yaws`` best, the yaw facing opposite the
        best always goes on (a torso alone hardly tells front from back; see
        :func:`~dressmeup.body.registration.init.kept_yaws`).
    refine_opposite : when the ``hypothesis_keep`` best rigid hypotheses all face within 90
        degrees of the best, also refine the best one facing further away
        (:func:`~dressmeup.body.registration.init.refined_hypotheses`; one short pose stage
        more). On by default since session 17: on the `half-squat-reach` tuning skirt it
        turned a fit facing backwards (327.4 mm) into one facing forward (15.1 mm); on the
        181 other tuning fits screened (sessions 16 and 17) it changed none
        (docs/body-models.md, "Session 17").
    yaw_postures : canonical poses with an untilted root (e.g. ``"a-pose"``, ``"bending"``)
        the hypothesis search's yaw stage runs from, each over all ``yaw_candidates``;
        each start yaw keeps its best core cost
        (:func:`~dressmeup.body.registration.init.best_per_start_yaw`). An upright torso
        ranks the headings of a deeply bent scan almost at random. Default: the A-pose
        alone; adding ``"bending"`` found the heading of two bent dresses on tuning data and
        lost it on a bent top (docs/body-models.md, "Session 17").
    limb_scan_cap : cap (m) of the scan -> body distances in the symmetric score that
        decides both limb searches (:func:`~dressmeup.body.registration.init.symmetric_score`;
        its body -> scan cap, and both caps of the score that ranks the hypotheses, are 0.1).
        With a smaller cap, loose cloth farther from the body than the cap costs the same
        wherever the body is, so a leg folded up into a skirt gains nothing from the cloth
        it nears; 0.03 and 0.05 made the tuning fits worse (docs/body-models.md, "Session
        12"), so the default stays 0.1.
    limb_search : after the hypothesis search, try other directions for each arm and leg
        (:mod:`.limbs`) and keep them if the settled body fits the scan better (the
        pose stage of that check has the hypotheses' pose-step count).
    limb_first_knee_bends : the knee bends (degrees) the first limb search tries for each
        leg direction (its arms, and every limb of the second search, try 0, 50, 100 and
        140). Default 0, 50, 100 (since session 14; the pattern search around the best may
        still bend a knee 30 degrees further): from the hypotheses' rough body a shin
        folded up into a skirt explains cloth and outscored the hanging one (raised-knee
        tuning fits 39.0 -> 23.2 mm, the other 74 tuning fits within 0.6 mm; docs/
        body-models.md, "Session 14").
    limb_search_after_pose : with ``limb_search``, search the limbs once more after the
        pose stage (fits without ``init``): from the settled body a limb the first search
        placed roughly (a thigh raised, its shin folded the wrong way) is found again.
    limb_aim : which limbs the second limb search (``limb_search_after_pose``) also aims
        at the scan the settled body leaves unexplained (a group of scan points more than 5
        cm from the body; see :mod:`.limbs`): ``"none"``, ``"arms"``, ``"all"`` (default
        since session 11). A lost outstretched arm, or the shin of a raised thigh folded
        the wrong way, lies outside the cube grid's reach (raised-knee tuning scans 52.5 ->
        39.0 mm, the other tuning sets within 1.7 mm). Not in the first search: from the
        hypotheses' rough body the unexplained scan is everywhere (aimed there, arms and
        legs moved on a clothed tuning set and a sitting skirt went 22 -> 37 mm).
    limb_search_final : with ``limb_search`` (fits without ``init``), search the limbs a
        last time from the finished body, before the L-BFGS rounds, and run the shape stage
        again when a limb moved. The earlier searches start from rougher bodies, where a
        raised shin folded up under the thigh into a skirt can outscore the hanging one;
        from the finished body the rigid score sees the hanging shin explain the foot. On
        by default since session 16: on tuning data (session 15's 90 fits of the clothed
        tuning sets and session 16's 32 fits of the perf suite's tuning scenarios) it fixed
        three fits (a marching skirt 49.3 -> 18.8 mm, a trousers lunge 90.4 -> 56.4, a
        clothed picking-up fit 223.8 -> 28.7) and moved no other by 5 mm or more (none of
        the perf suite's 31 others at all); it costs about 4 CPU-s a fit (55.0 -> 59.1 on
        the clothed tuning set, side by side) and cost 10.4 a scan on synth-registration-v3
        (51.0 -> 61.4; a kept move re-runs the shape stage), which the held-shape steps of
        the same session paid back (52.5, same fits; docs/body-models.md, "Session 15" and
        "Session 16").
    shape_search : fits without ``init``: after the final limb search, restart the shape
        from phenotype starts as tall as the fitted body (:mod:`.shapes`; one per gender,
        the height parameter solved for the stature), each followed by half a pose stage and
        the shape stage, and keep the body whose shape objective is lowest (the fitted one
        included). The size handover can reach a tall or short scan's size by the wrong
        parameters (age, muscle), and the shape stage does not leave that basin (session
        20: a 2.08 m woman 26.7 -> 12.8 mm; 16 tuning fits 9.21 -> 8.73 mm). Phenotype
        models only; two pose-and-shape stages more, about 9 CPU-s a fit
        (docs/body-models.md, "Session 20").
    shape_search_builds : each gender's start of the shape search is the build (muscle,
        weight, proportions each 0, 0.5 or 1: :data:`~.shapes.BUILD_GRID`), stature
        matched, whose body fits the scan best placed in the fitted pose (shape objective,
        no optimisation: 54 evaluations); ``False``: the average build (session 20).
    init_route : how a fit without ``init`` starts: ``"hypotheses"`` (the multi-hypothesis
        search), ``"keypoints"`` (3D keypoints detected on renders of the scan, needs the
        ``[keypoints]`` extra; see :mod:`.keypoints`), ``"auto"`` (with the extra both
        starts run and the one with the lower symmetric score goes on; without it the
        hypotheses). Keypoints passed to :meth:`fit` always start the fit.
    keypoint_refine_weight : keypoint weight after the start when the keypoints were
        detected on the scan (detectors place joints a few cm off the skeleton's).
    optimize_scale : also fit the uniform ``scale`` (else the result has ``scale = 1``).
    size_init : without ``init``/keypoints, start from a uniform scale matching the scan's
        vertical extent, refined in the pose stage and handed over to the shape in the
        shape stage (a penalty pulls it back to 1).
    size_handover : before the shape stage, fit the shape to the scaled rest body and set
        the scale to 1 (:meth:`~dressmeup.body.registration.problem.FitProblem.scale_into_shape`),
        so the shape stage does not have to grow or shrink the body against the data term.
    seed : sampling seed; device : torch device; verbose : progress bar.
    num_threads : torch threads during the fit (restored afterwards; None leaves torch's
        setting). One thread is fastest for these small problems on a shared CPU.
    remove_support : leave out of the scan the large flat surfaces a capture contains (the
        floor, a seat's top and sides, a wall; :mod:`.support`), found on
        ``support_sample`` times ``n_scan_points`` samples; the fit then uses
        ``n_scan_points`` of the points left. A scan without such surfaces is unchanged.
    up : the scan's up axis (``x``, ``-x``, ``y``, ``-y``, ``z``, ``-z``). Fits work with y
        up: another axis turns the scan (and ``init``, keypoints) to y up for the fit and
        the result back into the scan's frame (:func:`~dressmeup.body.rigid.rotate_params`).
        ``None`` (default) means y, and refuses a scan (after support removal) whose y
        extent is under half its largest, such as a standing person scanned z-up
        (:func:`~dressmeup.body.registration.scan.check_upright`); ``"y"`` skips that check.
    """

    #: Options of earlier releases and what replaced them (named in the error for an
    #: unknown option, see :func:`~dressmeup.body.registration.get_registrar`).
    RENAMED_OPTIONS: ClassVar[dict[str, str]] = {
        "loose_cloth": "far_cloth='loose', far_cloth_from='start' (loose_cloth=True)"}

    iterations: tuple[int, int, int] = (60, 160, 160)
    inside_weight: float = 0.5
    sigma_out: float = 0.15
    sigma_in: float = 0.01
    point_weight: float = 0.3
    cloth_max: float | None = 0.06
    far_cloth: str = "free"
    far_cloth_from: str = "shape"
    far_cloth_branch: bool = True
    hand_weight: float = 1.0
    skip_unseen: bool = True
    unseen_hit_radius: float | None = 0.03
    pose_prior_weight: float = 1e-2
    limit_weight: float = 1e-2
    shape_weight: float = 1e-4
    keypoint_weight: float = 1.0
    n_scan_points: int = 8000
    n_body_points: int = 5000
    correspondence_every: int = 2
    refine_rounds: int = 0
    shape_in_pose_stage: bool = True
    lbfgs_steps: int = 10
    lr_pose: float = 0.015
    lr_transl: float = 0.01
    lr_shape: float = 0.05
    yaw_search: bool = True
    hypotheses: tuple[str, ...] = DEFAULT_HYPOTHESES
    hypothesis_steps: tuple[int, int, int] = (20, 15, 40)
    hypothesis_keep: int = 3
    hypothesis_yaws: int = 3
    yaw_candidates: int = 8
    keep_opposite_yaw: bool = True
    refine_opposite: bool = True
    yaw_postures: tuple[str, ...] = ("a-pose",)
    limb_scan_cap: float = 0.1
    limb_search: bool = True
    limb_first_knee_bends: tuple[float, ...] = FIRST_KNEE_BENDS
    limb_search_after_pose: bool = True
    limb_aim: str = "all"
    limb_search_final: bool = True
    shape_search: bool = True
    shape_search_builds: bool = True
    init_route: str = "hypotheses"
    keypoint_refine_weight: float = 0.1
    optimize_scale: bool = False
    size_init: bool = True
    size_handover: bool = True
    seed: int = 0
    device: str = "cpu"
    num_threads: int | None = 1
    remove_support: bool = True
    support_sample: int = 4
    up: str | None = None
    verbose: bool = True

    def fit(self, scan, model, init: BodyParams | None = None, keypoints=None) -> RegistrationResult:
        """Fit ``model`` to ``scan``; see :func:`~dressmeup.body.registration.register`."""
        # heavy: torch (~1.1 s to import)
        import torch

        R = up_rotation(self.up or "y")  # a bad axis fails before any work
        turned = self.up not in (None, "y")
        if turned:
            scan, keypoints = rotate_scan(scan, R), rotate_keypoints(keypoints, R)
            init = None if init is None else rotate_params(init, model, R)
        previous = torch.get_num_threads()
        if self.num_threads:
            torch.set_num_threads(int(self.num_threads))
        try:
            result = self._fit(scan, model, init, keypoints)
        finally:
            torch.set_num_threads(previous)
        if turned:  # back into the scan's frame
            result.params = rotate_params(result.params, model, R.T)
            result.supports = [plane.rotated(R.T) for plane in result.supports]
            result.info["up"] = self.up
        return result

    # ---------------------------------------------------------------- stages
    def _initialise(self, problem: FitProblem, init: BodyParams | None) -> dict:
        """Start parameters: ``init`` if given, else the model's rest pose placed on the
        scan and turned by the yaw search. Returns info for the result."""
        n_global = self.iterations[0]
        if init is not None:
            init.check_model(problem.model)
            problem.set_params(shape=np.r_[init.shape, problem.default_shape[init.shape.size:]],
                               pose=init.pose, transl=init.transl, scale=init.scale)
            return {"init": "given"}
        problem.set_params(shape=problem.default_shape)
        size = self.size_init
        if problem.kp is not None and len(problem.kp[0]) >= 4:
            return keypoint_start(problem, self.hypotheses or ("a-pose",), self.hypothesis_steps[2],
                                  self.lr_pose, self.lr_transl, size, verbose=self.verbose)
        if self.hypotheses:
            return self._hypothesis_start(problem)
        place_on_scan(problem, size_init=size and problem.kp is None)
        if self.yaw_search and n_global > 0:
            yaw_search(problem, max(n_global // 2, 5), self.lr_pose, self.lr_transl,
                       verbose=self.verbose)
        return {"init": "rest pose + yaw search" if self.yaw_search else "rest pose"}

    def search_hypotheses(self, problem: FitProblem) -> dict:
        """The multi-hypothesis search alone with this registrar's options
        (:func:`~dressmeup.body.registration.init.hypothesis_search`); leaves the best start
        in ``problem`` and returns its info. Bad options raise
        :class:`~dressmeup.errors.InputError` first, as :meth:`fit` does."""
        self._check_options()
        return self._search_hypotheses(problem)

    def _search_hypotheses(self, problem: FitProblem) -> dict:
        """:meth:`search_hypotheses` without the option check (a fit checked them once)."""
        n_yaw, n_rigid, n_pose = self.hypothesis_steps
        return hypothesis_search(problem, self.hypotheses, n_yaw, n_rigid, n_pose,
                                 self.hypothesis_keep, self.hypothesis_yaws, self.lr_pose,
                                 self.lr_transl, self.size_init, verbose=self.verbose,
                                 yaw_candidates=self.yaw_candidates,
                                 keep_opposite=self.keep_opposite_yaw,
                                 refine_opposite=self.refine_opposite,
                                 yaw_postures=tuple(self.yaw_postures))

    def _hypothesis_start(self, problem: FitProblem) -> dict:
        """The multi-hypothesis search, then (``limb_search``) the limb-wise search."""
        n_pose = self.hypothesis_steps[2]
        info = self._search_hypotheses(problem)
        if self.limb_search:
            info.update(limb_search(problem, n_pose, self.lr_pose, self.lr_transl,
                                    self.size_init, scan_cap=self.limb_scan_cap,
                                    leg_bends_deg=tuple(self.limb_first_knee_bends),
                                    verbose=self.verbose))
        return info

    def _competing_starts(self, problem: FitProblem) -> dict:
        """``init_route="auto"`` with detected keypoints: the hypothesis start and the
        keypoint start both run; the one with the lower symmetric score goes on (the
        keypoints are dropped when the hypotheses win: they disagree with the scan)."""
        kp = problem.kp
        problem.kp = None
        problem.set_params(shape=problem.default_shape)
        info = self._hypothesis_start(problem) if self.hypotheses else {"init": "none"}
        scores = {"hypotheses": symmetric_score(problem)}
        best = problem.snapshot()
        if kp is not None and len(kp[0]) >= 4:
            problem.kp = kp
            problem.set_params(shape=problem.default_shape)
            info_k = keypoint_start(problem, self.hypotheses or ("a-pose",),
                                    self.hypothesis_steps[2], self.lr_pose, self.lr_transl,
                                    self.size_init, verbose=self.verbose)
            scores["keypoints"] = symmetric_score(problem)
            if scores["keypoints"] < scores["hypotheses"]:
                info = info_k
            else:
                problem.restore(best)
                problem.kp = None
        info["start_scores"] = {k: round(v, 5) for k, v in scores.items()}
        return info

    def _check_options(self) -> None:
        """Raise :class:`~dressmeup.errors.InputError` for an unknown choice."""

        for name, allowed in (("far_cloth", ("pull", "loose", "free")),
                              ("far_cloth_from", ("start", "pose", "shape")),
                              ("init_route", ("hypotheses", "keypoints", "auto")),
                              ("limb_aim", ("none", "arms", "all"))):
            if getattr(self, name) not in allowed:
                raise InputError(f"{name}: expected one of {', '.join(allowed)}, got "
                                 f"{getattr(self, name)!r}")

        def real(x) -> bool:  # a number (numpy's too), not a bool or a string; NaN compares False
            return isinstance(x, Real) and not isinstance(x, bool)

        radius = self.unseen_hit_radius
        if radius is not None and not (real(radius) and 0 < radius < 1):
            raise InputError(f"unseen_hit_radius: expected None or a distance in metres in "
                             f"(0, 1), got {radius!r}")
        if not (real(self.limb_scan_cap) and self.limb_scan_cap > 0):
            raise InputError(f"limb_scan_cap: expected a distance in metres > 0 (default 0.1), "
                             f"got {self.limb_scan_cap!r}")
        bends = self.limb_first_knee_bends
        numbers = not isinstance(bends, (str, bytes, dict)) and hasattr(bends, "__len__") and all(
            real(b) and 0 <= b < 180 for b in bends)
        if not (numbers and len(bends)):
            raise InputError("limb_first_knee_bends: expected a non-empty list of knee bends in "
                             f"degrees, each in [0, 180) (default {list(FIRST_KNEE_BENDS)}); "
                             f"got {bends!r}")

        if any(p not in CANONICAL_POSES for p in self.hypotheses):  # a bare name fails too
            raise InputError(f"hypotheses: expected a list of {', '.join(CANONICAL_POSES)}; "
                             f"got {self.hypotheses!r}")
        postures = self.yaw_postures
        if isinstance(postures, (str, bytes)) or not postures or any(
                p not in UPRIGHT_HYPOTHESES for p in postures):
            raise InputError(f"yaw_postures: expected a non-empty list of "
                             f"{', '.join(UPRIGHT_HYPOTHESES)} (canonical poses with an "
                             f"untilted root); got {postures!r}")

    def _use_keypoints(self) -> bool:
        """Whether this fit detects keypoints on the scan (see ``init_route``, checked by
        :meth:`_check_options`)."""

        if self.init_route == "hypotheses":
            return False

        if keypoints_available():
            return True
        if self.init_route == "keypoints":
            raise InputError("init_route='keypoints' needs the [keypoints] extra (mediapipe "
                             "0.10.14; docs/body-models.md), or use init_route='auto'")
        logger.info("keypoints extra not installed: multi-hypothesis start")
        return False

    def _fit(self, scan, model, init, keypoints) -> RegistrationResult:
        t_start = time.perf_counter()
        self._check_options()
        P = prepare_scan(scan, self.n_scan_points, self.seed)
        supports, support_info = [], None
        if self.remove_support:
            P, supports, support_info = self._without_support(scan, P)
        if self.up is None:
            check_upright(P)
        detected = None
        if keypoints is None and init is None and self._use_keypoints():
            detected = detect_keypoints(scan_without_support(scan, supports), model)
            keypoints = detected.joints
        kp = keypoint_arrays(keypoints, model)
        if kp is not None and len(kp[0]) == 0:
            kp = None
        problem = FitProblem(self, model, P, kp)
        if detected is not None and self.init_route == "auto":
            info = self._competing_starts(problem)
        else:
            info = self._initialise(problem, init)
        if detected is not None:
            info.update(keypoint_views=detected.detections, keypoints_found=int(len(kp[0])) if kp
                        else 0, keypoint_seconds=time.perf_counter() - t_start)
            problem.kp_weight = self.keypoint_refine_weight
        if support_info is not None:
            info["support"] = support_info
        fit_size = self.size_init and init is None
        losses = self._refine(problem, fit_size=fit_size, info=info, limbs_again=init is None)
        return RegistrationResult(params=problem.body_params(self.optimize_scale),
                                  seconds=time.perf_counter() - t_start, losses=losses, info=info,
                                  supports=supports)

    def _without_support(self, scan, P: np.ndarray) -> tuple[np.ndarray, list, dict]:
        """Find the supports on a denser sample of the scan; return the fit's points without
        them (``P`` itself when there are none), the planes and info (points removed of those
        checked, the planes, CPU seconds of the search)."""

        cpu = time.process_time()
        dense = prepare_scan(scan, max(self.support_sample, 1) * self.n_scan_points, self.seed)
        kept, planes = remove_support(dense, seed=self.seed)
        if planes:
            P = prepare_scan(kept, self.n_scan_points, self.seed)
            logger.info("left out %d of %d scan points on %d support surfaces",
                        len(dense) - len(kept), len(dense), len(planes))
        info = {"points_removed": len(dense) - len(kept), "points_checked": len(dense),
                "planes": [p.summary() for p in planes], "cpu_s": time.process_time() - cpu}
        return P, planes, info

    def _shape_stage(self, p: FitProblem, fit_size: bool) -> tuple[dict[str, float], list]:
        """The size handover (``size_handover``), then the shape stage with far cloth as
        configured (``far_cloth``); returns its loss terms (prefixed) and the parameters it
        moved (for the optional L-BFGS rounds)."""
        losses: dict[str, float] = {}
        if fit_size and self.size_handover and not self.optimize_scale:
            losses["size_handover_rms_mm"] = 1000 * p.scale_into_shape()
        p.far_cloth_on = True
        params = [p.pose, p.transl, p.shape_z]
        lrs = [self.lr_pose * 0.5, self.lr_transl * 0.5, self.lr_shape]
        if self.optimize_scale or abs(float(p.log_scale.detach())) > 0:
            params.append(p.log_scale)
            lrs.append(0.01)
        losses.update({f"shape_{k}": x for k, x in run_adam(
            p, "shape", self.iterations[2], params, lrs, verbose=self.verbose).items()})
        return losses, params

    def _pose_to_shape(self, p: FitProblem, n_pose: int, pose_params: list, pose_lrs: list,
                       fit_size: bool, limbs_again: bool) -> tuple[dict, dict | None, list]:
        """The pose stage, then (``limbs_again`` and the options ``limb_search``,
        ``limb_search_after_pose``) the second limb search, then :meth:`_shape_stage`;
        returns the loss terms (prefixed), the second limb search's info (None when it did
        not run) and the shape stage's parameters."""
        losses = {f"pose_{k}": x for k, x in run_adam(
            p, "pose", n_pose, pose_params, pose_lrs, verbose=self.verbose).items()}
        again = None
        if limbs_again and self.limb_search and self.limb_search_after_pose:
            again = self._aimed_limb_search(p, fit_size)
        shape_losses, shape_params = self._shape_stage(p, fit_size)
        losses.update(shape_losses)
        return losses, again, shape_params

    def _far_cloth_branches(self, p: FitProblem, *args) -> tuple[dict, dict | None, list, dict]:
        """``far_cloth_branch``: :meth:`_pose_to_shape` with far cloth pulling in the pose
        stage, then from the same start with ``far_cloth`` throughout; both end in the same
        shape stage, so they are two local minima of one objective, and the body where that
        objective (:meth:`~dressmeup.body.registration.problem.FitProblem.objective`) is lower
        stays in ``p`` (ties: the pulling one). Returns what :meth:`_pose_to_shape` returns
        for the kept branch and ``{"pull": objective, <far_cloth>: objective, "kept": ...}``.
        """
        start = p.snapshot()
        out = []
        for rule_on in (False, True):
            p.restore(start)
            p.far_cloth_on = rule_on
            losses, again, params = self._pose_to_shape(p, *args)
            out.append((p.objective("shape"), rule_on, p.snapshot(), losses, again, params))
        _, rule_on, snap, losses, again, params = min(out, key=lambda t: (t[0], t[1]))
        p.restore(snap)
        scores = {"pull": round(out[0][0], 4), self.far_cloth: round(out[1][0], 4),
                  "kept": self.far_cloth if rule_on else "pull"}
        return losses, again, params, scores

    def _aimed_limb_search(self, p: FitProblem, fit_size: bool) -> dict:
        """The limb search after the first (after the pose stage, and the final one): aimed
        as ``limb_aim``, every knee bend; its info."""
        return limb_search(p, self.hypothesis_steps[2], self.lr_pose, self.lr_transl, fit_size,
                           aim=self.limb_aim, scan_cap=self.limb_scan_cap, verbose=self.verbose)

    def _final_limb_search(self, p: FitProblem, info: dict | None) -> dict[str, float]:
        """``limb_search_final``: the limb search once more from the finished body (aimed as
        ``limb_aim``); when it keeps a move, the shape stage again (no size handover: the
        size is set). Its info into ``info["limbs_final"]``; returns the shape stage's loss
        terms, prefixed ``final_`` (none when nothing moved)."""
        last = self._aimed_limb_search(p, False)
        if info is not None:
            info["limbs_final"] = last
        if not last["limb_kept"]:
            return {}
        return {f"final_{k}": x for k, x in self._shape_stage(p, False)[0].items()}

    def _shape_search(self, p: FitProblem, info: dict | None) -> dict[str, float]:
        """``shape_search``: from the finished body, each stature-matched shape
        (:func:`~dressmeup.body.registration.shapes.stature_matched_shapes`) with the body's
        centroid kept, half a pose stage and the shape stage; the body with the lowest
        shape objective stays in ``p``. ``info["shape_search"]``: the objective of each start
        (``"fitted"`` and ``"gender <g> height <h>"``) and the one kept; returns the kept
        start's loss terms, prefixed ``search_`` (none when the fitted body stays)."""
        # heavy: torch (~1.1 s to import)
        import torch

        builds = BUILD_GRID if self.shape_search_builds else (DEFAULT_BUILD,)
        shapes = stature_matched_shapes(p.model, p.body_params(False).shape, builds)
        if not shapes:
            return {}
        fitted = p.snapshot()
        centroid = p.posed_numpy()[p.body_ids].mean(0)

        def place(shape: np.ndarray) -> None:  # the fitted pose, the centroid kept
            p.restore(fitted)
            p.set_params(shape=shape)
            with torch.no_grad():
                moved = p.posed_numpy()[p.body_ids].mean(0)
                p.transl.add_(torch.as_tensor(centroid - moved, dtype=p.dt, device=p.dev))

        starts = []
        for g in range(len(GENDERS)):  # each gender's build that fits the scan best as placed
            ranked = []
            for shape in shapes[g * len(builds):(g + 1) * len(builds)]:
                place(shape)
                ranked.append((p.objective("shape") if len(builds) > 1 else 0.0, shape))
            starts.append(min(ranked, key=lambda r: r[0])[1])
        p.restore(fitted)
        best = (p.objective("shape"), "fitted", fitted, {})
        scores = {"fitted": round(best[0], 4)}
        for shape in starts:
            place(shape)
            losses = {f"pose_{k}": x for k, x in run_adam(
                p, "pose", self.iterations[1] // 2, [p.pose, p.transl],
                [self.lr_pose, self.lr_transl], verbose=self.verbose).items()}
            losses.update(self._shape_stage(p, False)[0])
            name = f"gender {shape[I_GENDER]:.0f} height {shape[I_HEIGHT]:.2f}" + (
                " build {:.1f} {:.1f} {:.1f}".format(*shape[I_BUILD]) if len(builds) > 1 else "")
            scores[name] = round(p.objective("shape"), 4)
            if scores[name] < best[0]:
                best = (scores[name], name, p.snapshot(), losses)
        p.restore(best[2])
        scores["kept"] = best[1]
        if info is not None:
            info["shape_search"] = scores
        return {f"search_{k}": x for k, x in best[3].items()}

    def _refine(self, problem: FitProblem, fit_size: bool, info: dict | None = None,
                limbs_again: bool = False) -> dict[str, float]:
        """Global (rigid, core joints), pose, (``limbs_again`` and the options
        ``limb_search``, ``limb_search_after_pose``: a second limb search, its info into
        ``info["limbs_after_pose"]``), size handover and shape stages (with
        ``far_cloth_branch`` all of them after the global stage twice, see
        :meth:`_far_cloth_branches`; the objectives into ``info["far_cloth_branches"]``),
        (``limb_search_final``: :meth:`_final_limb_search`), (``shape_search``:
        :meth:`_shape_search`, fits without ``init``), then the optional L-BFGS rounds."""
        n_global, n_pose, _ = self.iterations
        p = problem
        losses: dict[str, float] = {}
        p.core_only = True
        losses.update({f"global_{k}": x for k, x in run_adam(
            p, "global", n_global, [p.pose, p.transl], [self.lr_pose, self.lr_transl],
            verbose=self.verbose).items()})
        p.core_only = False
        p.far_cloth_on = self.far_cloth_from in ("start", "pose")
        pose_params, pose_lrs = [p.pose, p.transl], [self.lr_pose, self.lr_transl]
        if self.shape_in_pose_stage:
            pose_params.append(p.shape_z)
            pose_lrs.append(self.lr_shape * 0.5)
        if fit_size:
            pose_params.append(p.log_scale)
            pose_lrs.append(0.003)
        stage = (p, n_pose, pose_params, pose_lrs, fit_size, limbs_again)
        if self.far_cloth_branch and self.far_cloth_from == "shape" and self.far_cloth != "pull":
            stage_losses, again, shape_params, scores = self._far_cloth_branches(*stage)
            if info is not None:
                info["far_cloth_branches"] = scores
        else:
            stage_losses, again, shape_params = self._pose_to_shape(*stage)
        losses.update(stage_losses)
        if again is not None and info is not None:
            info["limbs_after_pose"] = again
        if limbs_again and self.limb_search and self.limb_search_final:
            losses.update(self._final_limb_search(p, info))
        if limbs_again and self.shape_search:
            losses.update(self._shape_search(p, info))
        losses.update({f"refine_{k}": x for k, x in run_lbfgs(
            p, self.refine_rounds, shape_params, self.lbfgs_steps, verbose=self.verbose).items()})
        return losses
