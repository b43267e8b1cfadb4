"""Subcommands of the body stage: ``dressmeup register`` (fit a body model to a scan)."""

from __future__ import annotations

import argparse
import sys

from dressmeup.errors import InputError


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
    p.add_argument("--seed", type=int, default=0, help="sampling seed (default 0)")
    p.set_defaults(func=_run_register)


def _load_scan(path: str):
    from pathlib import Path

    import numpy as np

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"scan not found: {p}")
    if p.suffix.lower() == ".npy":
        return np.load(p, allow_pickle=False)
    if p.suffix.lower() in (".xyz", ".txt"):
        return np.loadtxt(p, usecols=(0, 1, 2))
    import trimesh

    mesh = trimesh.load(p, process=False, force="mesh")
    if len(mesh.faces) == 0:
        return np.asarray(mesh.vertices)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def _load_keypoints(path: str):
    import json
    from pathlib import Path

    import numpy as np

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"keypoints file not found: {p}")
    if p.suffix.lower() == ".json":
        return {k: np.asarray(v, dtype=float) for k, v in json.loads(p.read_text()).items()}
    return np.load(p, allow_pickle=False)


def _run_register(args: argparse.Namespace) -> int:
    from dressmeup.body import get_body_model
    from dressmeup.body.importers import import_body_params
    from dressmeup.body.registration import register as fit

    kw = {}
    if args.model in ("smpl", "smplh", "smplx"):
        kw["gender"] = args.gender
        if args.model_path:
            kw["model_path"] = args.model_path
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
    keypoints = _load_keypoints(args.keypoints) if args.keypoints else None
    result = fit(scan, model, init=init, keypoints=keypoints, registrar=args.registrar,
                 return_result=True, **options)
    path = result.params.save(args.out)
    final = {k: round(v, 4) for k, v in result.losses.items() if k.startswith("shape_")}
    sys.stdout.write(f"wrote {path} (model {model.name}, {result.seconds:.1f} s"
                     + (f", final losses {final}" if final else "") + ")\n")
    return 0
