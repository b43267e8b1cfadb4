"""Subcommands of the capture stage: ``synth-capture``, ``fuse``, ``build-dataset``.

``build-dataset`` chains the library stages for each session (fuse -> extract garments ->
UV + texture -> body registration -> DatasetWriter); a session that fails is reported and
skipped, and a re-run skips the samples already in the dataset.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from dressmeup.cli.executor_args import add_executor_args, executor_from_args
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_bytes


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register ``synth-capture``, ``fuse`` and ``build-dataset``."""
    p = subparsers.add_parser(
        "synth-capture", help="render a synthetic multi-view RGBD capture session with exact ground truth",
        description="Render colour, depth and label masks of a clothed person from every camera of "
                    "a rig (open3d ray casting) with a Kinect-like noise model. SAMPLE is a dataset "
                    "sample folder (samples/<subject>/<garment>/<pose>, with scan.ply and garment "
                    "meshes) or 'mannequin' for the built-in procedural subject.")
    p.add_argument("sample", help="dataset sample folder, or 'mannequin'")
    p.add_argument("--rig", default="default-7",
                   help="rig.json path, or 'default-7' (7 Azure-Kinect-like cameras, 640x576)")
    p.add_argument("--out", required=True, help="session folder to write")
    p.add_argument("--no-noise", action="store_true", help="exact depth (only quantised to 1 mm)")
    p.add_argument("--frames", type=int, default=1, help="frames per camera (fresh noise each)")
    p.add_argument("--perturb-deg", type=float, default=0.0,
                   help="write a drifted calibration: rotate every camera but the reference by this many degrees")
    p.add_argument("--perturb-cm", type=float, default=0.0, help="... and shift it by this many centimetres")
    p.add_argument("--scale", type=float, default=1.0, help="image size factor (0.5: 320x288)")
    p.add_argument("--subject-up", default="auto", help="the subject's up axis: auto, x, y or z")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=_synth_capture)

    p = subparsers.add_parser(
        "fuse", help="fuse a capture session into a coloured scan (TSDF)",
        description="Filter depth, optionally refine the extrinsics by multiway ICP, fuse with a "
                    "TSDF (open3d VoxelBlockGrid) and clean the mesh. Writes SCAN_DIR/scan.ply, "
                    "rig.json (the calibration used) and fusion.json; with --garments also "
                    "SCAN_DIR/garments/<id>/garment.obj (+ .mtl, .png).")
    p.add_argument("session", help="capture session folder (rig.json, session.json, frames)")
    p.add_argument("--out", required=True, help="scan folder to write")
    _fusion_args(p)
    p.add_argument("--garments", action="store_true", help="also cut out, UV-map and texture each garment")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a scan already in --out (default: refuse)")
    p.set_defaults(func=_fuse)

    p = subparsers.add_parser(
        "build-dataset", help="turn capture sessions into a DressMeUp-style dataset",
        description="For each session: fuse, extract and texture the garments, register the body, "
                    "and write one dataset sample per garment. Resumable: samples already in ROOT "
                    "are skipped. A session that fails is reported and skipped.")
    p.add_argument("sessions", nargs="+", help="session folders, or folders containing sessions")
    p.add_argument("--out", required=True, help="dataset root")
    p.add_argument("--scans", default=None,
                   help="folder of scans made by 'dressmeup fuse' (SCANS/<session name>/"
                        "scan.ply): those sessions are not fused again")
    _fusion_args(p)
    p.add_argument("--body", default="auto", choices=["auto", "register", "session", "ground-truth", "none"],
                   help="body source: 'register' fits the body model to the scan; 'session' reads "
                        "SESSION/body.npz (an external fit, in the rig frame); 'ground-truth' uses a "
                        "synthetic session's true body (samples are then written in its frame); 'auto' "
                        "tries register, then session, then ground-truth, then none")
    p.add_argument("--body-model", default="anny", help="body model for registration")
    p.add_argument("--split", default="train", help="split of the garments written")
    p.add_argument("--name", default="captured", help="dataset name in dataset.json")
    p.add_argument("--target-faces", type=int, default=20000, help="garment face count (decimation)")
    p.add_argument("--texture-size", type=int, default=1024)
    p.add_argument("--no-texture", action="store_true")
    add_executor_args(p, default_workers=1, what="session")
    p.set_defaults(func=_build_dataset)


def _fusion_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--voxel", type=float, default=0.004, help="TSDF voxel size in metres (default 0.004)")
    p.add_argument("--refine", action=argparse.BooleanOptionalAction, default=True,
                   help="refine the extrinsics by multiway ICP before fusing (default; "
                        "--no-refine skips it)")
    p.add_argument("--colored-icp", action="store_true", help="use coloured ICP at the finest ICP scale")
    p.add_argument("--device", default="cpu", help="cpu or cuda[:N]")
    p.add_argument("--poisson-depth", type=int, default=None, help="screened Poisson remesh at this depth")
    p.add_argument("--decimate", type=int, default=None, help="decimate the scan to this many faces")


def _fusion_config(args: argparse.Namespace) -> Any:
    # start-up time: the stage loads when the command runs
    from dressmeup.fusion.cleanup import CleanupConfig
    from dressmeup.fusion.icp import ICPConfig
    from dressmeup.fusion.pipeline import FusionConfig

    return FusionConfig(voxel_size=args.voxel, refine=args.refine, device=args.device,
                        icp=ICPConfig(colored=args.colored_icp),
                        cleanup=CleanupConfig(poisson_depth=args.poisson_depth, target_faces=args.decimate))


def _load_rig(spec: str) -> Any:
    # start-up time: the stage loads when the command runs
    from dressmeup.capture.rig import load_rig, ring_rig

    if spec == "default-7":
        return ring_rig(7, name="default-7")
    return load_rig(spec)


def _synth_capture(args: argparse.Namespace) -> int:
    # start-up time: the stage loads when the command runs
    from dressmeup.capture.synthetic import (
        NoiseModel,
        make_mannequin,
        subject_from_sample,
        synth_capture,
    )

    rig = _load_rig(args.rig)
    if args.scale != 1.0:
        rig = rig.scaled(args.scale)
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
    # start-up time: the stage loads when the command runs
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
    result = fuse_session(session, _fusion_config(args))
    extra: dict[str, Any] = {"session": str(Path(args.session).resolve())}
    if args.garments:
        # start-up time: the stage loads when the command runs
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
        worst = max(result.icp.corrections.values(), key=lambda x: x[0], default=(0.0, 0.0))
        sys.stdout.write(f"ICP: {len(result.icp.edges)} view pairs, largest correction "
                         f"{worst[0]:.2f} deg / {100 * worst[1]:.1f} cm\n")
    return 0


def _build_dataset(args: argparse.Namespace) -> int:
    # start-up time: the stage loads when the command runs
    from dressmeup.data.from_captures import build_dataset_from_sessions
    from dressmeup.extraction.pipeline import ExtractionConfig

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
