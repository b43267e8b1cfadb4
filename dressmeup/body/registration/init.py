"""Where a fit starts: placement on the scan, yaw search, pose hypotheses.

- :func:`place_on_scan`: centre the body on the scan and (upright scans without
  keypoints) match the vertical extent with a temporary uniform scale, which the shape takes
  over in the last stage (limb lengths then need not be faked by bending the knees).
- :func:`yaw_search`: from the current pose, try 4 root yaw angles with a short rigid
  stage fitting the torso, hips and head, keep the best.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from dressmeup.body.registration.stages import run_adam

logger = logging.getLogger(__name__)


def place_on_scan(problem, size_init: bool) -> None:
    """Translate (and with ``size_init`` scale) the current body onto the scan's centre."""
    import torch

    V = problem.posed_numpy()
    scale = float(torch.exp(problem.log_scale.detach()))
    Vd = (V - problem.transl.detach().cpu().numpy()) / scale
    if size_init:
        ratio = float(np.ptp(problem.P[:, 1]) / max(np.ptp(Vd[:, 1]), 1e-6))
        scale = min(max(ratio, 0.5), 1.5)
        problem.set_params(scale=scale)
    problem.set_params(transl=problem.P.mean(0) - scale * Vd.mean(0))


def yaw_search(problem, n_steps: int, lr_pose: float, lr_transl: float,
               yaws=(0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi), verbose: bool = False) -> float:
    """Try each root yaw (radians about +y) from the current pose with ``n_steps`` rigid
    steps on the core joints' skin; keep the best and return its core data cost.

    Candidates are compared on the torso, hips and head only: with the limbs, a wrong yaw
    can win (A-pose arms sideways match a walking scan's legs seen from the side).
    """
    import torch

    base = problem.snapshot()
    best = None
    problem.core_only = True
    try:
        for yaw in yaws:
            problem.restore(base)
            with torch.no_grad():
                problem.pose[0] = torch.tensor([0.0, yaw, 0.0], dtype=problem.dt)
            label = f"yaw {math.degrees(yaw):.0f}"
            terms = run_adam(problem, "global", n_steps, [problem.pose, problem.transl],
                             [lr_pose, lr_transl], label=label, verbose=verbose)
            logger.info("%s: core data %.4f", label, terms["data"])
            if best is None or terms["data"] < best[0]:
                best = (terms["data"], problem.snapshot())
    finally:
        problem.core_only = False
    problem.restore(best[1])
    return best[0]
