"""Does ``--refine`` keep good poses on Kinect v1-like data, and still fix a drift?

A synthetic sensor walks an arc through a room (``capture.synthetic.scene``: ``kitchen``, a
counter, shelves, a table and a cupboard; or ``room``, boxes and the mannequin) with the
Kinect v1 noise preset (``NoiseModel.kinect_v1``: axial noise growing with depth, disparity
steps, radial depth distortion). For each starting calibration

- ``accurate``: the true poses,
- ``jitter``: every frame but the first off by 0.25 degree / 5 mm (a dataset's poses),
- ``drift``: every frame but the first off by 1 degree / 1 cm,

it refines the poses (``fusion.refine.refine_extrinsics``, default settings; with
``--compare-old`` also without the significance rule, ``min_shift_sigma=0``) and prints per
case the largest change refinement made to a camera, the largest camera error against the
truth before and after, how many cameras moved, and the F-score at 10 mm of the fused scan
(TSDF, 4 mm voxels, no cleanup) against the ground truth visible from the cameras, before
and after.

Usage::

    python benchmarks/perf/refine_kinect.py [--scene kitchen|room] [--frames 12] [--sweep 60]
        [--radius 1.6] [--seed 1] [--cases accurate,jitter,drift] [--compare-old] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path


def _errors(rig, truth):
    from dressmeup.fusion.icp import pose_difference

    errs = [pose_difference(truth.camera(s).camera_to_world, rig.camera(s).camera_to_world) for s in truth.serials]
    return round(max(e[0] for e in errs), 3), round(1000 * max(e[1] for e in errs), 1)


def _fscore(frames, rig, scene, truth, samples):
    from dressmeup.capture.frame import with_rig_cameras
    from dressmeup.fusion.evaluate import score_surface
    from dressmeup.fusion.pipeline import FusionConfig, fuse_frames

    res = fuse_frames(with_rig_cameras(frames, rig), None, FusionConfig(cleanup=None))
    q = score_surface(res.vertices, res.faces, scene.vertices, scene.faces, truth, n_samples=samples,
                      thresholds=(0.01,))
    return round(q.fscore[0.01], 4)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", choices=["kitchen", "room"], default="kitchen")
    p.add_argument("--frames", type=int, default=12)
    p.add_argument("--sweep", type=float, default=60.0, help="the walk's arc, degrees")
    p.add_argument("--radius", type=float, default=1.6, help="the walk's radius, metres")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--cases", default="accurate,jitter,drift")
    p.add_argument("--samples", type=int, default=100_000)
    p.add_argument("--compare-old", action="store_true", help="also refine without the significance rule")
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")

    from dressmeup.capture.frame import with_rig_cameras
    from dressmeup.capture.rig import perturb_rig
    from dressmeup.capture.synthetic import NoiseModel, render_frames
    from dressmeup.capture.synthetic.scene import make_kitchen, make_room, walk_rig
    from dressmeup.fusion.icp import ICPConfig, pose_difference
    from dressmeup.fusion.pipeline import prepare_frames
    from dressmeup.fusion.refine import refine_extrinsics

    scene = make_kitchen() if args.scene == "kitchen" else make_room(seed=args.seed)
    truth = walk_rig(args.frames, radius=args.radius, sweep_deg=args.sweep)
    raw = render_frames(scene, truth, NoiseModel.kinect_v1(), seed=args.seed)
    frames = prepare_frames(raw)
    starts = {"accurate": truth, "jitter": perturb_rig(truth, 0.25, 0.005, seed=args.seed + 1),
              "drift": perturb_rig(truth, 1.0, 0.01, seed=args.seed + 1)}
    rules = {"significance + margin": ICPConfig()}
    if args.compare_old:
        rules["margin only (former rule)"] = ICPConfig(min_shift_sigma=0.0)
    rows = []
    for case in args.cases.split(","):
        start = starts[case]
        f_before = _fscore(raw, start, scene, truth, args.samples)
        for name, cfg in rules.items():
            cams, report = refine_extrinsics(with_rig_cameras(frames, start), cfg, reference=truth.reference)
            refined = start.with_cameras(list(cams.values()))
            change = [pose_difference(start.camera(s).camera_to_world, cams[s].camera_to_world) for s in truth.serials]
            sig = list(report.significance.values())
            row = {"case": case, "rule": name,
                   "moved": sum(1 for v in report.corrections.values() if v != (0.0, 0.0)),
                   "max_change_deg_mm": (round(max(c[0] for c in change), 3), round(1000 * max(c[1] for c in change), 1)),
                   "error_before_deg_mm": _errors(start, truth), "error_after_deg_mm": _errors(refined, truth),
                   "F@10mm_before": f_before, "F@10mm_after": _fscore(raw, refined, scene, truth, args.samples),
                   "significance": f"{min(sig):.2f}-{max(sig):.2f}" if sig else "",
                   "refine_s": round(report.seconds, 1)}
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    keys = list(rows[0]) if rows else []
    print(f"\n{args.scene}: {args.frames} VGA frames on a {args.sweep:g} degree arc of radius {args.radius:g} m, "
          f"Kinect v1 noise, seed {args.seed}; errors are the largest over cameras; load {os.getloadavg()[0]:.2f}")
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for r in rows:
        print("| " + " | ".join(str(r[k]) for k in keys) + " |")
    if args.json:
        Path(args.json).write_text(json.dumps({"args": vars(args), "rows": rows, "load": os.getloadavg()}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
