"""``dressmeup metrics PRED GT``: every applicable metric for two mesh files."""

from __future__ import annotations

import argparse
import json
import sys

from dressmeup.cli.checks import integer, seed
from dressmeup.errors import InputError
from dressmeup.limits import SURFACE_SAMPLES


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register the ``metrics`` subcommand."""
    p = subparsers.add_parser(
        "metrics",
        help="score a predicted mesh against a ground-truth mesh (P2S, Chamfer, ED, NC, F-score, IR, QCE/ASE)",
        description=(
            "Print every applicable metric of PRED against GT (docs/metrics.md): distances in mm, "
            "shares in %, with the direction of 'better' (arrow). IR needs --body. QCE/ASE/UV "
            "validity are added when PRED has UVs."
        ),
    )
    p.add_argument("pred", metavar="PRED", help="predicted mesh (.ply or .obj)")
    p.add_argument("gt", metavar="GT", help="ground-truth mesh (.ply or .obj)")
    p.add_argument(
        "--body", metavar="BODY", help="body mesh: adds IR and the penetrating-vertex share"
    )
    p.add_argument(
        "--samples",
        type=integer(1, SURFACE_SAMPLES),
        default=100_000,
        metavar="N",
        help="surface samples per mesh (default 100000)",
    )
    p.add_argument("--seed", type=seed, default=0, metavar="S", help="sampling seed (default 0)")
    p.add_argument(
        "--json",
        action="store_true",
        help="print JSON (values in metres / fractions) instead of a table",
    )
    p.set_defaults(func=run)


def _display(m) -> tuple[str, str]:
    if m.value is None:
        return "n/a", ""
    if m.unit == "m":
        return f"{m.value * 1e3:.4f}", "mm"
    if m.unit == "m^2":
        return f"{m.value * 1e6:.4f}", "mm^2"
    if m.unit == "fraction":
        return f"{m.value * 100:.2f}", "%"
    return f"{m.value:.4f}", ""


def _surface(mesh, what: str):
    """``mesh`` when some face has a positive area (metrics sample its surface)."""
    # start-up: the stage loads when the command runs
    from dressmeup.geometry.mesh import face_areas

    if not face_areas(mesh.vertices, mesh.faces).sum() > 0:
        raise InputError(f"{what} {mesh.path}: every face has zero area (degenerate "
                         "triangles), so there is no surface to measure")
    return mesh


def run(args: argparse.Namespace) -> int:
    """Load the meshes, compute the report and print it."""
    # start-up: the stage loads when the command runs
    from dressmeup.io.mesh import load_mesh
    from dressmeup.metrics.report import compare_meshes, scale_mismatch

    pred = _surface(load_mesh(args.pred), "PRED")
    gt = _surface(load_mesh(args.gt), "GT")
    body = _surface(load_mesh(args.body), "--body") if args.body else None
    mismatch = scale_mismatch(pred.vertices, gt.vertices, f"prediction {args.pred}",
                              f"ground truth {args.gt}")
    if mismatch:
        sys.stderr.write(f"dressmeup metrics: warning: {mismatch}\n")
    pred_uv = (pred.uv, pred.uv_faces) if pred.uv is not None else None
    rows = compare_meshes(
        (pred.vertices, pred.faces),
        (gt.vertices, gt.faces),
        body=(body.vertices, body.faces) if body is not None else None,
        n_samples=args.samples,
        seed=args.seed,
        pred_uv=pred_uv,
    )
    if args.json:
        doc = {
            "pred": str(args.pred),
            "gt": str(args.gt),
            "body": str(args.body) if args.body else None,
            "samples": args.samples,
            "seed": args.seed,
            "units": "SI: m, m^2; fractions in [0, 1]",
            "metrics": {m.name: m.as_dict() for m in rows},
        }
        sys.stdout.write(json.dumps(doc, indent=2) + "\n")
        return 0
    arrow = {"lower": "\u2193", "higher": "\u2191"}
    width = max(len(m.name) for m in rows) + 2
    lines = [f"pred: {args.pred}", f"gt:   {args.gt}"]
    if args.body:
        lines.append(f"body: {args.body}")
    lines.append(f"samples: {args.samples} per mesh, seed {args.seed}")
    lines.append("")
    lines.append(f"{'metric':<{width}}{'value':>12}  {'unit':<5} better  note")
    for m in rows:
        val, unit = _display(m)
        lines.append(
            f"{m.name:<{width}}{val:>12}  {unit:<5} {arrow.get(m.better, m.better):^6}  {m.note}"
        )
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
