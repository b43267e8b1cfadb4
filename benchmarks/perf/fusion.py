"""Fusion and garment-extraction accuracy and speed on synthetic captures of the default rig.

Renders the built-in mannequin with the default 7-camera ring (640x576 depth) with and
without sensor noise, fuses it (4 mm voxels), cuts out the garments, and scores everything
against the exact ground truth (docs/spec.md section 1, "Fusion quality": the ground truth is
restricted to the surface visible from >= 1 camera; completeness against the whole scan is
printed beside it). Then drifts the calibration (1 degree, 1 cm on every camera but the
reference) and fuses with and without multiway ICP refinement.

A last case corrupts the label masks like a 2D human-parsing model would (boundaries off
by up to 3 px, 3 wrongly labelled blobs per view).

Speed: TSDF fusion of one 7-view frame (VoxelBlockGrid, CPU) side by side with the named
alternative, open3d screened Poisson reconstruction of the same back-projected points.

Usage::

    python benchmarks/perf/fusion.py [--scale 1.0] [--samples 100000] [--json out.json]
    python benchmarks/perf/fusion.py --figures docs/images   # only the pictures of docs/fusion.md
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
    import warnings

    from dressmeup.extraction.labels import cluster_colors

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fc = cluster_colors(res.vertices, res.faces, res.colors, [g.label for g in subject.garments], up=rig_true.up)
    row["color_fallback_acc"] = round(face_label_accuracy(res.vertices, res.faces, fc, subject.vertices,
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
    """Best-of-``repeats`` wall and CPU seconds: TSDF alone, the whole fuse_frames, and Poisson."""
    import open3d as o3d

    from dressmeup.fusion.icp import backproject
    from dressmeup.fusion.pipeline import FusionConfig, fuse_frames, prepare_frames
    from dressmeup.fusion.tsdf import integrate_tsdf

    def best(fn):
        wall, cpu = [], []
        for _ in range(repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            fn()
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        return min(wall), min(cpu)

    prepared = prepare_frames(frames)  # they carry the rendering rig's cameras
    tsdf = best(lambda: integrate_tsdf(prepared, voxel_size=0.004))
    whole = best(lambda: fuse_frames(frames, rig, FusionConfig(voxel_size=0.004)))
    pts = [backproject(f) for f in prepared]
    P = np.concatenate([p for p, _ in pts])

    def poisson():
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(P))
        pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.012, max_nn=30))
        pcd.orient_normals_towards_camera_location(rig.target)
        pcd.normals = o3d.utility.Vector3dVector(-np.asarray(pcd.normals))
        o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(pcd, depth=9)

    return tsdf, whole, best(poisson) if repeats else (float("nan"), float("nan")), len(P)


def _view_camera(rig, width=360, height=540, azimuth_deg=25.0, distance=2.6):
    import math

    from dressmeup.capture.camera import Camera
    from dressmeup.capture.rig import look_at

    up = rig.up
    a = math.radians(azimuth_deg)
    e1 = np.cross(up, [1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.cross(up, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e1, up)
    eye = rig.target + 0.3 * up + distance * (math.cos(a) * e1 + math.sin(a) * e2)
    f = height / 2 / math.tan(math.radians(22))
    return Camera("view", width, height, f, f, (width - 1) / 2, (height - 1) / 2, look_at(eye, rig.target, up))


def _render(V, F, colors=None, color_fn=None, rig=None, cam=None):
    from dressmeup.capture.rig import Rig
    from dressmeup.capture.synthetic import SyntheticSubject, render_frames

    subj = SyntheticSubject(np.asarray(V), np.asarray(F), np.ones(len(F), np.uint8), [],
                            vertex_colors=colors, color_fn=color_fn)
    fr = render_frames(subj, Rig([cam]), None, light=cam.center - rig.target + rig.up)[0]
    img = fr.color.copy()
    img[fr.depth == 0] = 255
    return img


def _texture_fn(V, F, uv, uvf, tex):
    """Colour of surface points from a texture atlas (for rendering a textured garment)."""
    def fn(points, face_ids):
        tri = V[F[face_ids]]
        # barycentric coordinates of the points in their triangles
        v0, v1, v2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], points - tri[:, 0]
        d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
        d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
        den = np.maximum(d00 * d11 - d01 ** 2, 1e-20)
        b1 = (d11 * d20 - d01 * d21) / den
        b2 = (d00 * d21 - d01 * d20) / den
        b = np.stack([1 - b1 - b2, b1, b2], 1)
        t = np.einsum("kj,kjc->kc", b, uv[uvf[face_ids]])
        s = tex.shape[0]
        x = np.clip((t[:, 0] * s).astype(int), 0, s - 1)
        y = np.clip(((1 - t[:, 1]) * s).astype(int), 0, s - 1)
        return tex[y, x] / 255.0
    return fn


def make_figures(out_dir, scale=1.0) -> None:
    """Render the before/after pictures of docs/fusion.md into ``out_dir``."""
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dressmeup.capture.rig import perturb_rig, ring_rig
    from dressmeup.capture.session import SessionInfo
    from dressmeup.capture.synthetic import NoiseModel, make_mannequin, place_subject, render_frames
    from dressmeup.extraction.pipeline import ExtractionConfig, extract_garments
    from dressmeup.fusion.pipeline import FusionConfig, fuse_frames, prepare_frames
    from dressmeup.metrics.distance import distances_to

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rig = ring_rig(7, name="default-7").scaled(scale)
    subject, _ = place_subject(make_mannequin(), rig)
    frames = render_frames(subject, rig, NoiseModel(), seed=0)
    prepared = prepare_frames(frames)
    crop = np.s_[60:520, 200:440] if scale == 1.0 else np.s_[:, :]

    # 1. depth views: raw noisy vs filtered
    fig, ax = plt.subplots(2, 7, figsize=(14, 6.2))
    for k in range(7):
        for r, d in enumerate((frames[k].depth, prepared[k].depth)):
            img = np.where(d > 0, d, np.nan)[crop]
            ax[r, k].imshow(img, cmap="turbo", vmin=1.8, vmax=2.7)
            ax[r, k].set_axis_off()
        ax[0, k].set_title(rig.cameras[k].serial)
    ax[0, 0].text(-40, 230, "raw (noise, dropouts,\nflying pixels)", rotation=90, va="center", fontsize=9)
    ax[1, 0].text(-40, 230, "filtered", rotation=90, va="center", fontsize=9)
    fig.suptitle("Synthetic Kinect-like depth of the default 7-camera rig (1.8 m to 2.7 m)")
    fig.tight_layout()
    fig.savefig(out / "fusion-depth-views.png", dpi=80)
    plt.close(fig)

    # 2. fused mesh vs ground truth, error heat map
    res = fuse_frames(frames, rig, FusionConfig())
    cam = _view_camera(rig)
    gt_img = _render(subject.vertices, subject.faces, color_fn=subject.color_fn, rig=rig, cam=cam)
    fu_img = _render(res.vertices, res.faces, colors=res.colors, rig=rig, cam=cam)
    d = distances_to(res.vertices, (subject.vertices, subject.faces))
    cmap = plt.get_cmap("viridis")
    heat = (np.asarray(cmap(np.clip(d / 0.005, 0, 1)))[:, :3] * 255).astype(np.uint8)
    he_img = _render(res.vertices, res.faces, colors=heat, rig=rig, cam=cam)
    fig, ax = plt.subplots(1, 3, figsize=(10, 5.4))
    for a, img, t in zip(ax, (gt_img, fu_img, he_img),
                         ("ground truth", "TSDF fusion, 4 mm voxels", "distance to GT (0-5 mm)"), strict=True):
        a.imshow(img)
        a.set_title(t)
        a.set_axis_off()
    fig.tight_layout()
    fig.savefig(out / "fusion-mesh.png", dpi=80)
    plt.close(fig)

    # 3. drifted calibration before/after ICP
    drifted = perturb_rig(rig, 1.0, 0.01, seed=1)
    imgs = []
    for refine in (False, True):
        r = fuse_frames(frames, drifted, FusionConfig(refine=refine))
        imgs.append(_render(r.vertices, r.faces, colors=r.colors, rig=rig, cam=cam))
    fig, ax = plt.subplots(1, 2, figsize=(7, 5.4))
    for a, img, t in zip(ax, imgs, ("drifted calibration (1 deg, 1 cm)", "after multiway ICP"), strict=True):
        a.imshow(img)
        a.set_title(t)
        a.set_axis_off()
    fig.tight_layout()
    fig.savefig(out / "fusion-drift.png", dpi=80)
    plt.close(fig)

    # 4. labels and extracted garments, 5. texture
    info = SessionInfo("S00", "P0", subject.garments)
    ex = extract_garments(res, info, ExtractionConfig(target_faces=15000, texture_size=1024))
    palette = np.array([[128, 128, 128], [225, 180, 150], [40, 90, 200], [90, 60, 40]], np.uint8)
    vl = np.zeros(len(res.vertices), np.int64)
    for k in range(3):
        vl[res.faces[:, k]] = ex.face_labels
    lab_img = _render(res.vertices, res.faces, colors=palette[vl], rig=rig, cam=cam)
    g_imgs = [_render(g.vertices, g.faces, color_fn=_texture_fn(g.vertices, g.faces, g.uv, g.uv_faces, g.texture),
                      rig=rig, cam=cam) for g in ex.garments]
    fig, ax = plt.subplots(1, 1 + len(g_imgs), figsize=(3.4 * (1 + len(g_imgs)), 5.4))
    ax[0].imshow(lab_img)
    ax[0].set_title("voted labels (skin/top/trousers)")
    for a, img, g in zip(ax[1:], g_imgs, ex.garments, strict=True):
        a.imshow(img)
        a.set_title(f"{g.info.id}: cut out + baked texture")
    for a in ax:
        a.set_axis_off()
    fig.tight_layout()
    fig.savefig(out / "fusion-garment.png", dpi=80)
    plt.close(fig)
    fig, ax = plt.subplots(1, len(ex.garments), figsize=(5 * len(ex.garments), 5))
    for a, g in zip(np.atleast_1d(ax), ex.garments, strict=True):
        a.imshow(g.texture)
        a.set_title(f"{g.info.id} texture atlas (xatlas, {len(g.faces)} faces)")
        a.set_axis_off()
    fig.tight_layout()
    fig.savefig(out / "fusion-texture.png", dpi=80)
    plt.close(fig)


def _print_speed(frames, rig) -> None:
    (tw, tc), (fw, fc), (pw, pc), n_pts = _speed(frames, rig)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"\nSpeed, one 7-view frame ({n_pts} points), best of 3, load average {load:.1f} on "
          f"{os.cpu_count()} cores (wall s / CPU s):")
    print(f"| TSDF VoxelBlockGrid (integrate + mesh) | {tw:.2f} / {tc:.2f} |")
    print(f"| whole fuse_frames (filter + consistency + TSDF + cleanup) | {fw:.2f} / {fc:.2f} |")
    print(f"| alternative: open3d screened Poisson, depth 9, same points | {pw:.2f} / {pc:.2f} |")
    print(f"| ratio Poisson / TSDF (wall) | {pw / tw:.1f}x |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0, help="image size factor (1.0 = 640x576)")
    ap.add_argument("--samples", type=int, default=100_000)
    ap.add_argument("--json", default=None)
    ap.add_argument("--figures", default=None, help="render the docs pictures into this folder and stop")
    ap.add_argument("--speed-only", action="store_true", help="only the speed comparison")
    args = ap.parse_args(argv)
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")
    if args.figures:
        make_figures(args.figures, args.scale)
        return 0
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
    if args.speed_only:
        from dressmeup.capture.synthetic import render_frames

        _print_speed(render_frames(subject, rig, NoiseModel(), seed=0), rig)
        return 0
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
    # imperfect label masks, as a 2D human-parsing model gives them
    parsing = NoiseModel(mask_boundary_px=3, mask_blobs=3)
    row, _, _ = _score_case("noise+parsing-errors", subject, rig, rig, parsing, False, args.samples)
    rows.append(row)
    print(json.dumps(row), file=sys.stderr, flush=True)
    keys = ["case", "chamfer_l1_mm", "accuracy_mm", "completeness_mm", "completeness_all_mm",
            "fscore@1mm", "fscore@2mm", "fscore@5mm", "visible_fraction", "face_label_acc",
            "color_fallback_acc", "calib_err_mm_max", "fuse_s"]
    gkeys = sorted(k for k in rows[0] if k.startswith("G-"))
    print(f"\nFusion on the default rig ({rig.cameras[0].width}x{rig.cameras[0].height}, 7 cameras, "
          f"4 mm voxels; distances in mm vs GT visible from >= 1 camera)")
    print("| " + " | ".join(keys + gkeys) + " |")
    print("|" + "---|" * len(keys + gkeys))
    for r in rows:
        print("| " + " | ".join(str(r.get(k, "")) for k in keys + gkeys) + " |")
    _print_speed(frames_noisy, rig)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"rows": rows}, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
