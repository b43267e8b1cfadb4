"""Subcommands of the body stage: ``dressmeup register`` (fit a body model to a scan)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register this stage's subcommands."""
    p = subparsers.add_parser(
        "register",
        help="fit a body model to a scan (clothed or not) and write its parameters (.npz)",
        description=(
            "Fit a body model to a scan by optimisation (global alignment, then pose, then "
            "shape), or import another tool's fit with --registrar from-file. Output follows "
            "vertices = scale * model(shape, pose) + transl (docs/body-models.md)."
        ),
    )
    p.add_argument("scan", help="scan mesh (.ply/.obj/.stl/.off) or points (.npy (p,3), .xyz)")
    p.add_argument("--model", default="anny",
                   help="body model: anny (default, open), procedural, smpl, smplh, smplx")
    p.add_argument("--out", required=True, help="output parameter file (.npz)")
    p.add_argument("--init", help="starting parameters (.npz or any importable format)")
    p.add_argument("--keypoints", help="3D joint positions: .npy (j,3) with NaN rows for "
                   "missing joints, or .json {joint_name: [x, y, z]}")
    p.add_argument("--registrar", default="optimization",
                   help="registrar name: optimization (default) or from-file")
    p.add_argument("--params", help="with --registrar from-file: the parameter file to import")
    p.add_argument("--format", default="auto",
                   help="with --registrar from-file: npz, easymocap, pamir, smplify (default auto)")
    p.add_argument("--gender", default="neutral", help="SMPL family: neutral, female or male")
    p.add_argument("--model-path", help="SMPL family: the model file or its folder")
    p.add_argument("--iterations", default=None,
                   help="steps of the global,pose,shape stages, e.g. 60,160,160")
    p.add_argument("--clothed", action="store_true",
                   help="scan wears clothes: weaker pull of the body towards the scan surface")
    p.add_argument("--naked", action="store_true",
                   help="scan is naked: symmetric data term (body inside the scan costs as much "
                   "as outside)")
    p.add_argument("--init-route", choices=("hypotheses", "keypoints", "auto"),
                   default="hypotheses",
                   help="how the fit starts without --init/--keypoints: hypotheses (several "
                   "canonical poses x yaw, default), keypoints (detected on renders of the scan; "
                   "needs the [keypoints] extra), auto (if installed, both starts run and the better "
                   "fitting one goes on)")
    p.add_argument("--keep-support", action="store_true",
                   help="fit to the whole scan: by default large flat surfaces (the floor, a "
                   "seat's top and sides, a wall; at least 30 x 30 cm flat within 8 mm) are left "
                   "out before the fit and from the fit's distances")
    p.add_argument("--up", choices=("x", "-x", "y", "-y", "z", "-z"),
                   help="the scan's up axis (default y; a scan that does not look upright "
                   "with y up is refused, naming this option; write a downward axis as "
                   "--up=-z). The parameters are written in the scan's frame")
    p.add_argument("--no-picture", action="store_true",
                   help="do not write the picture of the fit (<out>.fit.png)")
    p.add_argument("--seed", type=int, default=0, help="sampling seed (default 0)")
    p.set_defaults(func=_run_register)


def _load_scan(path: str):
    # start-up time: the stage loads when the command runs
    import numpy as np

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"scan not found: {p}")
    if p.suffix.lower() == ".npy":
        return np.load(p, allow_pickle=False)
    if p.suffix.lower() in (".xyz", ".txt"):
        try:
            return np.loadtxt(p, usecols=(0, 1, 2))
        except ValueError as exc:
            raise InputError(f"{p}: not a point list of x y z rows ({exc})") from exc
    if p.suffix.lower() == ".ply":  # a mesh or a point cloud: header checked before parsing
        # start-up time: the stage loads when the command runs
        from dressmeup.io.mesh import check_ply_header

        check_ply_header(p)
    # start-up time: the stage loads when the command runs
    import trimesh

    try:
        mesh = trimesh.load(p, process=False, force="mesh")
    except Exception as exc:  # noqa: BLE001 - a third-party parser on user files
        raise InputError(f"{p}: cannot read the scan ({type(exc).__name__}: {exc})") from exc
    if len(mesh.faces) == 0:
        return np.asarray(mesh.vertices)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def _load_keypoints(path: str):
    # start-up time: the stage loads when the command runs
    import numpy as np

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"keypoints file not found: {p}")
    if p.suffix.lower() == ".json":
        # start-up time: the stage loads when the command runs
        from dressmeup.io.jsonio import read_json

        return {k: np.asarray(v, dtype=float) for k, v in read_json(p, "keypoints").items()}
    # start-up time: the stage loads when the command runs
    from dressmeup.io.npz import load_npz

    return load_npz(p, what="keypoints file")


def _run_register(args: argparse.Namespace) -> int:
    # start-up time: the stage loads when the command runs
    from dressmeup.body import get_body_model
    from dressmeup.body.importers import import_body_params
    from dressmeup.body.registration import register as fit

    kw = {}
    if args.model in ("smpl", "smplh", "smplx"):
        kw["gender"] = args.gender
        if args.model_path:
            kw["model_path"] = args.model_path
    if Path(args.out).is_dir():
        raise InputError(f"--out {args.out} is a folder; give the .npz file to write")
    keypoints = _load_keypoints(args.keypoints) if args.keypoints else None  # before the fit
    model = get_body_model(args.model, **kw)
    options: dict = {}
    if args.registrar == "from-file":
        if not args.params:
            raise InputError("--registrar from-file needs --params FILE")
        options = {"path": args.params, "format": args.format}
        scan = None
    else:
        scan = _load_scan(args.scan)
        options["seed"] = args.seed
        options["init_route"] = args.init_route
        options["remove_support"] = not args.keep_support
        options["up"] = args.up
        if args.iterations:
            try:
                its = tuple(int(x) for x in args.iterations.split(","))
            except ValueError:
                its = ()
            if len(its) != 3 or min(its) < 0:
                raise InputError(f"--iterations: expected three counts like 60,160,160, got "
                                 f"{args.iterations!r}")
            options["iterations"] = its
        if args.clothed and args.naked:
            raise InputError("--clothed and --naked exclude each other")
        if args.clothed:
            options["inside_weight"] = 0.2
        if args.naked:
            options.update(inside_weight=1.0, sigma_in=0.15)
    init = import_body_params(args.init, body_model=model) if args.init else None
    result = fit(scan, model, init=init, keypoints=keypoints, registrar=args.registrar,
                 return_result=True, **options)
    path = result.params.save(args.out)
    start = result.info.get("init")
    sys.stdout.write(f"wrote {path} (model {model.name}, {result.seconds:.1f} s"
                     + (f"; start: {start}" if start else "") + ")\n")
    restart = shape_restart_line(result.info)
    if restart:
        sys.stdout.write(restart + "\n")
    support = result.info.get("support") or {}
    if support.get("points_removed"):
        kinds = ", ".join(p["kind"] for p in support["planes"])
        sys.stdout.write(f"left out {support['points_removed']} of {support['points_checked']} "
                         f"scan points on {len(support['planes'])} flat support surfaces "
                         f"({kinds}; --keep-support keeps them)\n")
    if scan is not None:
        # start-up time: the stage loads when the command runs
        from dressmeup.body.registration.scan import rotate_scan, up_rotation
        from dressmeup.body.rigid import rotate_params

        R = up_rotation(args.up or "y")  # measured and pictured upright
        _report_fit(model, rotate_params(result.params, model, R), rotate_scan(scan, R),
                    Path(path), picture=not args.no_picture, seed=args.seed,
                    supports=[s.rotated(R) for s in getattr(result, "supports", ())])
    return 0


def shape_restart_line(info: dict) -> str:
    """One line saying which start of the shape search replaced the fitted body's shape
    (``info["shape_search"]`` of a fit), with the shape objectives; empty when the fitted
    body stayed or no search ran."""
    scores = info.get("shape_search") or {}
    kept = scores.get("kept", "fitted")
    if kept == "fitted" or kept not in scores:
        return ""
    return (f"shape search: restarted the shape as {kept} of the same stature (shape "
            f"objective {scores['fitted']:.4g} -> {scores[kept]:.4g})")


def _report_fit(model, params, scan, out: Path, picture: bool, seed: int,
                supports=()) -> None:
    """Print the fit's distances to the scan (mm), write them next to the result as
    ``<stem>.metrics.json`` and the picture as ``<stem>.fit.png``; the scan's points on
    ``supports`` (floor, seat: see ``registration.support``) are left out."""

    # start-up time: the stage loads when the command runs
    import numpy as np

    from dressmeup.body.registration.metrics import fit_metrics, format_metrics, vertex_parts
    from dressmeup.body.registration.scan import prepare_scan
    from dressmeup.body.registration.support import support_mask

    posed = model.posed(params)
    pts = prepare_scan(scan, n_points=60000, seed=seed)
    if len(supports):
        pts = pts[~support_mask(pts, list(supports))]
    parts = vertex_parts(model)
    m = fit_metrics(posed.vertices, model.faces, pts, parts)
    sys.stdout.write(format_metrics(m) + "\n")
    metrics_path = out.with_name(out.stem + ".metrics.json")
    atomic_write_text(metrics_path, json.dumps(m, indent=1))
    written = [str(metrics_path)]
    if picture:
        # start-up time: the stage loads when the command runs
        from scipy.spatial.transform import Rotation

        from dressmeup.body.registration.metrics import outside_distances_mm
        from dressmeup.viz.registration import render_registration

        forward = Rotation.from_rotvec(np.asarray(params.pose)[0]).apply([0.0, 0.0, 1.0])
        png = render_registration(
            posed.vertices, model.faces, pts, out.with_name(out.stem + ".fit.png"),
            forward=forward, outside_mm=outside_distances_mm(posed.vertices, model.faces, pts),
            title=(f"{out.name}: body->scan {m['body_to_scan_mm']:.1f} mm, scan->body "
                   f"{m['scan_to_body_mm']:.1f} mm, worst part outside "
                   f"{m['max_part_outside_mm']:.1f} mm (red: > 15 mm outside the scan)"),
            seed=seed)
        written.append(str(png))
    sys.stdout.write("wrote " + ", ".join(written) + "\n")
