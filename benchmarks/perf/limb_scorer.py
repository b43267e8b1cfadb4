"""The limb search's score: every scan point queried against the pruned query, one run.

:class:`dressmeup.body.registration.limbs.LimbScorer` scores a limb moved rigidly by the
symmetric capped distance. Its scan -> body term needs, for each scan point near the limb,
the distance to the moved limb's points; it queries only the scan points
nearer the limb's bounding box than to the rest of the body (the others cannot change).
This script scores the same random limb turns both ways in one process, checks that the
sums are equal bit for bit, and prints the CPU time of each with the load average.

Scan: an anny body (default shape) in the pose library's ``walking`` pose, 8,000 points with
2 mm noise, and a loose shell 2-6 cm off the legs and torso (cloth the body does not
explain), as the registrar samples it (``n_scan_points``, ``n_body_points`` defaults).

    python benchmarks/perf/limb_scorer.py              # 400 turns per limb, 4 limbs
    python benchmarks/perf/limb_scorer.py --turns 100 --model procedural
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def every_point_score(scorer, M_up: np.ndarray, M_lo: np.ndarray) -> float:
    """The score with every scan point near the limb queried (the earlier way)."""
    from scipy.spatial import cKDTree

    from dressmeup.body.registration.init import capped_distances

    X = scorer.points(M_up, M_lo)
    b = float(capped_distances(scorer.tree, X, scorer.cap).sum())
    d, _ = cKDTree(X).query(scorer.P_near, k=1, distance_upper_bound=scorer.scan_cap,
                            workers=1)
    s = float(np.minimum(scorer.d_near, d).sum())
    return (scorer.const_body + b) / scorer.n_b + (scorer.const_scan + s) / scorer.n_p


def scorers(model_name: str, seed: int = 0) -> list:
    """(limb name, LimbScorer) for the four limbs of a clothed walking scan."""
    import torch

    from dressmeup.body import get_body_model
    from dressmeup.body.registration import limbs
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
    P = synthetic_scan(model, params, n_points=8000, noise=0.002, seed=seed)
    rng = np.random.default_rng(seed)
    V = model.posed(params).vertices
    n = V - V.mean(0)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    low = np.flatnonzero(V[:, 1] < np.median(V[:, 1]))  # a loose shell round the lower body
    pick = rng.choice(low, 2000)
    P = np.r_[P, V[pick] + n[pick] * rng.uniform(0.02, 0.06, (len(pick), 1))]
    config = get_config(seed=seed)
    problem = FitProblem.from_config(config, model,
                                     prepare_scan(P, config.data.n_scan_points, seed))
    problem.set_params(pose=params.pose, transl=params.transl)
    names = list(model.joint_names)
    parents = np.asarray(model.joint_parents)
    dom = problem.W_sub.cpu().numpy().argmax(1)
    with torch.no_grad():
        out = model.forward(problem.shape_value()[None], problem.pose[None],
                            problem.transl[None], torch.exp(problem.log_scale)[None])
    Vb = out.vertices[0].cpu().numpy().astype(np.float64)[problem.body_ids]
    J = out.joints[0].cpu().numpy().astype(np.float64)
    found = []
    for up_name, lo_name, _ in limbs.LIMBS:
        up, lo = names.index(up_name), names.index(lo_name)
        found.append((up_name, limbs.LimbScorer(
            problem.P, problem.tree, Vb, dom == up, np.isin(dom, limbs._descendants(parents, lo)),
            J[up], J[lo])))
    return found


def main(argv: list[str] | None = None) -> int:
    from scipy.spatial.transform import Rotation

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--turns", type=int, default=400, help="random limb turns per limb")
    ap.add_argument("--model", default="anny")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(1)
    total = {"every point": 0.0, "pruned": 0.0}
    print(f"{'limb':<16}{'every point (s)':>16}{'pruned (s)':>12}{'ratio':>8}{'load':>6}")
    for name, scorer in scorers(args.model):
        turns = [Rotation.from_rotvec(rng.normal(0, 0.3 if k % 2 else np.pi, (2, 3)))
                 .as_matrix() for k in range(args.turns)]
        t = time.process_time()
        slow = [every_point_score(scorer, *m) for m in turns]
        t_slow = time.process_time() - t
        t = time.process_time()
        fast = [scorer.score(*m) for m in turns]
        t_fast = time.process_time() - t
        if slow != fast:
            raise SystemExit(f"{name}: the pruned score differs from the full one")
        total["every point"] += t_slow
        total["pruned"] += t_fast
        print(f"{name:<16}{t_slow:16.3f}{t_fast:12.3f}{t_slow / t_fast:8.2f}"
              f"{os.getloadavg()[0]:6.1f}")
    print(f"{'all':<16}{total['every point']:16.3f}{total['pruned']:12.3f}"
          f"{total['every point'] / total['pruned']:8.2f}{os.getloadavg()[0]:6.1f}  "
          "(CPU s; equal sums, bit for bit)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
