"""Train the shipped ``isomap-refine`` weights (``dressmeup/methods/retarget/weights/``).

    python benchmarks/train_retarget_weights.py --data DATA_ROOT --preset thesis --until-converged \
        --out dressmeup/methods/retarget/weights/isomap_refine_anny.pt

Presets (network sizes of ``dressmeup.methods.retarget.refine_config.PRESETS``): ``thesis``
(decoder 6 x 512, 128-d PointNet codes, PointNet hidden 128, 32 target neighbours: thesis
4.4.2; ``isomap-refine``), ``medium`` (6 x 256, 64-d codes, hidden 64: ``isomap-refine-sup``)
and ``fast`` (6 x 128, 64-d codes, hidden 64, 16 neighbours: ``isomap-refine-fast``).
Self-supervised (``--method isomap-refine``) or supervised (``--method isomap-refine-sup``) on
the train split of a synthetic dataset built by the generator; validation pairs choose the
kept step; weights stored as float16. Before training, the script checks that no training
garment is a test garment of any shipped edition generated with the same generator version and
seed (garments are compared by subject shape, type and parameters, so a garment is recognised
across dataset sizes) and refuses to train otherwise; ``dressmeup baseline train-retarget``
(which this calls) also refuses garments shared by content with the dataset's val/test splits.
Resumable: re-running continues from ``OUT.ckpt``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

from dressmeup.methods.retarget.refine_config import PRESETS

#: the network-size fields a preset sets (the loss settings stay each method's own)
SIZE_FIELDS = ("width", "depth", "code_dim", "pointnet_hidden", "k_neighbors")


def preset_params(name: str) -> dict:
    """The network size of a preset of ``refine_config.PRESETS``."""
    return {f: getattr(PRESETS[name], f) for f in SIZE_FIELDS}


def _plan4(params: dict, seed: int, secret: bytes | None) -> dict:
    """Garment ids -> key and split of a generator-4 plan: train and val (public seed), and
    test when its ``secret`` is known (a published secret, or the maintainers' file)."""
    from dressmeup.data.synth.config import SynthConfig
    from dressmeup.data.synth.dataset4 import Gen4Config
    from dressmeup.data.synth.generator4 import load_body_kit
    from dressmeup.data.synth.plan4 import SPLITS, split_garments

    # dataset.json's params hold more than a configuration (anchor_gap, the commitment)
    fields = {f.name for f in dataclasses.fields(SynthConfig)} - {"seed", "splits", "secret"}
    g4 = Gen4Config.from_synth(SynthConfig(**{k: v for k, v in params.items() if k in fields}))
    kit = load_body_kit(g4.body_model)
    out = {}
    for split in SPLITS:
        if split == "test" and secret is None:
            continue
        subjects, garments = split_garments(split, g4.design, kit, seed, secret)
        for g, v in garments.items():
            key = [subjects[v["design_subject"]]["shape"], v["type"], v["params"]]
            out[g] = {"key": json.dumps(key, sort_keys=True), "split": split}
    return out


def _plan(params: dict, seed: int, secret: bytes | None = None) -> dict:
    """The generator's plan of a dataset (garment ids -> key of its design, split); 1.x, 2.x
    and 4.x (4.x: the test split only with its ``secret``)."""
    from dressmeup.data.splits import split_by_garment
    from dressmeup.data.synth.common import plan_2x
    from dressmeup.data.synth.garments import garment_types
    from dressmeup.data.synth.generate import plan_dataset

    if str(params.get("version", "1")).startswith("4."):
        return _plan4(params, seed, secret)
    q = {"subjects": 3, "garments": 4, "poses": 5, **params}
    if str(q.get("version", "1")).startswith("2."):
        plan = plan_2x(q["subjects"], q["poses"], tuple(q["garments_per_split"]), seed, q.get("categories"))
        return {g: {"key": json.dumps([v["type"], v["params"]], sort_keys=True), "split": v["split"]}
                for g, v in plan["garments"].items()}
    types = sorted(q.get("types") or garment_types())
    plan = plan_dataset(q["subjects"], q["garments"], q["poses"], seed, types, None, None)
    cats = {g: v["category"] for g, v in plan["garments"].items()}
    splits = split_by_garment(list(cats), q.get("split_fractions", (0.6, 0.2, 0.2)), seed=seed,
                              categories=cats, strategy=q.get("split_strategy", "stratified"))
    return {g: {"key": json.dumps([plan["subjects"][v["subject"]]["shape"], v["type"], v["params"]],
                                  sort_keys=True), "split": splits[g]}
            for g, v in plan["garments"].items()}


def _check_no_test_garments(ds, split: str, exclude: list[str]) -> None:
    """Refuse to train on a garment that is a test garment of a shipped edition.

    Garments are recognised by the generator's design (type and parameters; v1 also the
    subject's shape), not by id, so a garment is found across dataset sizes: in generator 2.x
    the k-th garment of a category draws its parameters from ``[seed, 3, category, k]`` with the
    test garments first, so the mini/tiny editions' test garments are the full edition's.
    """
    from dressmeup.bench import load_edition
    from dressmeup.bench.edition import list_editions

    gen = ds.info["generator"]
    mine = _plan(gen["params"], gen["seed"])
    used = {g for g, v in ds.info["garments"].items() if v["split"] == split} - set(exclude)
    used_keys = {mine[g]["key"]: g for g in used}
    checked, sealed = [], []
    for name in list_editions():
        ed = load_edition(name)
        pin = ed.dataset
        if pin.kind != "generated" or pin.generator != gen["name"] or pin.seed != gen["seed"]:
            continue
        if str(pin.generator_version).split(".")[0] != str(gen["version"]).split(".")[0]:
            continue
        if pin.sealed:
            # seeded by a secret's streams, which the public seed never draws from
            sealed.append(name)
            continue
        for g, rec in _plan(pin.params, pin.seed, pin.published_secret).items():
            if rec["split"] == ed.split and rec["key"] in used_keys:
                raise SystemExit(f"training garment {used_keys[rec['key']]} is test "
                                 f"garment {g} of edition {name}: exclude it")
        checked.append(name)
    print(f"training garments {sorted(used)}: none is a test garment of {checked}"  # noqa: T201
          + (f"; test splits seeded by an unpublished secret: {sealed}" if sealed else ""))


def main() -> None:
    import torch

    from dressmeup.data import Dataset
    from dressmeup.methods.retarget.train_dataset import train_from_dataset

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--method", default="isomap-refine", choices=["isomap-refine", "isomap-refine-sup"])
    ap.add_argument("--preset", default="thesis", choices=sorted(PRESETS))
    ap.add_argument("--split", default="train")
    ap.add_argument("--exclude-garments", default="", help="comma-separated garment ids")
    ap.add_argument("--steps", type=int, default=5000, help="upper bound on the steps")
    ap.add_argument("--wall-minutes", type=float, default=None,
                    help="wall budget of this invocation (resume later; default: none)")
    ap.add_argument("--until-converged", action="store_true",
                    help="stop by the convergence rule on the validation pairs")
    ap.add_argument("--checkpoint-every", type=int, default=50)
    ap.add_argument("--max-triplets", type=int, default=0, help="cap on training pairs (0: all)")
    ap.add_argument("--max-val", type=int, default=12)
    ap.add_argument("--val-every", type=int, default=40)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--curves", default=None, help="PNG of the learning curves")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    exclude = [g for g in args.exclude_garments.split(",") if g]
    _check_no_test_garments(Dataset(args.data), args.split, exclude)
    t = time.perf_counter()
    info = train_from_dataset(args.data, args.out, method=args.method, params=preset_params(args.preset),
                              split=args.split, steps=args.steps, max_triplets=args.max_triplets or None,
                              max_val=args.max_val, seed=args.seed,
                              wall_minutes=args.wall_minutes, val_every=args.val_every, half=True,
                              until_converged=args.until_converged,
                              checkpoint_every=args.checkpoint_every,
                              curves=args.curves, exclude_garments=exclude,
                              callback=lambda s, total, terms: print(  # noqa: T201
                                  f"step {s:4d} loss {total:.5f} " + " ".join(f"{k} {v:.5f}" for k, v in terms.items()),
                                  flush=True) if s % 20 == 0 else None)
    print(json.dumps({k: v for k, v in info.items() if k != "hyperparameters"}, default=str))  # noqa: T201
    print(f"{args.method} ({args.preset}): {info['steps_done']} steps, {info['wall_seconds']:.0f} s wall, "  # noqa: T201
          f"{info['cpu_seconds']:.0f} s CPU in training ({time.perf_counter() - t:.0f} s in all); "
          f"kept step {info['kept_step']}; {Path(args.out)} {info['file_mb']} MB")


if __name__ == "__main__":
    main()
