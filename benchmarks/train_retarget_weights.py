"""Train the shipped ``isomap-refine`` weights (``dressmeup/methods/retarget/weights/``).

    python benchmarks/train_retarget_weights.py --data DATA_ROOT [--exclude-garments G01]

Self-supervised on the train split of a synthetic dataset built by the generator
(``dressmeup synth``; the shipped file was trained on the train garments of
synth-retarget-v1 without G01, which is the test garment of synth-retarget-mini-v1).
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


def main() -> None:
    import torch

    from dressmeup.data import Dataset
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.refine import WEIGHTS_DIR
    from dressmeup.methods.retarget.run import training_triplets

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="train")
    ap.add_argument("--exclude-garments", default="G01")
    ap.add_argument("--max-triplets", type=int, default=16)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None, help="default: weights/isomap_refine_<body model>.pt")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    triplets, model = training_triplets(Dataset(args.data), args.split, args.max_triplets, seed=args.seed,
                                        exclude_garments=[g for g in args.exclude_garments.split(",") if g])
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
