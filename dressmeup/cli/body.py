"""Subcommands of the body stage: ``dressmeup register`` (fit a body model to a scan)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from dressmeup.cli.checks import output_file, seed
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text

#: Most steps of one registration stage (the defaults are 60 to 160).
MAX_ITERATIONS = 100_000
#: A fit leaving 5 % of the scan farther than this from the body (mm) is reported as poor,
#: naming --up: an upside-down scan fitted from upright starts leaves 380 mm (a good fit of
#: a clothed scan: tens of mm).
POOR_FIT_P95_MM = 150.0


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
    p.add_argument("--out", required=True, type=output_file,
                   help="output parameter file (.npz)")
    p.add_argument("--init", help="starting parameters (.npz or any importable format)")
    p.add_argument("--keypoints", help="3D joint positions: .npy (j,3) with NaN rows for "
                   "missing joints, or .json {joint_name: [x, y, z]}")
    p.add_argument("--registrar", default="optimization", choices=("optimization", "from-file"),
                   help="registrar name: optimization (default) or from-file")
    p.add_argument("--params", help="with --registrar from-file: the parameter file to import")
    p.add_argument("--format", default="auto",
                   help="with --registrar from-file: npz, easymocap, pamir, smplify (default auto)")
    p.add_argument("--gender", default="neutral", choices=("neutral", "female", "male"),
                   help="SMPL family: neutral, female or male")
    p.add_argument("--model-path", help="SMPL family: the model file or its folder")
    p.add_argument("--preset", choices=("default", "naked", "clothed", "fast"),
                   default="default",
                   help="registrar settings (docs/body-models.md): default (clothed or naked "
                   "scans), naked (symmetric data term: body inside the scan costs as much as "
                   "outside), clothed (weaker pull of the body towards the scan surface), fast "
                   "(fewer samples and steps, a preview)")
    p.add_argument("--iterations", default=None,
                   help="steps of the rigid, pose and shape stages, e.g. 60,160,160")
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
    p.add_argument("--seed", type=seed, default=0, help="sampling seed (default 0)")
    p.set_defaults(func=_run_register, locks=("out",))


def _load_scan(path: str):
    # start-up: the stage loads when the command runs
    import numpy as np

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"scan not found: {p}")
    if p.suffix.lower() == ".npy":
        # start-up: the stage loads when the command runs
        from dressmeup.io.npz import load_npy

        return _points(load_npy(p, what="scan"), p)
    if p.suffix.lower() in (".xyz", ".txt"):
        # start-up: the stage loads when the command runs
        from dressmeup.limits import MESH_BYTES

        MESH_BYTES.check(p.stat().st_size, str(p), "point file size")
        try:
            return _points(np.loadtxt(p, usecols=(0, 1, 2), ndmin=2), p)
        except ValueError as exc:
            raise InputError(f"{p}: not a point list of x y z rows ({exc})") from exc
    if p.suffix.lower() == ".ply":  # a mesh or a point cloud: header checked before parsing
        # start-up: the stage loads when the command runs
        from dressmeup.io.ply import check_ply_header

        check_ply_header(p)
    # start-up: the stage loads when the command runs
    import trimesh

    # start-up: the stage loads when the command runs
    from dressmeup.limits import MESH_BYTES

    MESH_BYTES.check(p.stat().st_size, str(p))
    try:
        mesh = trimesh.load(p, process=False, force="mesh")
        V, F = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
    except Exception as exc:  # noqa: BLE001 - a third-party parser on user files
        raise InputError(f"{p}: cannot read the scan ({type(exc).__name__}: {exc})") from exc
    _points(V, p)
    if len(F) == 0:
        return V
    if F.ndim != 2 or F.shape[1] != 3 or F.min() < 0 or F.max() >= len(V):
        raise InputError(f"{p}: the scan's faces are not triangles indexing its "
                         f"{len(V)} vertices")
    return V, F


def _points(P, path: Path):
    """``P`` when it is ``(p, 3)`` finite points, at least four of them."""
    # start-up: the stage loads when the command runs
    import numpy as np

    P = np.asarray(P)
    if P.ndim != 2 or P.shape[1] != 3 or P.dtype.kind not in "fiu":
        raise InputError(f"{path}: expected (p, 3) points, got {P.dtype} {P.shape}")
    if len(P) < 4 or not np.isfinite(P).all():
        raise InputError(f"{path}: expected at least 4 finite points, got {len(P)} "
                         f"({int((~np.isfinite(P)).any(axis=1).sum())} with NaN or inf)")
    return P.astype(np.float64)


def _load_keypoints(path: str):
    # start-up: the stage loads when the command runs
    import numpy as np

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"keypoints file not found: {p}")
    if p.suffix.lower() == ".json":
        # start-up: the stage loads when the command runs
        from dressmeup.io.jsonio import read_json

        return {k: np.asarray(v, dtype=float) for k, v in read_json(p, "keypoints").items()}
    if p.suffix.lower() == ".npy":
        # start-up: the stage loads when the command runs
        from dressmeup.io.npz import load_npy

        return load_npy(p, what="keypoints file")
    # start-up: the stage loads when the command runs
    from dressmeup.io.npz import load_npz

    return load_npz(p, what="keypoints file")


def _fit_options(args: argparse.Namespace) -> dict:
    """The registrar's options from the command line, every one checked (before any file
    is read or model built)."""
    if args.registrar == "from-file":
        if not args.params:
            raise InputError("--registrar from-file needs --params FILE")
        return {"path": args.params, "format": args.format}
    if args.format != "auto" or args.params:
        raise InputError("--format and --params go with --registrar from-file")
    options: dict = {"preset": args.preset, "seed": args.seed, "init_route": args.init_route,
                     "remove_support": not args.keep_support, "up": args.up}
    if args.iterations:
        try:
            its = tuple(int(x) for x in args.iterations.split(","))
        except ValueError:
            its = ()
        if len(its) != 3 or min(its) < 0 or max(its) > MAX_ITERATIONS:
            raise InputError(f"--iterations: expected three counts from 0 to "
                             f"{MAX_ITERATIONS:,} like 60,160,160, got {args.iterations!r}")
        options["iterations"] = its
    return options


def _checked_scan(args: argparse.Namespace):
    """The scan, and when ``--up`` names another axis, checked to look upright once turned."""
    scan = _load_scan(args.scan)
    if args.up not in (None, "y"):
        # start-up: the stage loads when the command runs
        from dressmeup.body.registration.scan import check_upright, rotate_scan, up_rotation

        turned = rotate_scan(scan, up_rotation(args.up))
        check_upright(turned[0] if isinstance(turned, tuple) else turned,
                      f"{args.scan} turned by --up {args.up}")
    return scan


def _precheck(path: str) -> None:
    """Refuse a parameter file whose size or content is out of bounds (a pickle bomb, a
    damaged .npz) before minutes of model building; the importer reads it afterwards."""
    # start-up: the stage loads when the command runs
    from dressmeup.io.jsonio import parse_json_file
    from dressmeup.io.npz import npz_arrays_info
    from dressmeup.io.pickles import read_pickle_bytes

    suffix = Path(path).suffix.lower()
    if suffix in (".pkl", ".pickle"):
        read_pickle_bytes(path)
    elif suffix == ".npz":
        npz_arrays_info(path, "parameter file")
    elif suffix == ".json":
        parse_json_file(path)


def _run_register(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
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
    options = _fit_options(args)
    keypoints = _load_keypoints(args.keypoints) if args.keypoints else None  # before the fit
    scan = None if args.registrar == "from-file" else _checked_scan(args)
    for path in (args.init, args.params):  # bounded reads before the model is built
        if path:
            _precheck(path)
    model = get_body_model(args.model, **kw)
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
        # start-up: the stage loads when the command runs
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

    # start-up: the stage loads when the command runs
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
    if m.get("scan_to_body_p95_mm", 0.0) > POOR_FIT_P95_MM:
        sys.stderr.write(f"dressmeup register: warning: poor fit: 5 % of the scan is more than "
                         f"{m['scan_to_body_p95_mm']:.0f} mm from the body. Is the scan upright "
                         "with y up? An upside-down scan needs --up=-y, a z-up one --up z "
                         "(or --up=-z); a scan of several people or with large props fits "
                         "one body only\n")
    metrics_path = out.with_name(out.stem + ".metrics.json")
    atomic_write_text(metrics_path, json.dumps(m, indent=1))
    written = [str(metrics_path)]
    if picture:
        # start-up: the stage loads when the command runs
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
