"""The optimiser loop over a :class:`~dressmeup.body.registration.problem.FitProblem`, and
the stages made of one run of it (rigid, pose, shape: :mod:`.plan`).

:func:`run_adam`: Adam with a cosine learning-rate schedule over the parameters a stage
moves, minimising an :class:`~dressmeup.body.registration.problem.Objective`. Stage
``global`` moves only the root rotation (and what else is given, e.g. the translation);
``pose`` holds the distal joints for the first third, so the trunk and proximal joints
settle first; ``shape`` moves everything given. Steps that do not move the shape feed it
to the body model without a gradient, so its cached rest body is reused (the same values
and gradients for what moves, in less time).
"""

from __future__ import annotations

from dressmeup.body.registration.problem import Correspondences, Objective
from dressmeup.body.registration.terms import DISTAL_JOINTS
from dressmeup.progress import progress

#: learning rate of the temporary uniform scale (log) in the stages that move it
SIZE_RATE = 0.003


def run_adam(problem, objective: Objective, n: int, params: list, lrs: list[float],
             label: str | None = None, verbose: bool = False) -> dict[str, float]:
    """Run ``n`` Adam steps of ``objective`` on ``params`` (tensors of ``problem``, learning
    rates ``lrs``); return the last step's loss terms (before its update; empty for n <= 0).
    """
    # heavy: torch (~1.1 s to import)
    import torch

    if n <= 0:
        return {}
    names = list(problem.model.joint_names)
    distal = [names.index(j) for j in DISTAL_JOINTS if j in names]
    opt = torch.optim.Adam([{"params": [p], "lr": lr} for p, lr in zip(params, lrs, strict=True)])
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=n, eta_min=0.05 * min(lrs))
    terms: dict = {}
    pairs = Correspondences(steps=n)
    hold_shape = not any(p is problem.shape_z for p in params)
    pose = problem.pose
    bar = progress(range(n), desc=f"register: {label or objective.stage}",
                   disable=None if verbose else True)
    for it in bar:
        opt.zero_grad()
        loss, terms = problem.loss(objective, pairs, hold_shape=hold_shape)
        loss.backward()
        if pose.grad is not None:
            if objective.stage == "global":  # only the root rotation moves in this stage
                pose.grad[1:] = 0
            elif objective.stage == "pose" and it < n // 3 and distal:
                pose.grad[distal] = 0
        opt.step()
        sched.step()
    return terms


def rigid_stage(problem, spec, keypoints: float = 0.0, verbose: bool = False
                ) -> dict[str, float]:
    """The rigid stage (:class:`~dressmeup.body.registration.plan.Rigid`): root rotation
    and translation on the core joints; its last loss terms."""
    objective = Objective("global", core_only=True, keypoints=keypoints)
    return run_adam(problem, objective, spec.steps, [problem.pose, problem.transl],
                    [spec.rates.pose, spec.rates.transl], verbose=verbose)


def pose_stage(problem, spec, keypoints: float = 0.0, verbose: bool = False
               ) -> dict[str, float]:
    """The pose stage (:class:`~dressmeup.body.registration.plan.Pose`): every joint, the
    translation, the shape at half rate and (``spec.size``) the temporary scale; its last
    loss terms."""
    objective = Objective("pose", far_cloth=spec.far_cloth, keypoints=keypoints)
    params = [problem.pose, problem.transl, problem.shape_z]
    lrs = [spec.rates.pose, spec.rates.transl, spec.rates.shape * 0.5]
    if spec.size:
        params.append(problem.log_scale)
        lrs.append(SIZE_RATE)
    return run_adam(problem, objective, spec.steps, params, lrs, verbose=verbose)


def shape_stage(problem, spec, keypoints: float = 0.0, verbose: bool = False
                ) -> dict[str, float]:
    """The shape stage (:class:`~dressmeup.body.registration.plan.Shape`): the size
    handover (``spec.handover``; its remaining mismatch as ``size_handover_rms_mm``), then
    shape, pose and translation (half rate) with the far-cloth rule on; a temporary scale
    still away from 1 moves too, pulled back to 1. Returns the loss terms prefixed
    ``shape_``."""
    losses: dict[str, float] = {}
    if spec.handover:
        losses["size_handover_rms_mm"] = 1000 * problem.scale_into_shape()
    params = [problem.pose, problem.transl, problem.shape_z]
    lrs = [spec.rates.pose * 0.5, spec.rates.transl * 0.5, spec.rates.shape]
    if abs(float(problem.log_scale.detach())) > 0:
        params.append(problem.log_scale)
        lrs.append(0.01)
    objective = Objective("shape", far_cloth=True, keypoints=keypoints)
    losses.update({f"shape_{k}": x for k, x in run_adam(problem, objective, spec.steps, params,
                                                         lrs, verbose=verbose).items()})
    return losses
