"""Subcommands of the data stage: ``synth`` (build the synthetic dataset) and
``validate-dataset`` (check a dataset folder, report every problem)."""

from __future__ import annotations

import argparse
import sys


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register ``synth`` and ``validate-dataset``."""
    p = subparsers.add_parser(
        "synth", help="generate the built-in synthetic DressMeUp-style dataset",
        description="Generate a synthetic dataset: bodies of varied shape in varied poses, "
                    "parametric garments draped by skinning + quasi-static cloth relaxation. "
                    "Deterministic for a seed; re-running on the same OUT resumes.")
    p.add_argument("out", help="output dataset folder (created; resumed when it exists)")
    p.add_argument("--subjects", type=int, default=3, help="number of subjects (default 3)")
    p.add_argument("--garments", type=int, default=4, help="garments per subject (default 4)")
    p.add_argument("--poses", type=int, default=5, help="poses per garment (default 5)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--body-model", default="anny", choices=["anny", "procedural"],
                   help="body model (default anny; procedural is tiny, for tests)")
    p.add_argument("--registration-noise", type=float, default=0.0, metavar="SIGMA",
                   help="std of Gaussian noise added to the stored body pose (radians) and "
                        "shape; 0 stores the true parameters (default)")
    p.add_argument("--edge-length", type=float, default=None,
                   help="target garment edge length in metres (default: by body model)")
    p.add_argument("--no-scan", action="store_true", help="do not write clothed scan meshes")
    p.set_defaults(func=_synth)

    v = subparsers.add_parser(
        "validate-dataset", help="check a dataset folder and report every problem",
        description="Check dataset.json, the manifest schema, files, checksums, meshes, body "
                    "files and splits; print every problem; exit 1 when any is found.")
    v.add_argument("root", help="dataset folder")
    v.add_argument("--no-hashes", action="store_true", help="skip sha256 checks")
    v.add_argument("--no-meshes", action="store_true", help="skip loading meshes and bodies")
    v.set_defaults(func=_validate)


def _synth(args: argparse.Namespace) -> int:
    from dressmeup.data.synth import generate_dataset

    kw = {}
    if args.edge_length is not None:
        kw["edge_length"] = args.edge_length
    root = generate_dataset(args.out, subjects=args.subjects, garments=args.garments,
                            poses=args.poses, seed=args.seed, body_model=args.body_model,
                            registration_noise=args.registration_noise,
                            write_scan=not args.no_scan, **kw)
    from dressmeup.data.dataset import Dataset

    ds = Dataset(root)
    info = ds.info
    sys.stdout.write(f"wrote {len(ds)} samples ({info.get('n_garments')} garments, "
                     f"{info.get('n_subjects')} subjects) to {root}\n")
    rep = info.get("report", {})
    if rep:
        sys.stdout.write(f"skinning vs draped ground truth: mean {rep.get('skinning_mean_mm', 0):.1f} mm "
                         f"(max {rep.get('skinning_max_mm', 0):.1f} mm); "
                         f"time {info.get('timings', {}).get('last_run_s', 0):.1f} s\n")
    return 0


def _validate(args: argparse.Namespace) -> int:
    from dressmeup.data.validate import validate_dataset

    rep = validate_dataset(args.root, check_meshes=not args.no_meshes,
                           check_hashes=not args.no_hashes)
    sys.stdout.write(rep.format() + "\n")
    return 0 if rep.ok else 1
