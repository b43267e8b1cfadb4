"""Checkerboard pictures of every UV method on one mesh (docs/images/uv-<method>.png).

    python benchmarks/studies/uv_pictures.py [--mesh blob-2.5k] [--methods xatlas lscm harmonic slim neural]

The neural picture uses the model the speed benchmark trains on ``<shape>-2.5k`` (fast
configuration; trained here if missing) - inference only, like the other methods' runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from dressmeup.cache import cache_dir
from dressmeup.data.shapes import make_test_mesh
from dressmeup.methods.uvparam import get_method
from dressmeup.methods.uvparam.evaluate import score_uv
from dressmeup.methods.uvparam.neural.infer import infer
from dressmeup.methods.uvparam.neural.model import load_model, save_model
from dressmeup.methods.uvparam.neural.train import train
from dressmeup.viz.uv_checker import render_uv_checker

IMAGES = Path(__file__).resolve().parents[2] / "docs" / "images"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="blob-2.5k")
    ap.add_argument("--methods", nargs="+", default=["xatlas", "lscm", "harmonic", "slim", "neural"])
    ap.add_argument("--out", type=Path, default=IMAGES)
    args = ap.parse_args()
    V, F = make_test_mesh(args.mesh)
    for name in args.methods:
        if name == "neural":
            ckpt = cache_dir("uvparam_models") / f"{args.mesh.split('-')[0]}-2.5k-fast-s0.pt"
            if ckpt.exists():
                model = load_model(ckpt)
            else:
                model = train(*make_test_mesh(f"{args.mesh.split('-')[0]}-2.5k"), "fast", progress=True)
                save_model(model, ckpt)
            res = infer(model, V, F)
        else:
            res = get_method(name).parameterize(V, F)
        s = score_uv(V, F, res)
        title = (f"{name} on {args.mesh}: {res.n_charts} charts, QCE {s['qce']:.3f}, ASE {s['ase']:.3f}, "
                 f"flipped {s['flipped']:.1%}, overlap {s['overlap']:.1%}")
        path = render_uv_checker(V, F, res.uv, res.uv_faces, args.out / f"uv-{name}.png", title=title,
                                 chart_ids=res.chart_ids)
        print(path, title)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
