"""``dressmeup baseline retarget`` and ``dressmeup baseline train-retarget`` (retarget methods)."""

from __future__ import annotations

import argparse
import platform
import sys


def register(tasks: argparse._SubParsersAction) -> None:
    """Register ``retarget`` and ``train-retarget`` under ``dressmeup baseline``."""
    p = tasks.add_parser(
        "retarget", help="run a retargeting baseline over an edition into a submission",
        description="Retarget the source garment of every pair of the edition's split onto the "
                    "target body and write a submission folder that 'dressmeup score' accepts. "
                    "Methods: rigid, skinning, isomap, isomap-refine; chain post-processes with "
                    "'+detail' and '+penetration' (e.g. isomap-refine+detail).")
    p.add_argument("--method", required=True, help="method name, e.g. skinning or isomap-refine+penetration")
    p.add_argument("--data", required=True, help="dataset root (holds manifest.parquet)")
    p.add_argument("--edition", required=True, help="edition name (e.g. synth-retarget-v2) or path")
    p.add_argument("--out", required=True, help="submission folder to create (must be new or empty)")
    p.add_argument("--weights", default=None, help="isomap-refine checkpoint (.pt) from train-retarget")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="method hyperparameter (repeatable), e.g. --param k_place=3 "
                        "--param detail__anchor_fraction=0.5")
    p.add_argument("--limit", type=int, default=None, help="only the first N pairs (the submission "
                                                          "is then incomplete: for smoke tests)")
    p.add_argument("--overwrite", action="store_true", help="write into a non-empty folder")
    p.set_defaults(func=_run)

    t = tasks.add_parser(
        "train-retarget", help="train the isomap-refine network self-supervised",
        description="Train isomap-refine on the (garment, source body, target body) triplets of a "
                    "dataset split (no ground truth is used) and save a checkpoint.")
    t.add_argument("--data", required=True, help="dataset root")
    t.add_argument("--split", default="train", help="split to train on (default: train)")
    t.add_argument("--out", required=True, help="checkpoint path (.pt)")
    t.add_argument("--steps", type=int, default=300, help="training steps (one triplet each)")
    t.add_argument("--max-triplets", type=int, default=8, help="triplets used (default 8)")
    t.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="hyperparameter of isomap-refine (repeatable), e.g. --param width=256")
    t.add_argument("--exclude-garments", default="", help="comma-separated garment ids not to train on")
    t.add_argument("--seed", type=int, default=0)
    t.set_defaults(func=_train)


def _params(items: list[str]) -> dict:
    from dressmeup.methods.retarget.run import parse_value

    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"--param: expected KEY=VALUE, got {item!r}")
        k, v = item.split("=", 1)
        out[k.strip()] = parse_value(v)
    return out


def _run(args: argparse.Namespace) -> int:
    import numpy as np

    from dressmeup.bench import load_edition, write_submission
    from dressmeup.bench.submission import check_submission_out
    from dressmeup.data import Dataset
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.run import predict_pairs

    check_submission_out(args.out, args.overwrite)  # before the work, naming --overwrite
    edition = load_edition(args.edition)
    if edition.task != "retarget":
        raise ValueError(f"--edition: {edition.name} is a {edition.task!r} edition, expected a retarget one")
    params = _params(args.param)
    if args.weights:
        params["weights"] = args.weights
    method = get_method(args.method, **params)
    ds = Dataset(args.data)
    pairs = ds.retarget_pairs(edition.split)
    preds, seconds = predict_pairs(method, pairs, limit=args.limit)
    runtime = float(np.mean(seconds)) if seconds else 0.0
    out = write_submission(args.out, preds, edition=edition, method=args.method,
                           authors="dressmeup reference baselines",
                           url="https://github.com/dressmeup (docs/baselines.md)",
                           hardware=f"{platform.processor() or platform.machine()} CPU",
                           runtime_per_sample_s=runtime,
                           extra={"hyperparameters": {k: repr(v) for k, v in params.items()}},
                           overwrite=args.overwrite)
    sys.stdout.write(f"wrote {len(preds)} predictions to {out} ({runtime:.2f} s per pair)\n")
    return 0


def _train(args: argparse.Namespace) -> int:
    from dressmeup.data import Dataset
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.run import training_triplets

    params = _params(args.param)
    params.setdefault("steps", args.steps)
    params.setdefault("seed", args.seed)
    method = get_method("isomap-refine", **params)
    triplets, model = training_triplets(
        Dataset(args.data), args.split, args.max_triplets, seed=args.seed,
        exclude_garments=[g for g in args.exclude_garments.split(",") if g])
    method.fit(triplets, model)
    path = method.save(args.out)
    first = method.loss_history_[0][0]
    last = sum(h[0] for h in method.loss_history_[-10:]) / min(10, len(method.loss_history_))
    sys.stdout.write(f"trained on {len(triplets)} triplets ({model.name}); loss {first:.5f} -> {last:.5f}; "
                     f"saved {path}\n")
    return 0
