"""Registration's nearest-point queries on scipy and on pykdtree, side by side in one run.

Every Adam step of a fit asks for the nearest scan point of each body point and the nearest
body point of each scan point; the hypothesis and limb searches score thousands of poses
the same way. These queries go through
``dressmeup.geometry.neighbors.NearestTree``: pykdtree when installed, scipy's cKDTree
otherwise. This script measures both on the same inputs, alternating:

1. the two queries of one step at the registrar's sizes (8,000 scan points, 5,000 body
   points, the body where the scan is, as near a fit's end), milliseconds per step;
2. whole fits (``register``, one thread, as the edition runs them) on synthetic scans:
   CPU seconds of each backend, their ratio, and the largest distance between the two
   fits' vertices (mm; 0 when the two backends find the same neighbours all along).

Scans: an anny body (default shape, turned by a random yaw) in library poses, 30,000 points
with 2 mm noise, naked or with a garment shell 1-3 cm off the torso (:func:`scan_of`).

    python benchmarks/perf/nearest_tree.py                       # walking, sitting x naked/clothed
    python benchmarks/perf/nearest_tree.py --poses t-pose --kinds naked
    python benchmarks/perf/nearest_tree.py --fits 0              # the step queries only
"""

from __future__ import annotations

import argparse
import os
import time

BACKENDS = ("scipy", "pykdtree")


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


def step_queries(P, Vb, rounds: int) -> dict[str, float]:
    """Milliseconds of one step's two queries (body -> scan on the scan's tree, scan -> body
    on a tree built from the body) per backend, over ``rounds`` alternating repetitions."""
    from dressmeup.geometry import neighbors

    out = dict.fromkeys(BACKENDS, 0.0)
    scan_trees = {}
    for be in BACKENDS:
        neighbors.BACKEND = be
        scan_trees[be] = neighbors.NearestTree(P)
    for _ in range(rounds):
        for be in BACKENDS:
            neighbors.BACKEND = be
            t = time.process_time()
            scan_trees[be].query(Vb)
            neighbors.NearestTree(Vb).query(P)
            out[be] += time.process_time() - t
    neighbors.BACKEND = None
    return {be: 1e3 * v / rounds for be, v in out.items()}


def fit(model, P, backend: str):
    """CPU seconds of one ``register`` on ``P`` with ``backend``, and the fit's vertices."""
    import numpy as np

    from dressmeup.body.registration import register
    from dressmeup.geometry import neighbors

    neighbors.BACKEND = backend
    try:
        t = time.process_time()
        params = register(P, model, verbose=False)
        cpu = time.process_time() - t
    finally:
        neighbors.BACKEND = None
    return cpu, np.asarray(model.posed(params).vertices)


def main(argv: list[str] | None = None) -> int:
    import numpy as np
    import torch

    from dressmeup.body import get_body_model
    from dressmeup.body.registration.config import get_config
    from dressmeup.body.registration.scan import prepare_scan
    from dressmeup.geometry import neighbors

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--poses", default="walking,sitting", help="comma list of pose-library names")
    ap.add_argument("--kinds", default="naked,clothed", help="naked, clothed or both")
    ap.add_argument("--fits", type=int, default=1, help="scans per pose and kind (0: none)")
    ap.add_argument("--rounds", type=int, default=200, help="repetitions of the step queries")
    ap.add_argument("--model", default="anny")
    args = ap.parse_args(argv)
    if neighbors._pykdtree_class() is None:
        print("pykdtree is not installed: nothing to compare (pip install pykdtree)")
        return 1
    torch.set_num_threads(1)  # as the registrar's fits run
    model = get_body_model(args.model)
    data = get_config().data

    # a clothed scan and, as the body points, points of the same body naked (a fit near its end)
    P = prepare_scan(scan_of(model, "walking", True, 0), data.n_scan_points, 0)
    Vb = prepare_scan(scan_of(model, "walking", False, 0), data.n_body_points, 1)
    ms = step_queries(P, Vb, args.rounds)
    print(f"one step's queries ({data.n_scan_points} scan, {data.n_body_points} body points): "
          + ", ".join(f"{be} {ms[be]:.2f} ms" for be in BACKENDS)
          + f", ratio {ms['pykdtree'] / ms['scipy']:.2f}, load {os.getloadavg()[0]:.1f}")
    if args.fits <= 0:
        return 0

    print(f"{'scan':<22}{'scipy (CPU s)':>15}{'pykdtree':>10}{'ratio':>7}{'diff mm':>9}"
          f"{'load':>6}")
    total = dict.fromkeys(BACKENDS, 0.0)
    seed = 0
    for pose in (p for p in args.poses.split(",") if p):
        for kind in (k for k in args.kinds.split(",") if k):
            for _ in range(args.fits):
                seed += 1
                scan = scan_of(model, pose, kind == "clothed", seed)
                cpu, verts = {}, {}
                for be in BACKENDS:
                    cpu[be], verts[be] = fit(model, scan, be)
                    total[be] += cpu[be]
                diff = 1e3 * float(np.abs(verts["scipy"] - verts["pykdtree"]).max())
                print(f"{kind + '-' + pose + ' ' + str(seed):<22}{cpu['scipy']:15.1f}"
                      f"{cpu['pykdtree']:10.1f}{cpu['pykdtree'] / cpu['scipy']:7.2f}"
                      f"{diff:9.3f}{os.getloadavg()[0]:6.1f}", flush=True)
    print(f"{'all':<22}{total['scipy']:15.1f}{total['pykdtree']:10.1f}"
          f"{total['pykdtree'] / total['scipy']:7.2f}{'':>9}{os.getloadavg()[0]:6.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
