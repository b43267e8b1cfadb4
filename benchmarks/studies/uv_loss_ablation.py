"""Loss ablation of the neural UV method (thesis Figure 3.9).

Trains the UV MLPs with growing sets of losses on the same PatchNet charts (PatchNet is
trained once and shared) and scores each result: cycle only; cycle + isometric; the thesis'
full set (cycle, isometric, angle, area with weights 1, 1, 0.001, 0.001); and the full set
with angle and area weights raised to 0.1 (to show what the small thesis weights leave out).

    python benchmarks/studies/uv_loss_ablation.py [--mesh blob-1.5k] [--uv-iters 400]

Writes benchmarks/results/studies/<date>-uv_loss_ablation.md.
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
VARIANTS = [
    ("cycle only", (1.0, 0.0, 0.0, 0.0)),
    ("cycle + iso", (1.0, 1.0, 0.0, 0.0)),
    ("cycle + iso + angle + area (thesis weights)", (1.0, 1.0, 0.001, 0.001)),
    ("cycle + iso + angle + area (0.1 each)", (1.0, 1.0, 0.1, 0.1)),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="blob-1.5k")
    ap.add_argument("--config", default="fast")
    ap.add_argument("--uv-iters", type=int, default=400)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    torch.set_num_threads(1)
    V, F = make_test_mesh(args.mesh)
    base = train(V, F, args.config, progress=True, patchnet_only=True, seed=args.seed)
    rows = []
    for name, w in VARIANTS:
        t = time.perf_counter()
        model = train(V, F, args.config, progress=True, init_patchnet=base.patchnet, weights=w,
                      uv_iters=args.uv_iters, seed=args.seed)
        r = score_uv(V, F, infer(model, V, F))
        r.update(variant=name, weights=", ".join(f"{x:g}" for x in w), train=time.perf_counter() - t,
                 cycle=model.history["cycle"][-1])
        rows.append(r)
        print(name, {k: r[k] for k in ("qce", "ase", "flipped", "overlap")})
    cols = [("variant", "losses", "{}"), ("weights", "weights (cycle, iso, angle, area)", "{}"),
            ("qce", "QCE ↓", "{:.3f}"), ("ase", "ASE ↓", "{:.3f}"), ("flipped", "flipped ↓", "{:.2%}"),
            ("overlap", "overlap ↓", "{:.2%}"), ("cycle", "final cycle loss", "{:.2e}"),
            ("n_charts", "charts", "{}"), ("train", "UV training (s)", "{:.0f}")]
    text = (f"# Loss ablation (thesis Figure 3.9) on {args.mesh}\n\n{len(V)} vertices; {args.config} configuration, "
            f"{args.uv_iters} UV steps, one shared PatchNet (seed {args.seed}); scored on the training mesh.\n\n"
            + markdown_table(rows, cols))
    RESULTS.mkdir(parents=True, exist_ok=True)
    atomic_write_text(RESULTS / f"{date.today():%Y-%m-%d}-uv_loss_ablation.md", text)
    print(text)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
