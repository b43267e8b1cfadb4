"""Loss ablation of the isomap-refine training (thesis section 4.5.2.1, Table 4.4).

Trains one network per loss configuration on the same prepared training triplets (same
seed) and scores each on the same pairs with the benchmark's per-pair scoring: all losses;
L_corres only; L_length only; L_bend only; without L_corres; without L_length; without
L_bend; without the joint masks; without the penetration term.

Two scales:

- reduced (default): a small network (``--width``) trained a fixed number of ``--steps``,
  minutes on 2 cores; the numbers compare configurations briefly trained;
- converged (``--until-converged --preset fast``): every variant trained until the
  toolkit's convergence rule stops it, watching the ground-truth ED of ``--val-pairs``
  seeded pairs of the val split (the shipped networks' rule; ``--steps`` is then the most
  steps). With ``--work DIR`` each variant checkpoints to ``DIR/<variant>.ckpt`` and a
  finished variant's row is kept in ``DIR/rows.json``: a re-run resumes where it stopped
  (a variant stopped after its training but before its row was written resumes from its
  last checkpoint and may train one more validation interval before the rule stops it).

    python benchmarks/studies/loss_ablation.py --data ROOT --exclude-garments G01
    python benchmarks/studies/loss_ablation.py --data V5 --max-triplets 0 --preset fast \\
        --until-converged --steps 100000 --val-pairs 48 --threads 2 --work W
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import date
from pathlib import Path

import numpy as np
from study_labels import command_line, data_label

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
    ap.add_argument("--max-triplets", type=int, default=8, help="training pairs (0: all)")
    ap.add_argument("--test-split", default="test")
    ap.add_argument("--pairs-per-garment", type=int, default=2, help="seeded choice of test pairs per garment")
    ap.add_argument("--steps", type=int, default=80, help="steps (with --until-converged: the most)")
    ap.add_argument("--width", type=int, default=None,
                    help="decoder width (default: 128 with codes and PointNet hidden 64, "
                         "or the preset's)")
    ap.add_argument("--preset", default=None, help="network size preset (thesis, medium, fast)")
    ap.add_argument("--until-converged", action="store_true",
                    help="train each variant until the convergence rule stops it")
    ap.add_argument("--val-split", default="val")
    ap.add_argument("--val-pairs", type=int, default=48, help="val pairs the rule watches")
    ap.add_argument("--val-every", type=int, default=200)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--work", type=Path, default=None,
                    help="checkpoints and finished rows (a re-run resumes)")
    ap.add_argument("--n-samples", type=int, default=20000)
    ap.add_argument("--out", default=f"benchmarks/results/studies/{date.today():%Y-%m-%d}-loss_ablation.md")
    args = ap.parse_args()
    torch.set_num_threads(int(args.threads))
    if args.preset:
        arch = {"config": args.preset, "steps": args.steps}
        if args.width:
            arch["width"] = args.width
    else:
        arch = dict(width=args.width or 128, code_dim=64, pointnet_hidden=64, steps=args.steps)
    ds = Dataset(args.data)
    triplets, model = training_triplets(ds, "train", args.max_triplets or None,
                                        exclude_garments=[g for g in args.exclude_garments.split(",") if g])
    base = get_method("isomap-refine", **arch)
    t0 = time.perf_counter()
    train = base.prepare_many(triplets, model, "preparing training samples")
    val = []
    if args.until_converged:
        vt, _ = training_triplets(ds, args.val_split, args.val_pairs, seed=1, with_truth=True)
        val = base.prepare_many(vt, model, "preparing validation samples")
    done: dict = {}
    if args.work:
        args.work.mkdir(parents=True, exist_ok=True)
        if (args.work / "rows.json").is_file():
            done = {r["variant"]: r for r in json.loads((args.work / "rows.json").read_text())}
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
    print(f"prepared {len(train)} training, {len(val)} val and {len(test)} test samples in "  # noqa: T201
          f"{time.perf_counter() - t0:.0f} s", flush=True)
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
        if label in done:
            rows.append(done[label])
            print(f"{label}: kept from {args.work / 'rows.json'}", flush=True)  # noqa: T201
            continue
        method = get_method("isomap-refine", **arch, **{**ALL, **change})
        t = time.perf_counter()
        ckpt = args.work / (label.replace(" ", "_") + ".ckpt") if args.work else None
        method.fit_samples(train, model.name, val_samples=val or None, checkpoint=ckpt,
                           val_every=args.val_every, checkpoint_every=args.val_every,
                           until_converged=args.until_converged)
        h = method.history_
        final = float(np.mean([x[0] for x in method.loss_history_[-10:]]))
        rows.append({"variant": label, "final_loss": final, "train_seconds": round(time.perf_counter() - t, 1),
                     "steps": len(h.train), "stopped_by": h.stopped_by, "kept_step": h.best_step,
                     **score(method.predict_sample)})
        print(rows[-1], " load", os.getloadavg(), flush=True)  # noqa: T201
        if args.work:
            atomic_write_text(args.work / "rows.json", json.dumps([r for r in rows if "final_loss" in r
                                                                   and r["final_loss"] is not None], indent=1))
    if args.until_converged:
        scale = (f"every variant trained until the convergence rule stopped it or {args.steps} steps "
                 f"ran out (the last column says which), the rule watching the ED of {len(val)} "
                 f"`{args.val_split}` pairs every {args.val_every} steps; the kept weights are those "
                 f"of the best evaluation; network preset {args.preset or 'width ' + str(args.width or 128)}")
        head = f"{len(train)} training triplets, trained until converged"
    else:
        scale = ("REDUCED SCALE: a small network trained briefly from scratch per variant, so that the study "
                 "fits the shared machine; the figures compare loss configurations, not the shipped model")
        head = f"{len(train)} training triplets, {args.steps} steps, width {args.width or 128}"
    lines = [f"# Loss ablation of isomap-refine ({head}; scored on {len(test)} `{args.test_split}` pairs of "
             f"{data_label(args.data)}: "
             f"{', '.join(sorted({p.source.garment_id + ' ' + p.source.garment_type for p in pairs}))})", "",
             scale + ".", "",
             "P2S and ED in mm, IR in %. Produced by `python benchmarks/studies/loss_ablation.py "
             f"{command_line(sys.argv[1:], {str(args.data): 'DATA', str(args.work): 'W'})}`.", "",
             "| variant | P2S ↓ [mm] | ED ↓ [mm] | NC ↑ | IR ↓ [%] | steps (stopped by; step kept) |",
             "|---|---:|---:|---:|---:|---|"]
    lines += [f"| {r['variant']} | {1000 * r['p2s']:.2f} | {1000 * r['ed']:.2f} | {r['nc']:.4f} | {100 * r['ir']:.2f} | "
              + (f"{r['steps']} ({r['stopped_by']}; "
                 f"{'-' if r.get('kept_step') is None else r['kept_step']})" if r.get("steps") else "-")
              + " |"
              for r in rows]
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, "\n".join(lines) + "\n")
    atomic_write_text(out.with_suffix(".json"), json.dumps({"pairs": [p.pair_id for p in pairs], "rows": rows},
                                                           indent=2))
    print(f"wrote {out}")  # noqa: T201


if __name__ == "__main__":
    main()
