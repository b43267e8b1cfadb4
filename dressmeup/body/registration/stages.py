"""Optimisation stages over a :class:`~dressmeup.body.registration.problem.FitProblem`.

- :func:`run_adam`: Adam with a cosine learning-rate schedule for one stage (``global``:
  only the root rotation and translation move; ``pose``: the distal joints are held for the
  first third, so the trunk and proximal joints settle first; ``shape``: everything given).
- :func:`run_lbfgs`: optional ICP-like refinement (fixed correspondences, a few L-BFGS
  steps, repeat).

Both tell the problem whether the tensors they optimise include the shape
(``FitProblem.shape_moves``): when not, the loss feeds the shape without a gradient and
the body model reuses its cached rest body (the same values and the same gradients for
what moves, in less time).
"""

from __future__ import annotations

from contextlib import contextmanager

from dressmeup.body.registration.terms import DISTAL_JOINTS
from dressmeup.progress import progress


def run_adam(problem, stage: str, n: int, params: list, lrs: list[float],
             label: str | None = None, verbose: bool = False) -> dict[str, float]:
    """Run ``n`` Adam steps of ``stage`` on ``params`` (tensors of ``problem``); return the
    last step's loss terms."""
    # heavy: torch (~1.1 s to import)
    import torch

    if n <= 0:
        return {}
    names = list(problem.model.joint_names)
    distal = [names.index(j) for j in DISTAL_JOINTS if j in names]
    opt = torch.optim.Adam([{"params": [p], "lr": lr} for p, lr in zip(params, lrs, strict=True)])
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=n, eta_min=0.05 * min(lrs))
    terms: dict = {}
    problem.reset_correspondences()
    problem.stage_steps = n
    pose = problem.pose
    bar = progress(range(n), desc=f"register: {label or stage}", disable=None if verbose else True)
    with _shape_moves_if_optimised(problem, params):
        for it in bar:
            opt.zero_grad()
            loss, terms = problem.loss(stage)
            loss.backward()
            if pose.grad is not None:
                if stage == "global":  # only the root rotation moves in this stage
                    pose.grad[1:] = 0
                elif stage == "pose" and it < n // 3 and distal:
                    pose.grad[distal] = 0
            opt.step()
            sched.step()
    return terms


@contextmanager
def _shape_moves_if_optimised(problem, params: list):
    """Within the block ``problem.shape_moves`` says whether ``params`` (the tensors a stage
    optimises) include the shape; afterwards it is True again."""
    problem.shape_moves = any(p is problem.shape_z for p in params)
    try:
        yield
    finally:
        problem.shape_moves = True


def run_lbfgs(problem, n_outer: int, params: list, max_iter: int = 10,
              verbose: bool = False) -> dict[str, float]:
    """ICP-like refinement of the ``shape`` objective: ``n_outer`` rounds of fresh
    correspondences then ``max_iter`` L-BFGS steps with them frozen."""
    # heavy: torch (~1.1 s to import)
    import torch

    terms: dict = {}
    if n_outer <= 0:
        return terms
    opt = torch.optim.LBFGS(params, lr=1.0, max_iter=max_iter, history_size=20,
                            line_search_fn="strong_wolfe")
    with _shape_moves_if_optimised(problem, params):
        for _ in progress(range(n_outer), desc="register: refine",
                          disable=None if verbose else True):
            problem.freeze = False
            problem.rest_normals, problem.nn_s2b, problem.nn_b2s = None, None, None
            with torch.no_grad():
                problem.loss("shape")  # refresh correspondences and normals
            problem.freeze = True

            def closure():
                opt.zero_grad()
                loss, t = problem.loss("shape")
                loss.backward()
                terms.update(t)
                return loss

            opt.step(closure)
    problem.freeze = False
    return terms
