"""Registration accuracy and speed on synthetic scans made from known parameters.

Scans: the model posed with random phenotype/yaw/translation, sampled (30k points),
2 mm Gaussian noise, 4 missing round patches (6 cm); "clothed" adds a smooth garment shell
1-3 cm off the skin over the torso. Standing/walking are fitted from the upright default
initialisation without keypoints; sitting/arms-raised get the true 3D joints as keypoints.
Reported per scenario: mean vertex error and mean joint error (mm) of the fit against the
truth, next to the same errors of the starting body (average shape, zero pose, centred on
the scan: the named alternative), and wall / CPU seconds per fit.

    python benchmarks/perf/registration.py                  # anny, 2 subjects per scenario
    python benchmarks/perf/registration.py --model procedural --subjects 1 --quick
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

SCENARIOS = [
    ("naked", "standing", False), ("naked", "walking", False),
    ("clothed", "standing", False), ("clothed", "walking", False),
    ("naked", "sitting", True), ("naked", "arms_raised", True),
    ("clothed", "sitting", True), ("clothed", "arms_raised", True),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="anny")
    parser.add_argument("--subjects", type=int, default=2, help="random bodies per scenario")
    parser.add_argument("--scenarios", default="", help="comma list of kind-pose, e.g. naked-standing")
    parser.add_argument("--quick", action="store_true", help="fewer iterations (smoke run)")
    parser.add_argument("--json", help="also write the rows to this JSON file")
    parser.add_argument("--naked-symmetric", action="store_true",
                        help="fit naked scans with the symmetric data term (inside_weight=1, "
                        "sigma_in=sigma_out; the CLI's --naked), as a user who knows the scan "
                        "is naked would")
    args = parser.parse_args()
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")

    import torch

    torch.set_num_threads(1)
    from dressmeup.body import BodyParams, get_body_model
    from dressmeup.body.registration import register
    from dressmeup.body.synthetic import named_pose, synthetic_scan, vertex_joint_errors

    t0 = time.perf_counter()
    model = get_body_model(args.model)
    print(f"model {model.name}: {model.n_vertices} vertices, ready in "
          f"{time.perf_counter() - t0:.1f} s")
    wanted = {s for s in args.scenarios.split(",") if s}
    options = dict(verbose=False)
    if args.quick:
        options["iterations"] = (20, 60, 60)
    rows = []
    header = (f"{'scenario':<22}{'kp':>4}{'vertex mm':>11}{'joint mm':>10}{'start v/j mm':>15}"
              f"{'ratio':>7}{'wall s':>8}{'cpu s':>7}")
    print(header)
    for kind, pose_name, with_kp in SCENARIOS:
        name = f"{kind}-{pose_name}"
        if wanted and name not in wanted:
            continue
        for subject in range(args.subjects):
            seed = 1000 + 17 * subject + SCENARIOS.index((kind, pose_name, with_kp))
            rng = np.random.default_rng(seed)
            shape = rng.uniform(0.2, 0.8, model.shape_dim) if model.shape_dim == 6 else \
                rng.normal(0, 1, model.shape_dim)
            pose = named_pose(pose_name, yaw=rng.uniform(-0.4, 0.4))
            truth = BodyParams(model.name, shape=shape, pose=pose, transl=rng.normal(0, 0.3, 3))
            scan = synthetic_scan(model, truth, n_points=30000, noise=0.002, n_holes=4,
                                  hole_radius=0.06,
                                  shell=(0.01, 0.03) if kind == "clothed" else None, seed=seed)
            kp = model.posed(truth).joints if with_kp else None
            wall, cpu = time.perf_counter(), time.process_time()
            opts = dict(options)
            if args.naked_symmetric and kind == "naked":
                opts.update(inside_weight=1.0, sigma_in=0.15)
            fit = register(scan, model, keypoints=kp, seed=seed, **opts)
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            v_err, j_err = vertex_joint_errors(model, fit, truth)
            start = model.default_params()
            start.transl = scan.mean(0) - model.posed(start).vertices.mean(0)
            v0, j0 = vertex_joint_errors(model, start, truth)
            row = dict(scenario=name, subject=subject, keypoints=with_kp,
                       vertex_mm=1000 * v_err, joint_mm=1000 * j_err, start_vertex_mm=1000 * v0,
                       start_joint_mm=1000 * j0, wall_s=wall, cpu_s=cpu)
            rows.append(row)
            print(f"{name:<22}{'yes' if with_kp else 'no':>4}{row['vertex_mm']:>11.1f}"
                  f"{row['joint_mm']:>10.1f}{row['start_vertex_mm']:>8.0f}/{row['start_joint_mm']:<6.0f}"
                  f"{v_err / v0:>7.2f}{wall:>8.1f}{cpu:>7.1f}", flush=True)
    print("\nmean per scenario (targets: naked <= 10 mm, clothed <= 20 mm vertex error, < 60 s)")
    for name in dict.fromkeys(r["scenario"] for r in rows):
        sel = [r for r in rows if r["scenario"] == name]
        v = np.mean([r["vertex_mm"] for r in sel])
        j = np.mean([r["joint_mm"] for r in sel])
        w = np.mean([r["wall_s"] for r in sel])
        c = np.mean([r["cpu_s"] for r in sel])
        target = 10 if name.startswith("naked") else 20
        ok = "met" if v <= target and w < 60 else "NOT met"
        print(f"{name:<22} vertex {v:6.1f} mm  joint {j:6.1f} mm  wall {w:5.1f} s  "
              f"cpu {c:5.1f} s  ({ok})")
    if args.json:
        from dressmeup.io.atomic import atomic_write_text

        atomic_write_text(args.json, json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
