"""Fusion and garment-extraction accuracy and speed on synthetic captures of the default rig.

Renders the built-in mannequin with the default 7-camera ring (640x576 depth) with and
without sensor noise, fuses it (4 mm voxels), cuts out the garments, and scores everything
against the exact ground truth (SPEC.md section 1, "Fusion quality": the ground truth is
restricted to the surface visible from >= 1 camera; completeness against the whole scan is
printed beside it). Then drifts the calibration (1 degree, 1 cm on every camera but the
reference) and fuses with and without multiway ICP refinement.

Speed: TSDF fusion of one 7-view frame (VoxelBlockGrid, CPU) side by side with the named
alternative, open3d screened Poisson reconstruction of the same back-projected points.

Usage::

    python benchmarks/perf/fusion.py [--scale 1.0] [--samples 100000] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np


def _score_case(name, subject, rig_true, rig_used, noise, refine, samples, seed=0):
    from dressmeup.capture.synthetic import render_frames
    from dressmeup.extraction.cutout import cut_garment
    from dressmeup.extraction.labels import label_mesh
    from dressmeup.fusion.evaluate import extrinsic_errors, face_label_accuracy, score_surface
    from dressmeup.fusion.pipeline import FusionConfig, fuse_frames

    frames = render_frames(subject, rig_true, noise, seed=seed)
    t0 = time.perf_counter()
    res = fuse_frames(frames, rig_used, FusionConfig(voxel_size=0.004, refine=refine))
    wall = time.perf_counter() - t0
    row = {"case": name}
    s = score_surface(res.vertices, res.faces, subject.vertices, subject.faces, rig_true, n_samples=samples)
    row.update({k: round(v, 4) for k, v in s.as_dict().items()})
    cal = extrinsic_errors(res.rig, rig_true, subject.vertices[::20])
    row["calib_err_mm_max"] = round(1000 * max(cal.values()), 3)
    row["fuse_s"] = round(wall, 2)
    row.update({f"t_{k}_s": round(v, 2) for k, v in res.timings.items()})
    n_labels = int(subject.face_labels.max()) + 1
    fl = label_mesh(res.vertices, res.faces, res.frames, res.rig, n_labels)
    row["face_label_acc"] = round(face_label_accuracy(res.vertices, res.faces, fl, subject.vertices,
                                                      subject.faces, subject.face_labels), 4)
    for g in subject.garments:
        V, F, _ = cut_garment(res.vertices, res.faces, fl, g.label)
        gs = score_surface(V, F, subject.vertices, subject.faces, rig_true, n_samples=samples // 2,
                           gt_face_mask=subject.face_labels == g.label)
        row[f"{g.id}_chamfer_l1_mm"] = round(1000 * gs.chamfer_l1, 3)
        row[f"{g.id}_completeness_all_mm"] = round(1000 * gs.completeness_all, 3)
        row[f"{g.id}_fscore@5mm"] = round(gs.fscore[0.005], 4)
    return row, frames, res


def _speed(frames, rig, repeats=3):
    import open3d as o3d

    from dressmeup.fusion.icp import backproject
    from dressmeup.fusion.pipeline import prepare_frames
    from dressmeup.fusion.tsdf import integrate_tsdf

    prepared = prepare_frames(frames, rig)
    tsdf = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        integrate_tsdf(prepared, rig, voxel_size=0.004)
        tsdf.append(time.perf_counter() - t0)
    pts = [backproject(f, rig) for f in prepared]
    P = np.concatenate([p for p, _ in pts])
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(P))
    t0 = time.perf_counter()
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.012, max_nn=30))
    pcd.orient_normals_towards_camera_location(rig.target)
    pcd.normals = o3d.utility.Vector3dVector(-np.asarray(pcd.normals))
    o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pcd, depth=9)
    poisson = time.perf_counter() - t0
    return min(tsdf), poisson, len(P)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0, help="image size factor (1.0 = 640x576)")
    ap.add_argument("--samples", type=int, default=100_000)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass

    from dressmeup.capture.rig import perturb_rig, ring_rig
    from dressmeup.capture.synthetic import NoiseModel, make_mannequin, place_subject

    rig = ring_rig(7, name="default-7")
    if args.scale != 1.0:
        rig = rig.scaled(args.scale)
    subject, _ = place_subject(make_mannequin(), rig)
    drifted = perturb_rig(rig, 1.0, 0.01, seed=1)
    rows = []
    frames_noisy = None
    for noise_on in (False, True):
        noise = NoiseModel(enabled=noise_on)
        tag = "noise" if noise_on else "clean"
        for name, used, refine in ((f"{tag}", rig, False), (f"{tag}+drift", drifted, False),
                                   (f"{tag}+drift+ICP", drifted, True)):
            row, frames, _ = _score_case(name, subject, rig, used, noise, refine, args.samples)
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
            if noise_on:
                frames_noisy = frames
    keys = ["case", "chamfer_l1_mm", "accuracy_mm", "completeness_mm", "completeness_all_mm",
            "fscore@1mm", "fscore@2mm", "fscore@5mm", "visible_fraction", "face_label_acc",
            "calib_err_mm_max", "fuse_s"]
    gkeys = sorted(k for k in rows[0] if k.startswith("G-"))
    print(f"\nFusion on the default rig ({rig.cameras[0].width}x{rig.cameras[0].height}, 7 cameras, "
          f"4 mm voxels; distances in mm vs GT visible from >= 1 camera)")
    print("| " + " | ".join(keys + gkeys) + " |")
    print("|" + "---|" * len(keys + gkeys))
    for r in rows:
        print("| " + " | ".join(str(r.get(k, "")) for k in keys + gkeys) + " |")
    t_tsdf, t_poisson, n_pts = _speed(frames_noisy, rig)
    print(f"\nSpeed, one 7-view frame ({n_pts} points): TSDF VoxelBlockGrid CPU {t_tsdf:.2f} s | "
          f"open3d screened Poisson (depth 9, same points) {t_poisson:.2f} s | ratio Poisson/TSDF "
          f"{t_poisson / t_tsdf:.1f}x")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"rows": rows, "tsdf_s": t_tsdf, "poisson_s": t_poisson}, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
