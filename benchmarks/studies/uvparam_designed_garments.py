"""The shipped pretrained neural UV models against LSCM on the same charts, on a generator-4
edition's garments as designed (``dressmeup synth OUT --edition E --designed-garments``):
per garment the neural map (its category's model, and the ``general`` model) and LSCM on the
neural charts (``lscm-on-charts``), scored with the uvparam task's metrics (QCE, flipped and
overlapping share, seams, charts).

The v5 test garments are the ones no model saw: build them with the edition's secret
(maintainers; ``--secret FILE``) into a folder outside the project; the study writes only
aggregate figures and per-garment ids, types and scores, never a mesh.

    dressmeup synth /tmp/v5test --edition synth-retarget-v5 --designed-garments \\
        --secret ../shared/secrets/synth-retarget-v5.secret --workers 2
    python benchmarks/studies/uvparam_designed_garments.py --data /tmp/v5test --split test \\
        --out benchmarks/results/studies/2026-12-06-uvparam-v5-test-garments.md
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

METRICS = ("qce", "qce_max", "flip", "overlap", "seam_length", "charts")
#: row name -> (method, hyperparameters)
RUNS = {
    "neural (category model)": ("neural", {"pretrained": "category"}),
    "neural (general model)": ("neural", {"pretrained": "general"}),
    "lscm on the neural charts": ("lscm-on-charts", {"pretrained": "category"}),
}


def score(root: Path, split: str) -> list[dict]:
    """One row per garment and run: ids, type, category, vertices and the metrics."""
    from dressmeup.bench.tasks.uvparam.evaluate import evaluate_uv
    from dressmeup.data.synth.designed4 import designed_garments
    from dressmeup.io.mesh import load_mesh
    from dressmeup.methods.uvparam import get_method

    methods = {name: get_method(m, **kw) for name, (m, kw) in RUNS.items()}
    rows = []
    for gid, rec, path in designed_garments(root, split):
        mesh = load_mesh(path)
        for name, method in methods.items():
            t0 = time.perf_counter()
            res = method.parameterize(mesh.vertices, mesh.faces, category=rec["category"])
            sec = time.perf_counter() - t0
            rows.append({"garment": gid, "type": rec["type"], "category": rec["category"],
                         "vertices": len(mesh.vertices), "run": name, "seconds": sec,
                         "track": res.info.get("track"),
                         **evaluate_uv(mesh.vertices, mesh.faces, res.uv, res.uv_faces,
                                       METRICS, {})})
    return rows


def report(rows: list[dict], root: Path, split: str) -> str:
    """The study's Markdown: means per run, the neural/LSCM ratio per garment and type."""
    import pandas as pd

    t = pd.DataFrame(rows)
    head = (f"# Pretrained neural UV on the {split} garments of {root.name} (as designed)\n\n"
            f"Command: `python benchmarks/studies/uvparam_designed_garments.py --data "
            f"{root} --split {split}`; load {os.getloadavg()[0]:.1f}. {t['garment'].nunique()} "
            f"garments ({', '.join(f'{k} {v}' for k, v in t.drop_duplicates('garment')['category'].value_counts().items())}), "
            f"{int(t['vertices'].min())}-{int(t['vertices'].max())} vertices.\n\n")
    lines = ["| run | track | QCE mean (median) | QCE max (worst garment) | flipped | overlap | "
             "seam length | charts | s a garment |", "|---|---|--:|--:|--:|--:|--:|--:|--:|"]
    for name in RUNS:
        r = t[t["run"] == name]
        lines.append(f"| {name} | {r['track'].iloc[0]} | {r['qce'].mean():.3f} "
                     f"({r['qce'].median():.3f}) | {r['qce'].max():.3f} | "
                     f"{100 * r['flip'].mean():.2f} % | {100 * r['overlap'].mean():.2f} % | "
                     f"{r['seam_length'].mean():.2f} | {r['charts'].mean():.1f} | "
                     f"{r['seconds'].mean():.2f} |")
    nn = t[t["run"] == "neural (category model)"].set_index("garment")
    ls = t[t["run"] == "lscm on the neural charts"].set_index("garment")
    ratio = nn["qce"] / ls["qce"]
    within = int((ratio <= 1.15).sum())
    lines += ["", f"Neural (category model) QCE over LSCM's on the same charts: mean "
              f"{ratio.mean():.3f}, median {ratio.median():.3f}; within 15 % on {within} of "
              f"{len(ratio)} garments; flipped faces {100 * nn['flip'].mean():.2f} % "
              f"(garments with any: {int((nn['flip'] > 0).sum())}).", "",
              "| type | garments | neural QCE mean | LSCM on its charts | ratio | flipped |",
              "|---|--:|--:|--:|--:|--:|"]
    by = nn.assign(lscm=ls["qce"], ratio=ratio).groupby("type")
    for typ, g in by:
        lines.append(f"| {typ} | {len(g)} | {g['qce'].mean():.3f} | {g['lscm'].mean():.3f} | "
                     f"{g['ratio'].mean():.3f} | {100 * g['flip'].mean():.2f} % |")
    return head + "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, type=Path,
                    help="a folder of designed garments (or a generated generator-4 dataset)")
    ap.add_argument("--split", default="test", choices=["train", "val", "test"])
    ap.add_argument("--out", type=Path, default=None, help="write the Markdown here too")
    args = ap.parse_args(argv)
    text = report(score(args.data, args.split), args.data, args.split)
    print(text)
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
