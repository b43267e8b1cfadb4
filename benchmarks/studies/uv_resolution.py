"""Time against resolution (thesis Table 3.2): train once at ~2.5k vertices, infer at 30k and
100k, against xatlas, per-chart SLIM and per-chart LSCM on the same meshes.

The neural column is inference only (operators computed, not cached) with the training time
reported separately, as in the thesis. QCE/ASE/flips are given beside the times.

    python benchmarks/studies/uv_resolution.py [--shape blob] [--resolutions 30k 100k]
        [--methods xatlas slim lscm] [--config fast]

Writes benchmarks/results/studies/<date>-uv_resolution_<shape>.md.
"""

from __future__ import annotations

import argparse
import time
from datetime import date
from pathlib import Path

import numpy as np

from dressmeup.cache import cache_dir
from dressmeup.data.shapes import make_test_mesh
from dressmeup.io.atomic import atomic_write_text
from dressmeup.methods.uvparam import get_method
from dressmeup.methods.uvparam.evaluate import markdown_table, score_uv
from dressmeup.methods.uvparam.neural.infer import infer
from dressmeup.methods.uvparam.neural.model import load_model, save_model
from dressmeup.methods.uvparam.neural.train import train

RESULTS = Path(__file__).resolve().parents[1] / "results" / "studies"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shape", default="blob")
    ap.add_argument("--train-resolution", default="2.5k")
    ap.add_argument("--resolutions", nargs="+", default=["30k", "100k"])
    ap.add_argument("--methods", nargs="+", default=["xatlas", "slim", "lscm"])
    ap.add_argument("--config", default="fast", choices=("fast", "reference"))
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    ckpt = cache_dir("uvparam_models") / f"{args.shape}-{args.train_resolution}-{args.config}-s0.pt"
    if ckpt.exists():
        model = load_model(ckpt)
    else:
        Vt, Ft = make_test_mesh(f"{args.shape}-{args.train_resolution}")
        model = train(Vt, Ft, args.config, progress=True)
        save_model(model, ckpt)
    rows = []
    for res in [args.train_resolution] + list(args.resolutions):
        V, F = make_test_mesh(f"{args.shape}-{res}")
        r = score_uv(V, F, infer(model, V, F, use_operator_cache=False, threads=args.threads))
        r.update(method=f"neural ({args.config}) inference", mesh=f"{args.shape}-{res}", n=len(V))
        rows.append(r)
        print(r["mesh"], r["method"], f"{r['seconds']:.2f} s", f"QCE {r['qce']:.3f}")
        for name in args.methods:
            t = time.perf_counter()
            out = get_method(name).parameterize(V, F)
            r = score_uv(V, F, out)
            r.update(method=name, mesh=f"{args.shape}-{res}", n=len(V), seconds=time.perf_counter() - t)
            rows.append(r)
            print(r["mesh"], name, f"{r['seconds']:.2f} s", f"QCE {r['qce']:.3f}")
    cols = [("mesh", "mesh", "{}"), ("n", "vertices", "{}"), ("method", "method", "{}"),
            ("seconds", "time (s) ↓", "{:.2f}"), ("qce", "QCE ↓", "{:.3f}"), ("ase", "ASE ↓", "{:.3f}"),
            ("flipped", "flipped ↓", "{:.2%}"), ("overlap", "overlap ↓", "{:.2%}"), ("n_charts", "charts", "{}")]
    h = model.history
    text = (f"# Time against resolution (thesis Table 3.2), {args.shape}\n\nNeural model trained once on "
            f"{args.shape}-{args.train_resolution} ({args.config} configuration) in "
            f"{h.get('seconds_total', float('nan')):.0f} s; the neural rows are inference only, operators "
            f"included (not cached), torch threads {args.threads}. Shared 2-core CPU.\n\n"
            + markdown_table(rows, cols))
    RESULTS.mkdir(parents=True, exist_ok=True)
    atomic_write_text(RESULTS / f"{date.today():%Y-%m-%d}-uv_resolution_{args.shape}.md", text)
    print(text)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
