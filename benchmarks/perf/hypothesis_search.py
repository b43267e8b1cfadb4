"""Cost of the hypothesis search's variants, side by side in one run.

The multi-hypothesis start (``init.hypothesis_search``) runs before every fit without
``init``. This script times it on the same scans with registrar options that change its
work, alternating variants scan by scan, and prints the CPU seconds of each, the ratio to
the first variant, the load average, and the winning hypothesis (name, heading in degrees,
symmetric score in m), so cost and choice are read together:

- ``default``: the registrar's defaults (since session 17 with ``refine_opposite``);
- ``no-refine-opposite``: ``refine_opposite=False`` (the session-16 default);
- ``bent-yaw``: ``yaw_postures=("a-pose", "bending")`` (the yaw stage twice).

Scans: an anny body (default shape, turned by a random yaw) in library poses, 30,000
points with 2 mm noise, naked or with a smooth garment shell 1-3 cm off the torso (as in
``benchmarks/perf/registration.py``), sampled as the registrar does.

    python benchmarks/perf/hypothesis_search.py                  # 3 poses x naked/clothed
    python benchmarks/perf/hypothesis_search.py --poses walking --rounds 2
"""

from __future__ import annotations

import argparse
import os
import time

VARIANTS = {"default": {}, "no-refine-opposite": {"refine_opposite": False},
            "bent-yaw": {"yaw_postures": ("a-pose", "bending")}}


def scan_of(model, pose: str, clothed: bool, seed: int):
    """(30000, 3) scan points of the default body in library pose ``pose``, turned by a
    random yaw (seeded)."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    from dressmeup.body.synthetic import synthetic_scan
    from dressmeup.data.synth.garments import BodyFrame
    from dressmeup.data.synth.poses import pose_axis_angle

    params = model.default_params()
    frame = BodyFrame.from_joints(model.posed(params).joints, model.joint_names)
    params.pose[:] = pose_axis_angle(pose, model.joint_names, frame)
    yaw = np.random.default_rng(seed).uniform(-np.pi, np.pi)
    params.pose[0] = (Rotation.from_rotvec([0, yaw, 0]) *
                      Rotation.from_rotvec(params.pose[0])).as_rotvec()
    return synthetic_scan(model, params, n_points=30000, noise=0.002, n_holes=4,
                          hole_radius=0.06, seed=seed,
                          shell=(0.01, 0.03) if clothed else None)


def search(model, P, options: dict, seed: int) -> tuple[float, tuple]:
    """CPU seconds of one hypothesis search on scan ``P`` with registrar ``options``, and
    its winner ``(name, heading deg, score m)``."""
    from dressmeup.body.registration.optimizer import OptimizationRegistrar
    from dressmeup.body.registration.problem import FitProblem
    from dressmeup.body.registration.scan import prepare_scan

    reg = OptimizationRegistrar(verbose=False, seed=seed, **options)
    problem = FitProblem(reg, model, prepare_scan(P, reg.n_scan_points, seed), None)
    problem.set_params(shape=problem.default_shape)
    t = time.process_time()
    info = reg.search_hypotheses(problem)
    return time.process_time() - t, tuple(info["hypotheses_refined"][0])


def main(argv: list[str] | None = None) -> int:
    import torch

    from dressmeup.body import get_body_model

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--poses", default="walking,bowing,sitting",
                    help="comma list of pose-library names")
    ap.add_argument("--rounds", type=int, default=1, help="scans per pose and kind")
    ap.add_argument("--model", default="anny")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)  # as the registrar's fits run
    model = get_body_model(args.model)
    names = list(VARIANTS)
    print(f"{'scan':<22}" + "".join(f"{n:>20}" for n in names) + f"{'load':>6}")
    total = dict.fromkeys(names, 0.0)
    seed = 0
    for pose in (p for p in args.poses.split(",") if p):
        for clothed in (False, True):
            for _ in range(args.rounds):
                seed += 1
                P = scan_of(model, pose, clothed, seed)
                cells = []
                for n in names:
                    cpu, win = search(model, P, VARIANTS[n], seed)
                    total[n] += cpu
                    cells.append(f"{cpu:6.1f} s {win[0][:7]}@{win[1]:.0f}")
                label = f"{'clothed' if clothed else 'naked'}-{pose} {seed}"
                print(f"{label:<22}" + "".join(f"{c:>20}" for c in cells)
                      + f"{os.getloadavg()[0]:6.1f}", flush=True)
    base = total[names[0]]
    print(f"{'all (CPU s)':<22}" + "".join(f"{total[n]:20.1f}" for n in names)
          + f"{os.getloadavg()[0]:6.1f}")
    print(f"{'ratio to ' + names[0]:<22}" + "".join(f"{total[n] / base:20.2f}" for n in names))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
