"""The ``optimization`` registrar: a configuration (:mod:`.config`) whose plan (:mod:`.plan`)
runs on the scan (:mod:`.runner`)."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.body.registration.config import RegistrationConfig, get_config
from dressmeup.body.registration.keypoints import detect_keypoints, keypoints_available
from dressmeup.body.registration.plan import Plan, build_plan
from dressmeup.body.registration.problem import FitProblem
from dressmeup.body.registration.runner import run_plan
from dressmeup.body.registration.scan import (
    check_upright,
    keypoint_arrays,
    prepare_scan,
    rotate_keypoints,
    rotate_scan,
    up_rotation,
)
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


class OptimizationRegistrar:
    """Fit a body model to a scan by optimisation (see :mod:`dressmeup.body.registration`).

    Parameters
    ----------
    preset : a name of :data:`~.config.PRESETS` (``default``, ``fast``, ``naked``,
        ``clothed``) or a :class:`~.config.RegistrationConfig`.
    **overrides : settings by name (see the groups of :mod:`.config`), validated.

    Raises
    ------
    InputError
        Unknown preset or setting, or a value out of range.
    """

    def __init__(self, preset: str | RegistrationConfig = "default", **overrides: Any) -> None:
        self.config = get_config(preset, **overrides)

    def __repr__(self) -> str:
        return f"OptimizationRegistrar({self.config!r})"

    def plan(self, start: str = "search", detected: bool = False) -> Plan:
        """The plan a fit runs (:func:`~.plan.build_plan`): ``start`` ``"given"`` (with
        ``init``), ``"keypoints"``, ``"search"`` or ``"auto"``."""
        return build_plan(self.config, start, detected)

    def fit(self, scan, model, init: BodyParams | None = None, keypoints=None,
            plan: Plan | None = None) -> RegistrationResult:
        """Fit ``model`` to ``scan``; see :func:`~dressmeup.body.registration.register`.
        ``plan``: run these stages instead of the configuration's (an experiment)."""
        # heavy: torch (~1.1 s to import)
        import torch

        up = self.config.scan.up
        R = up_rotation(up or "y")
        turned = up not in (None, "y")
        if turned:
            scan, keypoints = rotate_scan(scan, R), rotate_keypoints(keypoints, R)
            init = None if init is None else rotate_params(init, model, R)
        threads = self.config.runtime.num_threads
        previous = torch.get_num_threads()
        if threads:
            torch.set_num_threads(int(threads))
        try:
            result = self._fit(scan, model, init, keypoints, plan)
        finally:
            torch.set_num_threads(previous)
        if turned:  # back into the scan's frame
            result.params = rotate_params(result.params, model, R.T)
            result.supports = [plane.rotated(R.T) for plane in result.supports]
            result.info["up"] = up
        return result

    def _use_keypoints(self) -> bool:
        """Whether a fit without init or keypoints detects keypoints on the scan
        (``init_route``)."""
        route = self.config.start.init_route
        if route == "hypotheses":
            return False
        if keypoints_available():
            return True
        if route == "keypoints":
            raise InputError("init_route='keypoints' needs the [keypoints] extra (mediapipe "
                             "0.10.14; docs/body-models.md), or use init_route='auto'")
        logger.info("keypoints extra not installed: multi-hypothesis start")
        return False

    def _fit(self, scan, model, init, keypoints, plan: Plan | None) -> RegistrationResult:
        t_start = time.perf_counter()
        cfg = self.config
        P = prepare_scan(scan, cfg.data.n_scan_points, cfg.runtime.seed)
        supports, support_info = [], None
        if cfg.scan.remove_support:
            P, supports, support_info = self._without_support(scan, P)
        if cfg.scan.up is None:
            check_upright(P)
        detected = None
        if keypoints is None and init is None and self._use_keypoints():
            detected = detect_keypoints(scan_without_support(scan, supports), model)
            keypoints = detected.joints
        kp = keypoint_arrays(keypoints, model)
        if kp is not None and len(kp[0]) == 0:
            kp = None
        enough = kp is not None and len(kp[0]) >= 4
        auto = detected is not None and cfg.start.init_route == "auto"
        start = "given" if init is not None else "auto" if auto and enough else \
            "keypoints" if enough else "search"
        plan = plan or self.plan(start, detected=detected is not None)
        problem = FitProblem.from_config(cfg, model, P, kp)
        state = run_plan(plan, problem, init=init, keypoints=not auto or enough,
                         verbose=cfg.runtime.verbose)
        info = state.info
        if detected is not None:
            info.update(keypoint_views=detected.detections, keypoints_found=int(len(kp[0]))
                        if kp else 0, keypoint_seconds=time.perf_counter() - t_start)
        if support_info is not None:
            info["support"] = support_info
        return RegistrationResult(params=problem.body_params(),
                                  seconds=time.perf_counter() - t_start, losses=state.losses,
                                  info=info, supports=supports)

    def _without_support(self, scan, P: np.ndarray) -> tuple[np.ndarray, list, dict]:
        """Find the supports on a denser sample of the scan; return the fit's points without
        them (``P`` itself when there are none), the planes and info (points removed of those
        checked, the planes, CPU seconds of the search)."""
        cfg = self.config
        n, seed = cfg.data.n_scan_points, cfg.runtime.seed
        cpu = time.process_time()
        dense = prepare_scan(scan, max(cfg.scan.support_sample, 1) * n, seed)
        kept, planes = remove_support(dense, seed=seed)
        if planes:
            P = prepare_scan(kept, n, seed)
            logger.info("left out %d of %d scan points on %d support surfaces",
                        len(dense) - len(kept), len(dense), len(planes))
        info = {"points_removed": len(dense) - len(kept), "points_checked": len(dense),
                "planes": [p.summary() for p in planes], "cpu_s": time.process_time() - cpu}
        return P, planes, info
