"""Loss ablation of the isomap-refine training (thesis section 4.5.2.1, Table 4.4).

Trains one network per loss configuration on the same prepared training triplets (same
seed, same steps) and scores each on the same pairs with the benchmark's per-pair scoring:
all losses; L_corres only; L_length only; L_bend only; without L_corres; without L_length;
without L_bend; without the joint masks; without the penetration term. The network is
small (``--width``) and trained briefly (``--steps``) so the whole study fits in minutes on
2 cores: the numbers compare configurations, they are not the shipped model's.

    python benchmarks/studies/loss_ablation.py --data ROOT --exclude-garments G01
"""

from __future__ import annotations

import argparse
import json
import time
from datetime import date
from pathlib import Path

import numpy as np

METRICS = ("p2s", "ed", "nc", "ir")
ALL = dict(w_length=1.0, w_corres=1.0, w_bend=0.01, w_penetration=1.0, use_joint_mask=True)
VARIANTS = {
    "all losses": {},
    "L_corres only": dict(w_length=0.0, w_bend=0.0, w_penetration=0.0),
    "L_length only": dict(w_corres=0.0, w_bend=0.0, w_penetration=0.0),
    "L_bend only": dict(w_length=0.0, w_corres=0.0, w_penetration=0.0),
    "without L_corres": dict(w_corres=0.0),
    "without L_length": dict(w_length=0.0),
    "without L_bend": dict(w_bend=0.0),
    "without joint masks": dict(use_joint_mask=False),
    "without penetration term": dict(w_penetration=0.0),
}


def main() -> None:
    import torch

    from dressmeup.bench.tasks.retarget.evaluate import evaluate_pair
    from dressmeup.data import Dataset
    from dressmeup.io.atomic import atomic_write_text
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.base import body_context
    from dressmeup.methods.retarget.run import body_model_for, training_triplets

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--exclude-garments", default="")
    ap.add_argument("--max-triplets", type=int, default=8)
    ap.add_argument("--test-split", default="test")
    ap.add_argument("--pairs-per-garment", type=int, default=2, help="seeded choice of test pairs per garment")
    ap.add_argument("--steps", type=int, default=80)
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--n-samples", type=int, default=20000)
    ap.add_argument("--out", default=f"benchmarks/results/studies/{date.today():%Y-%m-%d}-loss_ablation.md")
    args = ap.parse_args()
    torch.set_num_threads(1)
    arch = dict(width=args.width, code_dim=64, pointnet_hidden=64, steps=args.steps)
    ds = Dataset(args.data)
    triplets, model = training_triplets(ds, "train", args.max_triplets,
                                        exclude_garments=[g for g in args.exclude_garments.split(",") if g])
    base = get_method("isomap-refine", **arch)
    t0 = time.perf_counter()
    train = [base.prepare(*tr, model) for tr in triplets]
    rng = np.random.default_rng(0)
    by_garment: dict = {}
    for p in ds.retarget_pairs(args.test_split):
        by_garment.setdefault(p.source.garment_id, []).append(p)
    pairs = [grp[i] for g, grp in sorted(by_garment.items())
             for i in sorted(rng.choice(len(grp), min(args.pairs_per_garment, len(grp)), replace=False))]
    models: dict = {}
    test = []
    for p in pairs:
        g, gt = p.source.garment(), p.target.garment()
        src, tgt = p.source.body(), p.target.body()
        m = body_model_for(src, models)
        t = body_context(m, tgt)
        test.append((base.prepare(g.vertices, g.faces, src, tgt, m), np.asarray(g.faces), gt,
                     (t.skin_vertices, t.skin_faces)))
    print(f"prepared {len(train)} training and {len(test)} test samples in {time.perf_counter() - t0:.0f} s",  # noqa: T201
          flush=True)
    opts = {"n_samples": args.n_samples, "seed": 0, "chamfer_squared": True}

    def score(predict) -> dict[str, float]:
        vals = []
        for sample, F, gt, body in test:
            v, _ = evaluate_pair(predict(sample), F, np.asarray(gt.vertices), np.asarray(gt.faces), body, METRICS, opts)
            vals.append(v)
        return {k: float(np.nanmean([v[k] for v in vals])) for k in METRICS}

    rows = [{"variant": "coarse only (isomap, no network)", "final_loss": None,
             **score(lambda s: s.x.astype(np.float64) + s.center)}]
    print(rows[-1], flush=True)  # noqa: T201
    for label, change in VARIANTS.items():
        method = get_method("isomap-refine", **arch, **{**ALL, **change})
        t = time.perf_counter()
        method.fit_samples(train, model.name)
        final = float(np.mean([h[0] for h in method.loss_history_[-10:]]))
        rows.append({"variant": label, "final_loss": final, "train_seconds": round(time.perf_counter() - t, 1),
                     **score(method.predict_sample)})
        print(rows[-1], flush=True)  # noqa: T201
    lines = [f"# Loss ablation of isomap-refine ({len(train)} training triplets, {args.steps} steps, width "
             f"{args.width}; scored on {len(test)} `{args.test_split}` pairs of {args.data}: "
             f"{', '.join(sorted({p.source.garment_id + ' ' + p.source.garment_type for p in pairs}))})", "",
             "REDUCED SCALE: a small network trained briefly from scratch per variant, so that the study fits "
             "the shared machine; the figures compare loss configurations, not the shipped model.", "",
             "P2S and ED in mm, IR in %. Produced by `python benchmarks/studies/loss_ablation.py`.", "",
             "| variant | P2S ↓ [mm] | ED ↓ [mm] | NC ↑ | IR ↓ [%] |", "|---|---:|---:|---:|---:|"]
    lines += [f"| {r['variant']} | {1000 * r['p2s']:.2f} | {1000 * r['ed']:.2f} | {r['nc']:.4f} | {100 * r['ir']:.2f} |"
              for r in rows]
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, "\n".join(lines) + "\n")
    atomic_write_text(out.with_suffix(".json"), json.dumps({"pairs": [p.pair_id for p in pairs], "rows": rows},
                                                           indent=2))
    print(f"wrote {out}")  # noqa: T201


if __name__ == "__main__":
    main()
