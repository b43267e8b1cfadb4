"""Correspondence-noise ablation (thesis section 4.5.2, Table 4.2).

Gaussian noise N(0, sigma) (metres, per coordinate) is added to every coarse correspondence
x_i before the refinement network; sigma in {0, 0.001, 0.01, 0.1}. Reports P2S, ED, NC, IR
(the benchmark's own per-pair scoring, ``evaluate_pair``) for ``isomap`` (coarse only) and
``isomap-refine`` on the first ``--pairs`` pairs of a split.

    python benchmarks/studies/correspondence_noise.py --data ROOT --split test \\
        --weights dressmeup/methods/retarget/weights/isomap_refine_anny.pt
"""

from __future__ import annotations

import argparse
import json
import sys
from datetime import date
from pathlib import Path

import numpy as np
from study_labels import command_line, data_label, weights_label

METRICS = ("p2s", "ed", "nc", "ir")


def evaluate(method, pairs, models, n_samples: int) -> dict[str, float]:
    from dressmeup.bench.tasks.retarget.evaluate import evaluate_pair
    from dressmeup.methods.retarget.base import body_context
    from dressmeup.methods.retarget.run import body_model_for

    rows = []
    for p in pairs:
        g, gt = p.source.garment(), p.target.garment()
        src, tgt = p.source.body(), p.target.body()
        model = body_model_for(src, models)
        pred = method.retarget(g.vertices, g.faces, src, tgt, model)
        t = body_context(model, tgt)
        vals, _ = evaluate_pair(pred, np.asarray(g.faces), np.asarray(gt.vertices), np.asarray(gt.faces),
                                (t.skin_vertices, t.skin_faces), METRICS,
                                {"n_samples": n_samples, "seed": 0, "chamfer_squared": True})
        rows.append(vals)
    return {m: float(np.nanmean([r[m] for r in rows])) for m in METRICS}


def main() -> None:
    import torch

    from dressmeup.data import Dataset
    from dressmeup.io.atomic import atomic_write_text
    from dressmeup.methods.retarget import get_method

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="test")
    ap.add_argument("--pairs-per-garment", type=int, default=2, help="seeded choice of pairs per garment")
    ap.add_argument("--weights", default=None, help="isomap-refine checkpoint (default: the shipped one)")
    ap.add_argument("--sigmas", default="0,0.001,0.01,0.1")
    ap.add_argument("--n-samples", type=int, default=20000)
    ap.add_argument("--out", default=f"benchmarks/results/studies/{date.today():%Y-%m-%d}-correspondence_noise.md")
    args = ap.parse_args()
    torch.set_num_threads(1)
    rng = np.random.default_rng(0)
    by_garment: dict = {}
    for p in Dataset(args.data).retarget_pairs(args.split):
        by_garment.setdefault(p.source.garment_id, []).append(p)
    pairs = [grp[i] for g, grp in sorted(by_garment.items())
             for i in sorted(rng.choice(len(grp), min(args.pairs_per_garment, len(grp)), replace=False))]
    models: dict = {}
    rows = []
    for sigma in [float(s) for s in args.sigmas.split(",")]:
        for name in ("isomap", "isomap-refine"):
            kw = {"correspondence_noise": sigma}
            if name == "isomap-refine" and args.weights:
                kw["weights"] = args.weights
            res = evaluate(get_method(name, **kw), pairs, models, args.n_samples)
            rows.append({"method": name, "sigma": sigma, **res})
            print(f"{name:14s} sigma={sigma:<6} " + " ".join(f"{k}={v:.5f}" for k, v in res.items()),  # noqa: T201
                  flush=True)
    lines = [f"# Correspondence-noise ablation ({len(pairs)} pairs of split `{args.split}` of "
             f"{data_label(args.data)}: "
             f"{', '.join(sorted({p.source.garment_id + ' ' + p.source.garment_type for p in pairs}))})",
             "", "Noise N(0, sigma) added to every coarse correspondence before the refinement "
             f"(thesis Table 4.2), weights {weights_label(args.weights)}. P2S and ED in mm, IR in %. "
             "Produced by `python benchmarks/studies/correspondence_noise.py "
             f"{command_line(sys.argv[1:], {str(args.data): 'DATA'})}`.", "",
             "| method | sigma (m) | P2S ↓ [mm] | ED ↓ [mm] | NC ↑ | IR ↓ [%] |", "|---|---:|---:|---:|---:|---:|"]
    lines += [f"| {r['method']} | {r['sigma']} | {1000 * r['p2s']:.2f} | {1000 * r['ed']:.2f} | {r['nc']:.4f} | "
              f"{100 * r['ir']:.2f} |" for r in rows]
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, "\n".join(lines) + "\n")
    atomic_write_text(out.with_suffix(".json"), json.dumps({"pairs": [p.pair_id for p in pairs], "rows": rows},
                                                           indent=2))
    print(f"wrote {out}")  # noqa: T201


if __name__ == "__main__":
    main()
