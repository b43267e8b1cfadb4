"""``dressmeup baseline uvparam ...`` and ``dressmeup baseline train-uvparam ...``.

``uvparam`` runs one UV method over meshes (named test meshes such as ``torus-30k`` or mesh
files) and writes a submission folder: one ``<mesh_id>.npz`` per mesh with ``uv (k, 2)``,
``uv_faces (m, 3)``, ``chart_ids (m,)`` and ``seconds``, plus ``submission.json``.
``train-uvparam`` trains the neural method on one mesh and saves a checkpoint for
``uvparam --method neural --checkpoint``.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from dressmeup.cli.checks import new_output, output_file
from dressmeup.cli.executor_args import add_executor_args, executor_from_args
from dressmeup.errors import InputError
from dressmeup.hyperparameters import parse_params

METHOD_NAMES = ("xatlas", "lscm", "harmonic", "slim", "neural", "lscm-on-charts")


def register(tasks: argparse._SubParsersAction) -> None:
    """Register ``uvparam`` and ``train-uvparam`` under ``dressmeup baseline``."""
    p = tasks.add_parser(
        "uvparam", help="run a UV parameterisation method into a submission folder",
        description="Parameterise meshes with one method and write per-corner UV submissions "
                    "(<mesh_id>.npz with uv, uv_faces, chart_ids, seconds + submission.json, the "
                    "dressmeup.bench submission format). Meshes are an edition's mesh set built "
                    "with build_data (--edition with --data ROOT: every mesh of its split, the "
                    "way the demo and benchmarks/run_baselines.py run it), or "
                    "test-mesh ids (sphere-2k, torus-30k, blob-3k, sheet-2k, skirt-3k, body-native, "
                    "...) or mesh files (.obj/.ply/.off, id = file stem).")
    p.add_argument("--method", required=True, choices=METHOD_NAMES)
    p.add_argument("--meshes", nargs="+", default=None,
                   help="mesh ids or files (default: the synth-uvparam-v1 set)")
    p.add_argument("--edition", default=None,
                   help="take the mesh ids from this uvparam edition (name or JSON path); also "
                        "recorded in submission.json (default synth-uvparam-v1)")
    p.add_argument("--data", type=Path, default=None,
                   help="the edition's mesh set (a folder built by build_data, e.g. by 'dressmeup "
                        "demo'); needs --edition; replaces --meshes")
    p.add_argument("--out", required=True, type=lambda s: Path(new_output(s)),
                   help="submission folder to write")
    p.add_argument("--config", default="fast", choices=("fast", "reference"),
                   help="neural method: network configuration")
    p.add_argument("--checkpoint", type=Path, default=None,
                   help="neural method: trained model (infer only); otherwise it trains per mesh")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="extra method hyperparameter (repeatable), e.g. --param n_patches=12")
    p.add_argument("--overwrite", action="store_true", help="allow writing into a non-empty folder")
    p.add_argument("--images", type=Path, default=None,
                   help="also write a checkerboard picture per mesh into this folder")
    add_executor_args(p, default_workers=1, what="mesh of --data (the edition's mesh set)")
    p.set_defaults(func=_run_uvparam, locks=("out",))

    t = tasks.add_parser(
        "train-uvparam", help="train the neural UV method on one mesh and save a checkpoint",
        description="Train PatchNet and the UV MLPs (thesis chapter 3) on one mesh (decimated to "
                    "about train_vertices first) and save a checkpoint for inference on other "
                    "discretisations of the same shape.")
    t.add_argument("mesh", help="mesh id (e.g. blob-3k) or mesh file")
    t.add_argument("--out", required=True, type=lambda s: Path(output_file(s)),
                   help="checkpoint file to write (.pt)")
    t.add_argument("--config", default="fast", choices=("fast", "reference"))
    t.add_argument("--param", action="append", default=[], metavar="KEY=VALUE")
    t.set_defaults(func=_run_train, locks=("out",))


def _parse_params(items: list[str]) -> dict:
    return parse_params(items)


def load_mesh_arg(spec: str):
    """A test-mesh id or a mesh file -> (mesh_id, V, F)."""
    # start-up: the stage loads when the command runs
    import numpy as np

    from dressmeup.data.shapes import make_test_mesh

    path = Path(spec)
    if path.suffix.lower() in (".obj", ".ply", ".off", ".stl", ".glb"):
        if not path.is_file():
            raise FileNotFoundError(f"mesh file {path} does not exist")
        mesh_id = re.sub(r"[^A-Za-z0-9_-]", "_", path.stem)
        if path.suffix.lower() in (".obj", ".ply"):  # the toolkit's bounded reader
            # start-up: the stage loads when the command runs
            from dressmeup.io.mesh import load_mesh

            m = load_mesh(path)
            return mesh_id, m.vertices, m.faces
        # start-up: the stage loads when the command runs
        import trimesh

        from dressmeup.geometry.mesh import as_arrays
        from dressmeup.limits import MESH_BYTES

        MESH_BYTES.check(path.stat().st_size, str(path))
        try:
            mesh = trimesh.load(path, force="mesh", process=False)
            V, F = as_arrays(np.asarray(mesh.vertices, dtype=np.float64),
                             np.asarray(mesh.faces, dtype=np.int64), name=str(path))
        except Exception as exc:  # noqa: BLE001 - a third-party parser on user files
            raise InputError(f"{path}: cannot read the mesh ({type(exc).__name__}: "
                             f"{exc})") from exc
        return mesh_id, V, F
    V, F = make_test_mesh(spec)
    return spec, V, F


def _mesh_ids_from_edition(edition: str) -> list[str]:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.edition import load_edition

    ed = load_edition(edition)
    if ed.task != "uvparam":
        raise InputError(f"--edition {edition}: a '{ed.task}' edition, expected a 'uvparam' one")
    ids = ed.dataset.params.get("mesh_ids")
    if not ids:
        raise InputError(f"--edition {edition}: the edition lists no mesh_ids")
    return list(ids)


def _run_uvparam(args: argparse.Namespace) -> int:

    # start-up: the stage loads when the command runs
    import numpy as np

    from dressmeup.bench.scoring.submission import check_submission_out
    from dressmeup.data.shapes import DEFAULT_MESH_IDS
    from dressmeup.methods.uvparam import get_method
    from dressmeup.progress import progress

    check_submission_out(args.out, args.overwrite)  # before the work, naming --overwrite
    params = _parse_params(args.param)
    if args.method == "neural":
        params.setdefault("config", args.config)
        if args.checkpoint is not None:
            params["checkpoint"] = args.checkpoint
    if args.data is not None:
        return _run_on_mesh_set(args, params)
    if args.executor or args.scheduler or (args.workers or 1) > 1:
        raise InputError("--executor/--workers/--scheduler run an edition's mesh set "
                         "(--edition with --data); --meshes runs here, one mesh after another")
    method = get_method(args.method, **params)
    if args.meshes:
        specs = args.meshes
    elif args.edition:
        specs = _mesh_ids_from_edition(args.edition)
    else:
        specs = list(DEFAULT_MESH_IDS)
    out: Path = args.out
    edition = args.edition or "synth-uvparam-v1"
    preds, times = {}, {}
    for spec in progress(specs, desc=f"uvparam {args.method}"):
        mesh_id, V, F = load_mesh_arg(spec)
        res = method.parameterize(V, F)
        times[mesh_id] = res.seconds
        preds[mesh_id] = {"uv": res.uv, "uv_faces": res.uv_faces, "chart_ids": res.chart_ids,
                          "seconds": np.float64(res.seconds)}
        if args.images:
            # start-up: the stage loads when the command runs
            from dressmeup.viz.uv_checker import render_uv_checker

            render_uv_checker(V, F, res.uv, res.uv_faces, Path(args.images) / f"uv-{args.method}-{mesh_id}.png",
                              title=f"{args.method} on {mesh_id} ({res.n_charts} charts)",
                              chart_ids=res.chart_ids)
        sys.stdout.write(f"{mesh_id}: {len(V)} vertices, {res.n_charts} charts, {res.seconds:.2f} s\n")
    # start-up: the stage loads when the command runs
    from dressmeup.bench.scoring.provenance import hardware
    from dressmeup.bench.scoring.submission import write_submission
    from dressmeup.runs import BASELINE_AUTHORS

    write_submission(out, preds, edition=edition, method=args.method,
                     authors=BASELINE_AUTHORS, url="", hardware=hardware(),
                     runtime_per_sample_s=float(np.mean(list(times.values()))) if times else None,
                     task="uvparam", overwrite=args.overwrite,
                     extra={"hyperparameters": {k: repr(v) for k, v in params.items()},
                            "runtime_seconds": times})
    sys.stdout.write(f"wrote {len(times)} UV maps to {out}\n")
    return 0


def _run_on_mesh_set(args: argparse.Namespace, params: dict) -> int:
    """``--data``: every mesh of the edition's split, through :func:`dressmeup.runs.run_uvparam_baseline`."""
    # start-up: the stage loads when the command runs
    from dressmeup.runs import run_uvparam_baseline

    if args.edition is None:
        raise InputError("--data needs --edition (the edition whose mesh set --data holds)")
    if args.meshes or args.images:
        raise InputError("--data runs the edition's whole mesh set: drop --meshes and --images")
    lines: list[str] = []
    out = run_uvparam_baseline(args.method, args.edition, args.data, args.out,
                               overwrite=args.overwrite, log=lines.append,
                               executor=executor_from_args(args, default_workers=1), **params)
    sys.stdout.write(f"wrote {out} ({lines[-1].strip() if lines else args.method})\n")
    return 0


def _run_train(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.geometry.simplify import decimate
    from dressmeup.methods.uvparam.neural.model import get_config, save_model
    from dressmeup.methods.uvparam.neural.train import train

    cfg = get_config(args.config, **_parse_params(args.param))
    mesh_id, V, F = load_mesh_arg(args.mesh)
    Vt, Ft = decimate(V, F, cfg.train_vertices)
    model = train(Vt, Ft, cfg, progress=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    save_model(model, args.out)
    h = model.history
    sys.stdout.write(f"trained on {mesh_id} ({len(Vt)} vertices) in {h['seconds_total']:.1f} s: "
                     f"{h['n_charts_train']} charts, final cycle {h['cycle'][-1]:.2e}, "
                     f"iso {h['iso'][-1]:.2e}; wrote {args.out}\n")
    return 0
