"""``dressmeup baseline retarget`` and ``dressmeup baseline train-retarget`` (retarget methods)."""

from __future__ import annotations

import argparse
import sys

from dressmeup.cli.checks import integer, new_output, number, output_file, seed
from dressmeup.cli.executor_args import add_executor_args, executor_from_args
from dressmeup.errors import InputError
from dressmeup.hyperparameters import parse_params
from dressmeup.limits import WORKERS
from dressmeup.methods.retarget import METHODS, POSTPROCESSES

#: Most training steps of one run (the reference weights took 3,000 to 20,000).
MAX_STEPS = 10_000_000


def register(tasks: argparse._SubParsersAction) -> None:
    """Register ``retarget`` and ``train-retarget`` under ``dressmeup baseline``."""
    p = tasks.add_parser(
        "retarget", help="run a retargeting baseline over an edition into a submission",
        description="Retarget the source garment of every pair of the edition's split onto the "
                    "target body and write a submission folder that 'dressmeup score' accepts. "
                    f"Methods: {', '.join(METHODS)}; chain post-processes with "
                    f"{' and '.join(repr('+' + p) for p in POSTPROCESSES)} (e.g. "
                    "isomap-refine+detail); docs/baselines.md describes each.")
    p.add_argument("--method", required=True,
                   help=f"method name: {', '.join(METHODS)}, optionally followed by "
                        f"{' and/or '.join('+' + p for p in POSTPROCESSES)} (e.g. "
                        "isomap-refine+penetration)")
    p.add_argument("--data", required=True, help="dataset root (holds manifest.parquet)")
    p.add_argument("--edition", required=True, help="edition name (e.g. synth-retarget-v2) or path")
    p.add_argument("--out", required=True, type=new_output,
                   help="submission folder to create (must be new or empty)")
    p.add_argument("--weights", default=None, help="isomap-refine checkpoint (.pt) from train-retarget")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="method hyperparameter (repeatable), e.g. --param k_place=3 "
                        "--param detail__anchor_fraction=0.5")
    p.add_argument("--limit", type=integer(1), default=None,
                   help="only the first N pairs (the submission is then incomplete: for smoke "
                        "tests)")
    p.add_argument("--overwrite", action="store_true", help="write into a non-empty folder")
    add_executor_args(p, default_workers=1, what="pair")
    p.set_defaults(func=_run, locks=("out",))

    t = tasks.add_parser(
        "train-retarget", help="train the isomap-refine network (self-supervised, or supervised: -sup)",
        description="Train isomap-refine (self-supervised: only the source garment and the two bodies of "
                    "each training pair are read) or isomap-refine-sup (supervised by the target garment) "
                    "on a dataset split and save a checkpoint. Refuses training garments that appear, by "
                    "content, in another split; validation pairs choose the kept step; the test split is "
                    "never read. Seeded; resumes from the checkpoint OUT.ckpt when it exists.")
    t.add_argument("--data", required=True, help="dataset root")
    t.add_argument("--method", default="isomap-refine", choices=["isomap-refine", "isomap-refine-fast", "isomap-refine-sup"],
                   help="network to train (default isomap-refine)")
    t.add_argument("--split", default="train", help="split to train on (default: train)")
    t.add_argument("--val-split", default="val", help="validation split ('none': no validation; default val)")
    t.add_argument("--max-val", type=integer(1), default=16,
                   help="validation pairs used (default 16)")
    t.add_argument("--out", required=True, type=output_file, help="checkpoint path (.pt)")
    t.add_argument("--steps", type=integer(1, MAX_STEPS), default=300,
                   help="training steps (one pair each)")
    t.add_argument("--max-triplets", type=integer(0), default=0,
                   help="training pairs used (default 0: all)")
    t.add_argument("--wall-minutes", type=number(0.0, 525600.0, lo_open=True), default=None,
                   help="wall budget of this run; training stops there (resume later from "
                        "OUT.ckpt)")
    t.add_argument("--val-every", type=integer(1), default=50,
                   help="steps between validations (default 50)")
    t.add_argument("--checkpoint-every", type=integer(1), default=50,
                   help="steps between checkpoints (default 50)")
    t.add_argument("--half", action="store_true", help="store the weights as float16 (half the file)")
    t.add_argument("--until-converged", action="store_true",
                   help="stop when the validation figure improved by less than 1 %% over the last "
                        "20 %% of the steps and one pass over the training pairs (--steps is then "
                        "the most steps)")
    t.add_argument("--curves", default=None, help="write the learning curves to this PNG")
    t.add_argument("--threads", type=integer(1, WORKERS), default=None,
                   help="torch threads (default: torch's choice)")
    t.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                   help="hyperparameter of the method (repeatable), e.g. --param width=256")
    t.add_argument("--exclude-garments", default="", help="comma-separated garment ids not to train on")
    t.add_argument("--seed", type=seed, default=0)
    t.set_defaults(func=_train, locks=("out",))


def _params(items: list[str]) -> dict:
    return parse_params(items)


def _run(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench import load_edition
    from dressmeup.bench.scoring.submission import check_submission_out
    from dressmeup.runs import run_retarget_baseline

    check_submission_out(args.out, args.overwrite)  # before the work, naming --overwrite
    edition = load_edition(args.edition)
    if edition.task != "retarget":
        raise InputError(f"--edition: {edition.name} is a {edition.task!r} edition, expected a retarget one")
    params = _params(args.param)
    if args.weights:
        params["weights"] = args.weights
    lines: list[str] = []
    out = run_retarget_baseline(args.method, edition, args.data, args.out, train_steps=0,
                                limit=args.limit, overwrite=args.overwrite,
                                executor=executor_from_args(args, default_workers=1),
                                url="https://github.com/dressmeup/dressmeup/blob/main/docs/baselines.md",
                                log=lines.append, **params)
    sys.stdout.write(f"wrote {out} ({lines[-1].strip() if lines else args.method})\n")
    return 0


def _train(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.methods.retarget.train_dataset import train_from_dataset

    if args.threads:
        # start-up: the stage loads when the command runs
        import torch

        torch.set_num_threads(int(args.threads))
    info = train_from_dataset(
        args.data, args.out, method=args.method, params=_params(args.param), split=args.split,
        val_split=None if args.val_split.lower() == "none" else args.val_split, steps=args.steps,
        max_triplets=args.max_triplets or None, max_val=args.max_val, seed=args.seed,
        wall_minutes=args.wall_minutes, val_every=args.val_every, checkpoint_every=args.checkpoint_every,
        half=args.half, curves=args.curves, exclude_garments=[g for g in args.exclude_garments.split(",") if g],
        until_converged=args.until_converged)
    sys.stdout.write(f"trained {args.method} on {info['train_pairs']} pairs of {len(info['train_garments'])} "
                     f"garments: {info['steps_done']} of {info['steps_requested']} steps (stopped by "
                     f"{info['stopped_by']}), {info['wall_seconds']:.0f} s wall, {info['cpu_seconds']:.0f} s CPU; "
                     f"kept step {info['kept_step']}; saved {args.out} ({info['file_mb']} MB)\n")
    return 0
