"""Compare retargeting method variants pair by pair, per garment type.

Runs each ``--methods`` entry (a ``get_method`` name, optional hyperparameters after ``:`` as
``key=value`` separated by ``,``) over the same pairs of a split and scores them with the
benchmark's own per-pair scoring (``evaluate_pair``: P2S, ED, NC, IR on ``--n-samples``
surface samples). Prints and writes a table of means per garment type and overall, and the
per-pair values (JSON). Used for the loose-garment variant and for the supervised vs self-supervised comparison.

    python benchmarks/studies/retarget_variants.py --data ROOT --split test \\
        --methods isomap isomap-offset isomap+penetration isomap-offset+penetration \\
        --out benchmarks/results/studies/2026-12-01-retarget_loose_garments.md
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

METRICS = ("p2s", "ed", "nc", "ir")


def _parse(spec: str) -> tuple[str, dict]:
    from dressmeup.hyperparameters import parse_value

    name, _, rest = spec.partition(":")
    kw = {}
    for item in filter(None, rest.split(",")):
        k, _, v = item.partition("=")
        kw[k] = parse_value(v)
    return name, kw


def main() -> None:
    import torch

    from dressmeup.bench.tasks.retarget.evaluate import evaluate_pair
    from dressmeup.data import Dataset
    from dressmeup.io.atomic import atomic_write_text
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.base import body_context
    from dressmeup.methods.retarget.run import body_model_for

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="test")
    ap.add_argument("--edition", default=None, help="use this edition's pairs (its split, sampled per track)")
    ap.add_argument("--track", default=None, help="only pairs of this track (re-pose, re-shape, cross)")
    ap.add_argument("--category", default=None, help="only source garments of this category (e.g. topwear)")
    ap.add_argument("--methods", nargs="+", required=True)
    ap.add_argument("--pairs-per-garment", type=int, default=0, help="seeded choice per garment (0: all)")
    ap.add_argument("--n-samples", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--versus", nargs="+", default=None,
                    help="paired differences to each of these methods (default: the first of --methods)")
    ap.add_argument("--title", default="Retargeting variants")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    missing = [m for m in args.versus or [] if m not in args.methods]
    if missing:
        raise SystemExit(f"--versus {missing}: not among --methods")
    torch.set_num_threads(1)

    ds = Dataset(args.data)
    if args.edition:
        from dressmeup.bench import load_edition
        from dressmeup.bench.tasks.retarget.data import edition_pairs

        pairs = edition_pairs(load_edition(args.edition), ds)
    else:
        pairs = ds.retarget_pairs(args.split)
    if args.track:
        pairs = [p for p in pairs if p.track == args.track]
    if args.category:
        pairs = [p for p in pairs if p.source.category == args.category]
    if args.pairs_per_garment:
        rng = np.random.default_rng(args.seed)
        by_g: dict[str, list] = {}
        for p in pairs:
            by_g.setdefault(p.source.garment_id, []).append(p)
        pairs = sorted((p for g in sorted(by_g) for p in
                        [by_g[g][i] for i in sorted(rng.choice(len(by_g[g]), min(args.pairs_per_garment,
                                                                                   len(by_g[g])), replace=False))]),
                       key=lambda p: p.pair_id)
    opts = {"n_samples": args.n_samples, "seed": 0, "chamfer_squared": True}
    models: dict = {}
    cache = []
    for p in pairs:
        g, gt = p.source.garment(), p.target.garment()
        src, tgt = p.source.body(), p.target.body()
        model = body_model_for(src, models)
        t = body_context(model, tgt)
        cache.append((p, g, gt, src, tgt, model, (t.skin_vertices, t.skin_faces)))
    rows = []
    t_all = time.perf_counter()
    for spec in args.methods:
        name, kw = _parse(spec)
        method = get_method(name, **kw)
        t0 = time.perf_counter()
        for p, g, gt, src, tgt, model, body in cache:
            pred = method.retarget(g.vertices, g.faces, src, tgt, model)
            vals, _ = evaluate_pair(pred, np.asarray(g.faces), np.asarray(gt.vertices), np.asarray(gt.faces), body,
                                    METRICS, opts)
            rows.append({"method": spec, "pair": p.pair_id, "garment": p.source.garment_id, "track": p.track,
                         "type": p.source.garment_type, "category": p.source.category, **vals})
        print(f"{spec}: {len(cache)} pairs in {time.perf_counter() - t0:.0f} s "  # noqa: T201
              f"(load {os.getloadavg()[0]:.1f})", flush=True)

    from dressmeup.bench.scoring.intervals import bootstrap_mean, paired_difference

    types = sorted({r["type"] for r in rows})
    lines = [f"# {args.title}", "",
             f"{len(cache)} `{args.split}` pairs of `{args.data}` "
             f"({', '.join(f'{t}: {sum(1 for c in cache if c[0].source.garment_type == t)}' for t in types)}); "
             f"per-pair scoring of the benchmark (`evaluate_pair`) on {args.n_samples} surface samples. "
             "P2S and ED in mm, IR in %. Produced by `python benchmarks/studies/retarget_variants.py "
             + " ".join(f"--methods {m}" if i == 0 else m for i, m in enumerate(args.methods)) + "`.", "",
             "| method | type | P2S ↓ [mm] | ED ↓ [mm] | NC ↑ | IR ↓ [%] |", "|---|---|---:|---:|---:|---:|"]
    for spec in args.methods:
        for ty in [*types, "all"]:
            sel = [r for r in rows if r["method"] == spec and (ty == "all" or r["type"] == ty)]
            mean = {m: float(np.nanmean([r[m] for r in sel])) for m in METRICS}
            lines.append(f"| {spec} | {ty} | {1000 * mean['p2s']:.2f} | {1000 * mean['ed']:.2f} | "
                         f"{mean['nc']:.4f} | {100 * mean['ir']:.2f} |")
    n_g = len({r["garment"] for r in rows})

    def ci(vals, units, scale, fmt):
        iv = bootstrap_mean(vals, units)
        return "-" if iv is None else f"{scale * iv.mean:{fmt}} [{scale * iv.lo:{fmt}}, {scale * iv.hi:{fmt}}]"

    for first in args.versus or args.methods[:1]:
        lines += ["", f"Means over all pairs with 95 % cluster-bootstrap intervals over the {n_g} source garments "
                  f"(`dressmeup.bench.scoring.intervals`), and the paired difference to `{first}` "
                  "(`Sep.`: its interval excludes 0).", "",
                  f"| method | P2S ↓ [mm] | NC ↑ | IR ↓ [%] | ΔP2S vs {first} [mm] | Sep. | ΔNC vs {first} | Sep. |",
                  "|---|---|---|---|---|:-:|---|:-:|"]
        ref = {r["pair"]: r for r in rows if r["method"] == first}
        for spec in args.methods:
            sel = [r for r in rows if r["method"] == spec]
            units = [r["garment"] for r in sel]
            cells = [ci([r[m] for r in sel], units, sc, f)
                     for m, sc, f in (("p2s", 1000, ".2f"), ("nc", 1, ".4f"), ("ir", 100, ".2f"))]
            diffs = []
            for m, sc, f in (("p2s", 1000, ".2f"), ("nc", 1, ".4f")):
                d = paired_difference([r[m] for r in sel], [ref[r["pair"]][m] for r in sel], units)
                diffs += ["-", ""] if d is None or spec == first else [
                    f"{sc * d.diff:+{f}} [{sc * d.lo:+{f}}, {sc * d.hi:+{f}}]", "yes" if d.separated else "no"]
            lines.append(f"| {spec} | " + " | ".join(cells + diffs) + " |")
    text = "\n".join(lines) + "\n"
    print(text)  # noqa: T201
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, text)
    atomic_write_text(out.with_suffix(".json"), json.dumps({"rows": rows, "seconds": time.perf_counter() - t_all},
                                                           indent=1))


if __name__ == "__main__":
    main()
