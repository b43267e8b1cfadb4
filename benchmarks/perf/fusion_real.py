"""Fusion of a moving sensor's frames against Open3D's own integration of the same frames and poses.

Two sources:

- a session imported from a real dataset (``dressmeup import-capture tum|7scenes|redwood|
  arkitscenes SRC --out SESSION --frames ...``): ``--session SESSION``;
- without ``--session``, a synthetic one: a VGA Kinect v1-like sensor walking on an arc
  through a room (floor, walls, boxes, the mannequin; ``capture.synthetic.scene``) with the
  synthetic generator's sensor noise, written as a session; it also has exact ground truth.

For each, it times and scores:

- ``open3d``: ``fusion.evaluate.open3d_reference_mesh``, Open3D's VoxelBlockGrid integration
  of the raw frames with the session's poses, every observed voxel meshed (the reference),
  timed also with colour integrated (what a coloured scan costs);
- ``dressmeup``: ``fuse_session`` (filtering, TSDF, cleanup) with the default rule (voxels seen
  by >= 1 frame) and, for comparison, the former rule (weight strictly above 1);
- ``dressmeup --refine``: the same with refinement (the poses it keeps, and why it refused);
- on the synthetic source, also a drifted calibration (1 degree / 1 cm on every frame but the
  first) with and without refinement, and accuracy / completeness against the ground truth.

F@10mm and its precision / recall compare each dressmeup mesh with the Open3D mesh (200,000
samples each). Run timings on a quiet machine (nothing else heavy running) and
print the load beside them.

Speed, side by side (``--speed-only`` runs only this): ``fuse_session`` with the defaults and
Open3D's coloured integration of the same frames (``open3d_reference_mesh(color=True)``),
alternated ``--repeats`` times in one run, best wall and CPU seconds of each, their ratio and
the load average beside every figure; ``fuse_session``'s own step timings. ``--save-scan DIR``
writes the default scan (``save_scan``); ``--previous DIR`` scores it against a scan written
before (F@10mm, F@1mm: did a change of the pipeline change its output?).

Usage::

    python benchmarks/perf/fusion_real.py [--frames 12] [--voxel 0.004] [--json out.json]
    python benchmarks/perf/fusion_real.py --session sessions/fr1-desk [--json out.json]
    python benchmarks/perf/fusion_real.py --speed-only [--previous OLD_SCAN] [--save-scan NEW_SCAN]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _timed(fn):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, round(time.perf_counter() - t0, 2), round(time.process_time() - c0, 2)


def _synthetic_session(out: Path, n_frames: int, seed: int) -> Path:
    from dressmeup.capture.session import SessionInfo, write_frame, write_session
    from dressmeup.capture.synthetic import NoiseModel, render_frames
    from dressmeup.capture.synthetic.scene import make_room, walk_rig

    scene = make_room(seed=seed)
    rig = walk_rig(n_frames)
    write_session(out, rig, SessionInfo("room", "P0", garments=list(scene.garments)))
    for fr in render_frames(scene, rig, NoiseModel(), seed=seed):
        write_frame(out, fr)
    np.savez(out / "scene_truth.npz", vertices=scene.vertices, faces=scene.faces)
    return out


def _score(mesh, ref, samples):
    from dressmeup.metrics import fusion_quality

    q = fusion_quality(mesh, ref, thresholds=(0.005, 0.01), n_samples=samples, seed=0)
    return {"F@10mm": round(q.fscore[0.01], 4), "precision@10mm": round(q.precision[0.01], 4),
            "recall@10mm": round(q.recall[0.01], 4), "F@5mm": round(q.fscore[0.005], 4)}


def _truth(mesh, truth, samples):
    from dressmeup.metrics import fusion_quality

    q = fusion_quality(mesh, truth, thresholds=(0.01,), n_samples=samples, seed=0)
    # completeness is left out: most of the room (ceiling, the walls behind the sensor) is unseen
    return {"accuracy_mm": round(1000 * q.accuracy, 2), "precision_vs_truth@10mm": round(q.precision[0.01], 4)}


def _speed(session, frames, voxel, repeats):
    """Best wall / CPU seconds of fuse_session and of Open3D's coloured integration, alternated."""
    from dressmeup.fusion.evaluate import open3d_reference_mesh
    from dressmeup.fusion.pipeline import FusionConfig, fuse_session

    cfg = FusionConfig(voxel_size=voxel)
    best = {"open3d": [np.inf, np.inf, 0.0], "dressmeup": [np.inf, np.inf, 0.0]}
    steps: dict[str, float] = {}
    result = None
    for _ in range(repeats):
        for name in ("open3d", "dressmeup"):
            if name == "open3d":
                _, wall, cpu = _timed(lambda: open3d_reference_mesh(frames, voxel, 5.0, 5.0, color=True))
            else:
                result, wall, cpu = _timed(lambda: fuse_session(session, cfg))
                steps = {k: min(v, steps.get(k, np.inf)) for k, v in result.timings.items()}
            load = os.getloadavg()[0]
            print(f"{name}: {wall:.2f} s wall, {cpu:.2f} s CPU, load {load:.2f}", file=sys.stderr, flush=True)
            b = best[name]
            b[0], b[1] = min(b[0], wall), min(b[1], cpu)
            b[2] = max(b[2], load)
    return best, steps, result


def _print_speed(best, steps, n_frames, args, previous):
    o, d = best["open3d"], best["dressmeup"]
    print(f"\nSpeed, {n_frames} frames, {1000 * args.voxel:g} mm voxels, best of {args.repeats} "
          f"alternated runs, {os.cpu_count()} cores:")
    print("| | wall s | CPU s | highest load average during its runs |")
    print("|---|---|---|---|")
    print(f"| Open3D VoxelBlockGrid, colour integrated | {o[0]:.2f} | {o[1]:.2f} | {o[2]:.2f} |")
    print(f"| dressmeup fuse_session | {d[0]:.2f} | {d[1]:.2f} | {d[2]:.2f} |")
    print(f"| ratio dressmeup / Open3D | {d[0] / o[0]:.2f} | {d[1] / o[1]:.2f} | |")
    print("fuse_session steps (best, wall s): " + ", ".join(f"{k} {v:.2f}" for k, v in steps.items()))
    if previous is not None:
        print(f"against the previous scan: F@10mm {previous['F@10mm']}, F@1mm {previous['F@1mm']}, "
              f"faces {previous['faces_before']} -> {previous['faces']}")


def _against_previous(result, previous_dir, samples):
    from dressmeup.fusion.pipeline import load_scan
    from dressmeup.metrics import fusion_quality

    V, F, _ = load_scan(previous_dir)
    q = fusion_quality((result.vertices, result.faces), (V, F), thresholds=(0.001, 0.01), n_samples=samples, seed=0)
    return {"F@10mm": round(q.fscore[0.01], 4), "F@1mm": round(q.fscore[0.001], 4),
            "faces_before": len(F), "faces": len(result.faces)}


def _fuse_row(name, session, cfg, ref, samples, truth=None, rig=None):
    from dressmeup.fusion.pipeline import fuse_frames, fuse_session

    if rig is None:
        res, wall, cpu = _timed(lambda: fuse_session(session, cfg))
    else:
        frames = [fr for i in range(session.info.n_frames) for fr in session.load_frames(i)]
        res, wall, cpu = _timed(lambda: fuse_frames(frames, rig, cfg))
    row = {"case": name, "wall_s": wall, "cpu_s": cpu, "faces": len(res.faces), **_score((res.vertices, res.faces), ref, samples)}
    if truth is not None:
        row.update(_truth((res.vertices, res.faces), truth, samples))
    if res.icp is not None:
        r = res.icp
        row["refine_s"] = round(r.seconds, 2)
        row["moved"] = sorted(s for s, v in r.corrections.items() if v != (0.0, 0.0))
        row["refused"] = len(r.refused)
        before = [v for v in r.residual_before_mm.values() if np.isfinite(v)]
        after = [v for v in r.residual_after_mm.values() if np.isfinite(v)]
        row["residual_median_mm"] = f"{np.median(before):.2f} -> {np.median(after):.2f}" if before else ""
        row["largest_proposal_deg_mm"] = max(((round(d, 2), round(1000 * m, 1)) for d, m in r.proposed.values()),
                                             default=(0, 0))
    print(json.dumps(row), file=sys.stderr, flush=True)
    return row


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--session", default=None, help="an imported real session (default: a synthetic walk)")
    p.add_argument("--frames", type=int, default=12, help="synthetic frames (default 12)")
    p.add_argument("--voxel", type=float, default=0.004)
    p.add_argument("--samples", type=int, default=200_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", default=None)
    p.add_argument("--repeats", type=int, default=2, help="alternated speed runs (default 2)")
    p.add_argument("--speed-only", action="store_true", help="only the side-by-side speed comparison")
    p.add_argument("--save-scan", default=None, help="write the default scan into this folder")
    p.add_argument("--previous", default=None, help="a scan folder written before: F-scores against it")
    args = p.parse_args(argv)
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")

    from dressmeup.capture.rig import perturb_rig
    from dressmeup.capture.session import open_session
    from dressmeup.fusion.evaluate import open3d_reference_mesh
    from dressmeup.fusion.pipeline import FusionConfig

    tmp = None
    if args.session is None:
        tmp = tempfile.TemporaryDirectory()
        folder, _, _ = _timed(lambda: _synthetic_session(Path(tmp.name) / "walk", args.frames, args.seed))
    else:
        folder = Path(args.session)
    session = open_session(folder)
    frames = [fr for i in range(session.info.n_frames) for fr in session.load_frames(i)]
    truth = None
    if (folder / "scene_truth.npz").is_file():
        z = np.load(folder / "scene_truth.npz")
        truth = (z["vertices"], z["faces"])
    best, steps, result = _speed(session, frames, args.voxel, args.repeats)
    previous = None if args.previous is None else _against_previous(result, args.previous, args.samples)
    if args.save_scan:
        from dressmeup.fusion.pipeline import save_scan

        save_scan(result, args.save_scan)
    if args.speed_only:
        _print_speed(best, steps, len(frames), args, previous)
        if args.json:
            Path(args.json).write_text(json.dumps({"session": str(folder), "frames": len(frames), "speed": best,
                                                   "steps": steps, "previous": previous}, indent=2))
        if tmp is not None:
            tmp.cleanup()
        return 0
    ref, wall, cpu = _timed(lambda: open3d_reference_mesh(frames, args.voxel, 5.0, 5.0))
    rows = [{"case": "open3d (reference)", "wall_s": wall, "cpu_s": cpu, "faces": len(ref[1])}]
    if truth is not None:
        rows[0].update(_truth(ref, truth, args.samples))
    _, wall, cpu = _timed(lambda: open3d_reference_mesh(frames, args.voxel, 5.0, 5.0, color=True))
    rows.append({"case": "open3d with colour (time only)", "wall_s": wall, "cpu_s": cpu})
    cfg = FusionConfig(voxel_size=args.voxel)
    rows.append(_fuse_row("dressmeup", session, cfg, ref, args.samples, truth))
    rows.append(_fuse_row("dressmeup, former rule (weight > 1)", session,
                          FusionConfig(voxel_size=args.voxel, min_weight=2.0), ref, args.samples, truth))
    rows.append(_fuse_row("dressmeup --refine", session, FusionConfig(voxel_size=args.voxel, refine=True),
                          ref, args.samples, truth))
    if truth is not None:
        drifted = perturb_rig(session.rig, 1.0, 0.01, seed=1)
        rows.append(_fuse_row("drifted 1 deg / 1 cm", session, cfg, ref, args.samples, truth, rig=drifted))
        rows.append(_fuse_row("drifted 1 deg / 1 cm, --refine", session,
                              FusionConfig(voxel_size=args.voxel, refine=True), ref, args.samples, truth, rig=drifted))
    keys = ["case", "wall_s", "cpu_s", "faces", "F@10mm", "precision@10mm", "recall@10mm", "F@5mm",
            "accuracy_mm", "precision_vs_truth@10mm", "refine_s", "residual_median_mm", "refused", "largest_proposal_deg_mm"]
    c0 = session.rig.cameras[0]
    print(f"\n{folder.name}: {len(frames)} frames {c0.width}x{c0.height}, {1000 * args.voxel:g} mm voxels; "
          f"F-scores against Open3D's integration of the same frames and poses; load {os.getloadavg()[0]:.2f}")
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for r in rows:
        print("| " + " | ".join(str(r.get(k, "")) for k in keys) + " |")
    _print_speed(best, steps, len(frames), args, previous)
    if args.json:
        Path(args.json).write_text(json.dumps({"session": str(folder), "frames": len(frames), "rows": rows,
                                               "speed": best, "steps": steps, "previous": previous,
                                               "load": os.getloadavg()}, indent=2, default=str))
    if tmp is not None:
        tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
