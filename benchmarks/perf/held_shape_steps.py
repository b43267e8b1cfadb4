"""Registration steps that hold the shape: the full graph against the held shape, one run.

Most of a fit's Adam steps do not move the body shape (the yaw search, the rigid and pose
steps of the hypotheses, the limb searches' settling, the rigid stage). Those steps feed
the shape to the body model without a gradient (``FitProblem.loss(..., hold_shape=True)``,
as ``run_adam`` asks when the shape is not among the tensors it moves), so the model's
cached rest body is reused instead of re-shaped (anny's phenotype blendshapes) every step.
This script runs the
same loss + backward steps both ways in one process, alternating, checks that every loss
and every pose and translation gradient is equal bit for bit, and prints the CPU time of
each with the load average.

Scan: an anny body (default shape) in the pose library's ``walking`` pose, 30,000 points
with 2 mm noise, sampled as the registrar does (``n_scan_points``, ``n_body_points``).

    python benchmarks/perf/held_shape_steps.py              # 3 rounds of 60 steps per stage
    python benchmarks/perf/held_shape_steps.py --steps 20 --model procedural
"""

from __future__ import annotations

import argparse
import os
import time


def problem_on_walking_scan(model_name: str, seed: int = 0):
    """A ``FitProblem`` on a synthetic walking scan, started from a slightly wrong pose."""
    from dressmeup.body import get_body_model
    from dressmeup.body.registration.config import get_config
    from dressmeup.body.registration.problem import FitProblem
    from dressmeup.body.registration.scan import prepare_scan
    from dressmeup.body.synthetic import synthetic_scan
    from dressmeup.data.synth.garments import BodyFrame
    from dressmeup.data.synth.poses import pose_axis_angle

    model = get_body_model(model_name)
    params = model.default_params()
    frame = BodyFrame.from_joints(model.posed(params).joints, model.joint_names)
    params.pose[:] = pose_axis_angle("walking", model.joint_names, frame)
    P = synthetic_scan(model, params, n_points=30000, noise=0.002, seed=seed)
    config = get_config(seed=seed)
    problem = FitProblem.from_config(config, model,
                                     prepare_scan(P, config.data.n_scan_points, seed))
    problem.set_params(pose=0.8 * params.pose, transl=params.transl + 0.02)
    return problem


def steps(problem, objective, n: int, held: bool) -> tuple[float, list]:
    """CPU seconds of ``n`` loss + backward steps of ``objective`` (parameters not moved,
    so both variants see the same inputs) and the (loss, pose grad, transl grad) of each."""
    from dressmeup.body.registration.problem import Correspondences

    pairs = Correspondences(steps=n)
    out = []
    t = time.process_time()
    for _ in range(n):
        for x in (problem.pose, problem.transl, problem.shape_z):
            x.grad = None
        loss, _ = problem.loss(objective, pairs, hold_shape=held)
        loss.backward()
        out.append((loss.detach().clone(), problem.pose.grad.clone(),
                    problem.transl.grad.clone()))
    return time.process_time() - t, out


def main(argv: list[str] | None = None) -> int:
    import torch

    from dressmeup.body.registration.problem import Objective

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=60, help="steps per stage and round")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds")
    ap.add_argument("--model", default="anny")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)  # as the registrar's fits run
    problem = problem_on_walking_scan(args.model)
    print(f"{'stage':<8}{'full graph (s)':>15}{'held shape (s)':>16}{'ratio':>8}{'load':>6}")
    total = [0.0, 0.0]
    for stage in ("global", "pose"):
        objective = Objective(stage, core_only=stage == "global")
        t_full = t_held = 0.0
        for _ in range(args.rounds):
            tf, full = steps(problem, objective, args.steps, held=False)
            th, held = steps(problem, objective, args.steps, held=True)
            for a, b in zip(full, held, strict=True):
                if not all(torch.equal(x, y) for x, y in zip(a, b, strict=True)):
                    raise SystemExit(f"{stage}: the held shape changed a loss or a gradient")
            t_full += tf
            t_held += th
        total[0] += t_full
        total[1] += t_held
        print(f"{stage:<8}{t_full:15.3f}{t_held:16.3f}{t_full / t_held:8.2f}"
              f"{os.getloadavg()[0]:6.1f}")
    print(f"{'all':<8}{total[0]:15.3f}{total[1]:16.3f}{total[0] / total[1]:8.2f}"
          f"{os.getloadavg()[0]:6.1f}  (CPU s; equal losses and gradients, bit for bit)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
