"""Number of patches against distortion for the neural UV method (thesis Figure 3.8).

Trains the method with K = 2, 4, 8, 12, 16 PatchNet patches on one closed mesh and scores
each UV map (the final chart count can differ from K: empty patches vanish, disconnected
islands and non-disk patches add charts).

    python benchmarks/studies/uv_patches.py [--mesh blob-1.5k] [--patches 2 4 8 12 16]

Writes benchmarks/results/studies/<date>-uv_patches.md.
"""

from __future__ import annotations

import argparse
import time
from datetime import date
from pathlib import Path

import numpy as np
import torch

from dressmeup.data.shapes import make_test_mesh
from dressmeup.io.atomic import atomic_write_text
from dressmeup.methods.uvparam.evaluate import markdown_table, score_uv
from dressmeup.methods.uvparam.neural.infer import infer
from dressmeup.methods.uvparam.neural.train import train

RESULTS = Path(__file__).resolve().parents[1] / "results" / "studies"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="blob-1.5k")
    ap.add_argument("--config", default="fast")
    ap.add_argument("--patches", type=int, nargs="+", default=[2, 4, 8, 12, 16])
    ap.add_argument("--uv-iters", type=int, default=400)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    torch.set_num_threads(1)
    V, F = make_test_mesh(args.mesh)
    rows = []
    for k in args.patches:
        t = time.perf_counter()
        model = train(V, F, args.config, progress=True, n_patches=k, uv_iters=args.uv_iters, seed=args.seed)
        r = score_uv(V, F, infer(model, V, F))
        r.update(K=k, train=time.perf_counter() - t)
        rows.append(r)
        print(k, {key: r[key] for key in ("n_charts", "qce", "ase", "flipped", "overlap")})
    cols = [("K", "K (PatchNet patches)", "{}"), ("n_charts", "final charts", "{}"), ("qce", "QCE ↓", "{:.3f}"),
            ("qce_max", "QCE max ↓", "{:.2f}"), ("ase", "ASE ↓", "{:.3f}"), ("flipped", "flipped ↓", "{:.2%}"),
            ("overlap", "overlap ↓", "{:.2%}"), ("train", "training (s)", "{:.0f}")]
    text = (f"# Patches against distortion (thesis Figure 3.8) on {args.mesh}\n\n{len(V)} vertices; "
            f"{args.config} configuration, {args.uv_iters} UV steps, seed {args.seed}; scored on the training mesh.\n\n"
            + markdown_table(rows, cols))
    RESULTS.mkdir(parents=True, exist_ok=True)
    atomic_write_text(RESULTS / f"{date.today():%Y-%m-%d}-uv_patches.md", text)
    print(text)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
