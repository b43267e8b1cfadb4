"""Train the shipped ``isomap-refine`` weights (``dressmeup/methods/retarget/weights/``).

    python benchmarks/train_retarget_weights.py --data DATA_ROOT --steps 120 --max-triplets 8

Self-supervised on the train split of a synthetic dataset built by the generator (the shipped
file was trained on the train garments of the synth-retarget-v2 data, 120 steps on 8
triplets). Before training, the script checks that no training garment is a test garment of
any shipped edition generated with the same generator version and seed (garments are compared
by subject shape, type and parameters, so a garment is recognised across dataset sizes) and
refuses to train otherwise.
The network is narrower than the thesis' (width 256, 64-d PointNet codes, PointNet hidden 64
instead of 512 / 128 / 128) to stay under the 5 MB budget of shipped files; everything else
(6 layers, AdaIN conditioning, losses, k = 32) follows thesis 4.3.2/4.4.2. It is exactly
``dressmeup baseline train-retarget`` with these settings.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

SHIPPED = dict(width=256, depth=6, code_dim=64, pointnet_hidden=64)


def _garment_key(plan: dict, gid: str) -> str:
    import json

    g = plan["garments"][gid]
    return json.dumps([plan["subjects"][g["subject"]]["shape"], g["type"], g["params"]],
                      sort_keys=True)


def _check_no_test_garments(ds, split: str, exclude: list[str]) -> None:
    """Refuse to train on a garment that is a test garment of a shipped edition."""
    from dressmeup.bench import load_edition
    from dressmeup.bench.edition import list_editions
    from dressmeup.data.splits import split_by_garment
    from dressmeup.data.synth.garments import garment_types
    from dressmeup.data.synth.generate import plan_dataset

    gen = ds.info["generator"]
    p = gen["params"]
    plan = plan_dataset(p["subjects"], p["garments"], p["poses"], gen["seed"], p["types"], None, None)
    used = {g for g, v in ds.info["garments"].items() if v["split"] == split} - set(exclude)
    used_keys = {_garment_key(plan, g): g for g in used}
    checked = []
    for name in list_editions():
        ed = load_edition(name)
        pin = ed.dataset
        if (pin.kind != "generated" or pin.generator != gen["name"]
                or pin.generator_version != str(gen["version"]) or pin.seed != gen["seed"]):
            continue
        q = {"subjects": 3, "garments": 4, "poses": 5, **pin.params}
        types = sorted(q.get("types") or garment_types())
        eplan = plan_dataset(q["subjects"], q["garments"], q["poses"], pin.seed, types, None, None)
        cats = {g: v["category"] for g, v in eplan["garments"].items()}
        splits = split_by_garment(list(cats), q.get("split_fractions", (0.6, 0.2, 0.2)),
                                  seed=pin.seed, categories=cats,
                                  strategy=q.get("split_strategy", "stratified"))
        for g, s in splits.items():
            if s == ed.split and _garment_key(eplan, g) in used_keys:
                raise SystemExit(f"training garment {used_keys[_garment_key(eplan, g)]} is test "
                                 f"garment {g} of edition {name}: exclude it")
        checked.append(name)
    print(f"training garments {sorted(used)}: none is a test garment of {checked}")  # noqa: T201


def main() -> None:
    import torch

    from dressmeup.data import Dataset
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.refine import WEIGHTS_DIR
    from dressmeup.methods.retarget.run import training_triplets

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="train")
    ap.add_argument("--exclude-garments", default="", help="comma-separated garment ids")
    ap.add_argument("--max-triplets", type=int, default=16)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None, help="default: weights/isomap_refine_<body model>.pt")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    triplets, model = training_triplets(Dataset(args.data), args.split, args.max_triplets, seed=args.seed,
                                        exclude_garments=[g for g in args.exclude_garments.split(",") if g])
    _check_no_test_garments(Dataset(args.data), args.split,
                            [g for g in args.exclude_garments.split(",") if g])
    method = get_method("isomap-refine", steps=args.steps, seed=args.seed, **SHIPPED)
    t = time.perf_counter()
    method.fit(triplets, model, callback=lambda s, total, terms: print(  # noqa: T201
        f"step {s:4d} loss {total:.5f} " + " ".join(f"{k} {v:.5f}" for k, v in terms.items()), flush=True)
        if s % 10 == 0 else None)
    out = Path(args.out) if args.out else WEIGHTS_DIR / f"isomap_refine_{model.name}.pt"
    method.save(out)
    print(f"trained {args.steps} steps on {len(triplets)} triplets in {time.perf_counter() - t:.0f} s; "  # noqa: T201
          f"saved {out} ({out.stat().st_size / 1e6:.2f} MB)")


if __name__ == "__main__":
    main()
