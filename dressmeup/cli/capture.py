"""Subcommands of the capture stage: ``synth-capture``, ``import-capture``, ``validate-session``,
``fuse``, ``build-dataset``.

``build-dataset`` chains the library stages for each session (fuse -> extract garments ->
UV + texture -> body registration -> DatasetWriter); a session that fails is reported and
skipped, and a re-run skips the samples already in the dataset.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from dressmeup.cli.checks import device, integer, new_output, number, seed
from dressmeup.cli.executor_args import add_executor_args, executor_from_args
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.limits import FRAMES, IMAGE_PIXELS, MESH_FACES

#: Smallest TSDF voxel (metres): a person's surface at 0.5 mm is about 16 million voxels.
MIN_VOXEL_M = 0.0005
#: Deepest screened Poisson octree (2^14 cells a side; each level about 4x the faces).
MAX_POISSON_DEPTH = 14


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register ``synth-capture``, ``import-capture``, ``validate-session``, ``fuse`` and
    ``build-dataset``."""
    p = subparsers.add_parser(
        "synth-capture", help="render a synthetic multi-view RGBD capture session with exact ground truth",
        description="Render colour, depth and label masks of a clothed person from every camera of "
                    "a rig (open3d ray casting) with a Kinect-like noise model. SAMPLE is a dataset "
                    "sample folder (samples/<subject>/<garment>/<pose>, with scan.ply and garment "
                    "meshes) or 'mannequin' for the built-in procedural subject.")
    p.add_argument("sample", help="dataset sample folder, or 'mannequin'")
    p.add_argument("--rig", default="default-7",
                   help="rig.json path, or 'default-7' (7 Azure-Kinect-like cameras, 640x576)")
    p.add_argument("--out", required=True, type=new_output, help="session folder to write")
    p.add_argument("--no-noise", action="store_true", help="exact depth (only quantised to 1 mm)")
    p.add_argument("--frames", type=integer(1), default=1,
                   help="frames per camera (fresh noise each)")
    p.add_argument("--perturb-deg", type=number(0.0, 180.0), default=0.0,
                   help="write a drifted calibration: rotate every camera but the reference by this many degrees")
    p.add_argument("--perturb-cm", type=number(0.0, 100.0), default=0.0,
                   help="... and shift it by this many centimetres")
    p.add_argument("--scale", type=number(0.05, 16.0), default=1.0,
                   help="image size factor, 0.05 to 16 (0.5: 320x288)")
    p.add_argument("--subject-up", default="auto", choices=("auto", "x", "y", "z"),
                   help="the subject's up axis: auto, x, y or z")
    p.add_argument("--seed", type=seed, default=0)
    p.set_defaults(func=_synth_capture, locks=("out",))
    _register_import(subparsers)

    p = subparsers.add_parser(
        "fuse", help="fuse a capture session into a coloured scan (TSDF)",
        description="Filter depth, optionally refine the extrinsics by multiway ICP, fuse with a "
                    "TSDF (open3d VoxelBlockGrid) and clean the mesh. Writes SCAN_DIR/scan.ply, "
                    "rig.json (the calibration used) and fusion.json; with --garments also "
                    "SCAN_DIR/garments/<id>/garment.obj (+ .mtl, .png).")
    p.add_argument("session", help="capture session folder (rig.json, session.json, frames)")
    p.add_argument("--out", required=True, type=new_output, help="scan folder to write")
    _fusion_args(p)
    p.add_argument("--garments", action="store_true", help="also cut out, UV-map and texture each garment")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a scan already in --out (default: refuse)")
    p.set_defaults(func=_fuse, locks=("out",))

    p = subparsers.add_parser(
        "build-dataset", help="turn capture sessions into a DressMeUp-style dataset",
        description="For each session: fuse, extract and texture the garments, register the body, "
                    "and write one dataset sample per garment. Resumable: samples already in ROOT "
                    "are skipped. A session that fails is reported and skipped.")
    p.add_argument("sessions", nargs="+", help="session folders, or folders containing sessions")
    p.add_argument("--out", required=True, type=new_output, help="dataset root")
    p.add_argument("--scans", default=None,
                   help="folder of scans made by 'dressmeup fuse' (SCANS/<session name>/"
                        "scan.ply): those sessions are not fused again")
    _fusion_args(p)
    p.add_argument("--body", default="auto", choices=["auto", "register", "session", "ground-truth", "none"],
                   help="body source: 'register' fits the body model to the scan; 'session' reads "
                        "SESSION/body.npz (an external fit, in the rig frame); 'ground-truth' uses a "
                        "synthetic session's true body (samples are then written in its frame); 'auto' "
                        "tries register, then session, then ground-truth, then none")
    p.add_argument("--body-model", default="anny",
                   choices=("anny", "procedural", "smpl", "smplh", "smplx"),
                   help="body model for registration")
    p.add_argument("--split", default="train", choices=("train", "val", "test"),
                   help="split of the garments written")
    p.add_argument("--name", default="captured", help="dataset name in dataset.json")
    p.add_argument("--target-faces", type=integer(1), default=20000,
                   help="garment face count (decimation)")
    p.add_argument("--texture-size", type=integer(1), default=1024)
    p.add_argument("--no-texture", action="store_true")
    add_executor_args(p, default_workers=1, what="session")
    p.set_defaults(func=_build_dataset, locks=("out",))


def _register_import(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "import-capture", help="import an RGB-D dataset folder (TUM, 7-Scenes, Redwood, ARKitScenes) as a session",
        description="Write a capture session from a public RGB-D dataset's folder: one camera per frame "
                    "(a moving sensor), the dataset's intrinsics and depth unit, its poses turned into "
                    "OpenCV camera-to-world matrices. Layouts and conventions: docs/capture-format.md. "
                    "Poses within 2e-3 of orthonormal are re-orthonormalised and reported; worse ones are "
                    "refused, all listed.")
    p.add_argument("format", choices=["tum", "7scenes", "redwood", "open3d-log", "arkitscenes"],
                   help="the dataset's layout (open3d-log: the same as redwood)")
    p.add_argument("src", help="the dataset folder (a TUM sequence, a 7-Scenes seq-XX, a Redwood/Open3D "
                               "folder, an ARKitScenes scan)")
    p.add_argument("--out", required=True, type=new_output, help="session folder to write")
    p.add_argument("--frames", default=None,
                   help="which frames (of those with a pose): 'all' (default), a slice 'start:stop:step' "
                        "('::10': every 10th) or a list '0,15,30'")
    p.add_argument("--intrinsics", default=None, help="fx,fy,cx,cy in pixels instead of the dataset's own")
    p.add_argument("--max-time-diff", type=number(0.0, 3600.0), default=None,
                   help="seconds between an image and its pose (default: TUM 0.02, ARKitScenes 0.05)")
    p.add_argument("--trajectory", default=None, help="Redwood: the .log trajectory (default: the only one)")
    p.add_argument("--subject", default=None, help="subject id in session.json (default: the folder name)")
    p.add_argument("--pose", default="P0", help="pose id in session.json (default P0)")
    p.add_argument("--overwrite", action="store_true", help="write into an existing session folder")
    p.set_defaults(func=_import_capture, locks=("out",))

    p = subparsers.add_parser(
        "validate-session", help="check a capture session folder and list every problem",
        description="Check rig.json (every camera: intrinsics, distortion, the pose rule), session.json, "
                    "and every frame's images (present, decodable, type and size, label values). "
                    "Prints every problem at once, each naming the file and camera; exit status 1 "
                    "when there is any.")
    p.add_argument("session", help="capture session folder")
    p.add_argument("--quick", action="store_true", help="only check that image files exist (no decoding)")
    p.set_defaults(func=_validate_session)


def _import_capture(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.capture.importers import ImportOptions, import_capture

    out = Path(args.out)
    if out.exists() and any(out.iterdir()) and not args.overwrite:
        raise InputError(f"--out {out} exists and is not empty; choose a new folder or pass --overwrite")
    intr = None
    if args.intrinsics:
        try:
            intr = tuple(float(v) for v in args.intrinsics.split(","))
        except ValueError:
            intr = ()
        if len(intr) != 4 or not all(math.isfinite(v) for v in intr) or min(intr[:2]) <= 0:
            raise InputError(f"--intrinsics {args.intrinsics!r}: expected four finite numbers "
                             "fx,fy,cx,cy in pixels (fx, fy positive)")
    report = import_capture(args.format, args.src, out, ImportOptions(
        frames=args.frames, intrinsics=intr, max_time_difference=args.max_time_diff,
        trajectory=args.trajectory, subject_id=args.subject, pose_id=args.pose))
    for line in report.skipped + report.notes:
        sys.stdout.write(f"note: {line}\n")
    for serial, r in report.repairs.items():
        sys.stdout.write(f"note: camera {serial}: {r.describe()}\n")
    sys.stdout.write(f"wrote {out}: {report.frames} frame(s), one camera each\n")
    return 0


def _validate_session(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.capture.session import check_session

    check = check_session(args.session, check_images=not args.quick)
    for note in check.notes:
        sys.stdout.write(f"note: {note}\n")
    if check.problems:
        sys.stdout.write(f"{args.session}: {len(check.problems)} problem(s)\n")
        for p in check.problems:
            sys.stdout.write(f"  {p}\n")
        return 1
    n = len(check.rig.cameras) if check.rig else 0
    frames = check.info.n_frames if check.info else 0
    sys.stdout.write(f"{args.session}: valid ({n} camera(s) x {frames} frame(s))\n")
    return 0


def _fusion_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--voxel", type=number(MIN_VOXEL_M, 1.0), default=0.004,
                   help=f"TSDF voxel size in metres, {MIN_VOXEL_M:g} to 1 (default 0.004)")
    p.add_argument("--min-weight", type=number(1.0, 1e6), default=1.0,
                   help="mesh a voxel only when at least this many frames observed it (default 1: "
                        "every surface any frame saw, including surface seen by one view)")
    p.add_argument("--refine", action=argparse.BooleanOptionalAction, default=False,
                   help="refine the extrinsics before fusing: multiway ICP whose poses are kept only "
                        "where they lower view-to-view residuals and the data determine the move, "
                        "within --refine-max-deg/-cm and --refine-seconds (default off: calibrated "
                        "rigs and dataset poses are used as they are; turn it on for a drifted "
                        "calibration)")
    p.add_argument("--refine-max-deg", type=number(0.0, 180.0), default=3.0,
                   help="refinement may turn a camera by at most this many degrees (default 3)")
    p.add_argument("--refine-max-cm", type=number(0.0, 1000.0), default=5.0,
                   help="refinement may move a camera by at most this many centimetres (default 5)")
    p.add_argument("--refine-seconds", type=number(0.0, 86400.0), default=60.0,
                   help="time limit of the refinement's registrations (default 60)")
    p.add_argument("--colored-icp", action="store_true", help="use coloured ICP at the finest ICP scale")
    p.add_argument("--device", default="cpu", type=device, help="cpu or cuda[:N]")
    p.add_argument("--poisson-depth", type=integer(1, MAX_POISSON_DEPTH), default=None,
                   help=f"screened Poisson remesh at this depth (1 to {MAX_POISSON_DEPTH})")
    p.add_argument("--decimate", type=integer(1, MESH_FACES), default=None,
                   help="decimate the scan to this many faces")
    p.add_argument("--no-cleanup", action="store_true",
                   help="keep the raw TSDF mesh: no component, non-manifold or hole repair (the cleanup "
                        "takes about a quarter of fusing 12 VGA frames of a room)")


def _fusion_config(args: argparse.Namespace) -> Any:
    # start-up: the stage loads when the command runs
    from dressmeup.fusion.cleanup import CleanupConfig
    from dressmeup.fusion.icp import ICPConfig
    from dressmeup.fusion.pipeline import FusionConfig

    if args.no_cleanup and (args.poisson_depth or args.decimate):
        raise InputError("--no-cleanup cannot be combined with --poisson-depth or --decimate (both are cleanup steps)")
    return FusionConfig(voxel_size=args.voxel, min_weight=args.min_weight, refine=args.refine,
                        device=args.device,
                        icp=ICPConfig(colored=args.colored_icp, max_rotation_deg=args.refine_max_deg,
                                      max_translation_m=args.refine_max_cm / 100.0,
                                      time_limit_s=args.refine_seconds),
                        cleanup=None if args.no_cleanup else
                        CleanupConfig(poisson_depth=args.poisson_depth, target_faces=args.decimate))


def _load_rig(spec: str) -> Any:
    # start-up: the stage loads when the command runs
    from dressmeup.capture.rig import load_rig, ring_rig

    if spec == "default-7":
        return ring_rig(7, name="default-7")
    return load_rig(spec)


def _synth_capture(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.capture.synthetic import (
        NoiseModel,
        make_mannequin,
        subject_from_sample,
        synth_capture,
    )

    rig = _load_rig(args.rig)
    if args.scale != 1.0:
        rig = rig.scaled(args.scale)
    for cam in rig.cameras:
        IMAGE_PIXELS.check(cam.width * cam.height, f"--scale {args.scale:g}",
                           f"image of camera {cam.serial} ({cam.width} x {cam.height})")
    FRAMES.check(args.frames * len(rig.cameras), f"--frames {args.frames}",
                 f"frames of {len(rig.cameras)} camera(s)")
    if args.sample == "mannequin":
        subject = make_mannequin(seed=args.seed)
        body_src = None
    else:
        subject = subject_from_sample(args.sample)
        body_src = Path(args.sample) / "body.npz"
    noise = NoiseModel(enabled=not args.no_noise)
    out = synth_capture(subject, rig, args.out, noise=noise, seed=args.seed, n_frames=args.frames,
                        perturb_deg=args.perturb_deg, perturb_m=args.perturb_cm / 100.0,
                        subject_up=args.subject_up)
    if body_src is not None and body_src.is_file():
        atomic_write_bytes(out / "ground_truth" / "body.npz", body_src.read_bytes())
    sys.stdout.write(f"wrote {out} ({len(rig.cameras)} cameras x {args.frames} frame(s), "
                     f"{len(subject.garments)} garment(s): {', '.join(g.id for g in subject.garments)})\n")
    return 0


def _fuse(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.capture.session import open_session
    from dressmeup.fusion.pipeline import fuse_session, save_scan

    out = Path(args.out)
    # outputs are checked before minutes of fusion work
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} is an existing file; give a folder for the scan")
    if (out / "scan.ply").exists() and not args.overwrite:
        raise InputError(f"--out {out} already holds scan.ply; choose a new folder or pass "
                         "--overwrite to replace it")
    session = open_session(args.session)
    for note in session.notes:
        sys.stdout.write(f"note: {note}\n")
    views = len(session.rig.cameras) * max(1, session.info.n_frames)
    if args.min_weight > views:
        raise InputError(f"--min-weight {args.min_weight:g}: the session has {views} views, so "
                         "no voxel is seen that often; give at most that many")
    result = fuse_session(session, _fusion_config(args))
    extra: dict[str, Any] = {"session": str(Path(args.session).resolve()),
                             **({"pose_notes": session.notes} if session.notes else {})}
    if args.garments:
        # start-up: the stage loads when the command runs
        from dressmeup.extraction.pipeline import extract_garments, save_garment

        ex = extract_garments(result, session.info)
        extra["labels_from"] = ex.method
        for g in ex.garments:
            save_garment(g, out / "garments" / g.info.id)
        extra["garments"] = [{"id": g.info.id, "faces": int(len(g.faces)),
                              "texture_coverage": g.texture_coverage} for g in ex.garments]
    save_scan(result, out, extra)
    t = result.timings
    sys.stdout.write(f"wrote {out / 'scan.ply'}: {len(result.vertices)} vertices, {len(result.faces)} faces "
                     f"({', '.join(f'{k} {v:.1f} s' for k, v in t.items())})\n")
    if result.icp is not None:
        r = result.icp
        worst = max(r.corrections.values(), key=lambda x: x[0], default=(0.0, 0.0))
        kept = sum(1 for v in r.corrections.values() if v != (0.0, 0.0))
        sys.stdout.write(f"refinement: {len(r.edges)} view pairs, {kept} camera(s) moved (largest "
                         f"{worst[0]:.2f} deg / {100 * worst[1]:.1f} cm), {len(r.refused)} proposal(s) "
                         f"refused, {r.seconds:.1f} s\n")
    return 0


def _build_dataset(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.data.from_captures import build_dataset_from_sessions
    from dressmeup.extraction.pipeline import ExtractionConfig

    IMAGE_PIXELS.check(args.texture_size ** 2, f"--texture-size {args.texture_size}",
                       "texture image")
    report = build_dataset_from_sessions(
        args.sessions, args.out, fusion_config=_fusion_config(args),
        extraction_config=ExtractionConfig(target_faces=args.target_faces,
                                           texture=not args.no_texture,
                                           texture_size=args.texture_size),
        body=args.body, body_model=args.body_model, split=args.split, name=args.name,
        scans=args.scans,
        executor=executor_from_args(args, default_workers=1))
    for session, error in report.failed:
        sys.stderr.write(f"build-dataset: skipped session {session}: {error}\n")
    sys.stdout.write(f"{args.out}: {report.written} sample(s) written, {report.skipped} already "
                     f"present, {len(report.failed)} session(s) failed\n")
    if report.failures_path is not None:
        sys.stdout.write(f"failures listed in {report.failures_path}\n")
        return 1
    return 0
