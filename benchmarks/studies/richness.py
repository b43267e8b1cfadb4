"""Richness study (thesis section 4.6.2, Table 4.6) on a body template.

Richness (``dressmeup.metrics.richness``, k = 10, lower is better) of Isomap embeddings of
dimension 16/32/64/128/256 (full classical MDS of the all-pairs heat-method geodesics), of
landmark MDS at the same dimensions (the `auto` choice of ``isomap`` past 3000 skin vertices),
and of low-dimensional alternatives: the raw template coordinates (3-d) and Laplacian
eigenmaps (3-d and 16-d). The geodesic matrix is the reference ranking.

    python benchmarks/studies/richness.py --body anny --out benchmarks/results/studies/2026-11-22-richness_anny.md

Writes a Markdown table and a JSON file with the same numbers.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from datetime import date
from pathlib import Path

import numpy as np

THESIS = {"BodyMap (thesis)": 0.955, "Isomap 16 (thesis)": 0.491, "Isomap 32 (thesis)": 0.473,
          "Isomap 64 (thesis)": 0.437, "Isomap 128 (thesis)": 0.426, "Isomap 256 (thesis)": 0.424}


def main() -> None:
    import torch

    from dressmeup.body import get_body_model
    from dressmeup.io.atomic import atomic_write_text
    from dressmeup.methods.retarget.embedding import (
        geodesic_matrix,
        heat_solver,
        landmark_geodesics,
        skin_component,
    )
    from dressmeup.methods.retarget.mds import classical_mds, landmark_mds, laplacian_eigenmaps
    from dressmeup.metrics import richness

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--body", default="anny", help="body model whose template is studied (default anny)")
    ap.add_argument("--dims", default="16,32,64,128,256")
    ap.add_argument("--landmarks", type=int, default=2000, help="landmarks of landmark MDS")
    ap.add_argument("--k", type=int, default=10, help="Richness neighbourhood size")
    ap.add_argument("--subset", type=int, default=0,
                    help="score on a random subset of this many vertices (0: all skin vertices)")
    ap.add_argument("--no-full", action="store_true",
                    help="skip full MDS (its O(n^3) eigensolver takes hours past ~10k vertices on 2 "
                         "cores); then only the --subset rows of the geodesic matrix are computed")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None, help="Markdown output (default benchmarks/results/studies/<date>-richness_<body>.md)")
    args = ap.parse_args()
    torch.set_num_threads(1)
    dims = [int(d) for d in args.dims.split(",")]

    model = get_body_model(args.body)
    ids, F = skin_component(model.template_vertices, model.faces)
    V = np.asarray(model.template_vertices)[ids]
    n = len(ids)
    print(f"{args.body}: {n} skin vertices, {len(F)} faces")  # noqa: T201
    rng = np.random.default_rng(args.seed)
    sub = np.sort(rng.choice(n, args.subset, replace=False)) if 0 < args.subset < n else np.arange(n)
    t = time.perf_counter()
    if args.no_full:
        solver = heat_solver(V, F)
        Dsub = np.stack([solver.compute_distance(int(i))[sub] for i in sub]).astype(np.float32)
        Dsub = 0.5 * (Dsub + Dsub.T)
        np.fill_diagonal(Dsub, 0.0)
    else:
        D = geodesic_matrix(V, F)
        Dsub = D[np.ix_(sub, sub)]
    t_geo = time.perf_counter() - t
    print(f"heat geodesics for scoring: {t_geo:.1f} s", flush=True)  # noqa: T201

    rows = []

    def score(label, emb, seconds):
        r = richness(Dsub, emb[sub], k=args.k)
        rows.append({"representation": label, "dim": int(emb.shape[1]), "richness": float(r),
                     "seconds": round(float(seconds), 2)})
        print(f"{label:32s} R = {r:.4f} ({seconds:.1f} s)", flush=True)  # noqa: T201

    if not args.no_full:
        t = time.perf_counter()
        full = classical_mds(D, dim=max(dims), seed=args.seed)
        t_full = time.perf_counter() - t + t_geo
        del D
        for d in dims:
            score(f"Isomap {d} (full MDS)", full[:, :d], t_full)
    t = time.perf_counter()
    lm, Dl = landmark_geodesics(V, F, args.landmarks, seed=args.seed)
    lmds = landmark_mds(Dl, lm, dim=max(dims), seed=args.seed)
    t_lm = time.perf_counter() - t
    for d in dims:
        score(f"Isomap {d} (landmark MDS, {len(lm)})", lmds[:, :d], t_lm)
    score("template coordinates (xyz)", V.astype(np.float32), 0.0)
    t = time.perf_counter()
    eig = laplacian_eigenmaps(V, F, dim=16)
    t_eig = time.perf_counter() - t
    score("Laplacian eigenmaps 3", eig[:, :3], t_eig)
    score("Laplacian eigenmaps 16", eig, t_eig)

    out = Path(args.out or f"benchmarks/results/studies/{date.today():%Y-%m-%d}-richness_{args.body}.md")
    lines = [f"# Richness study on the `{args.body}` template ({n} skin vertices"
             f"{f', scored on {len(sub)} random vertices' if len(sub) < n else ''}, k = {args.k})",
             "", "Lower is better. Seconds: time to build the embedding (full MDS includes the "
             "all-pairs geodesics). Produced by `python benchmarks/studies/richness.py "
             f"{' '.join(sys.argv[1:])}`.", "",
             "| representation | dim | Richness ↓ | seconds |", "|---|---:|---:|---:|"]
    lines += [f"| {r['representation']} | {r['dim']} | {r['richness']:.4f} | {r['seconds']} |" for r in rows]
    lines += ["", "Thesis Table 4.6 (SMPL, 6890 vertices) for comparison: "
              + ", ".join(f"{k} {v}" for k, v in THESIS.items()), ""]
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, "\n".join(lines))
    atomic_write_text(out.with_suffix(".json"), json.dumps(
        {"body": args.body, "skin_vertices": n, "scored_vertices": int(len(sub)), "k": args.k,
         "landmarks": args.landmarks, "rows": rows, "thesis": THESIS}, indent=2))
    print(f"wrote {out}")  # noqa: T201


if __name__ == "__main__":
    main()
