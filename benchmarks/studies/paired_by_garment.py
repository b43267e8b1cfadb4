"""Where two methods differ: the per-garment mean of their paired per-pair difference.

Reads the committed per-pair results of two methods scored on one edition
(``benchmarks/results/<edition>/<method>/per_sample.parquet``) and plots, for every test
garment, the mean over its pairs of ``B - A`` on one metric and track (bars, sorted, coloured by
category), with the overall mean and median of the per-pair
differences. Shows whether a mean difference is spread over the garments or made by a few
(no data needed, seconds).

    python benchmarks/studies/paired_by_garment.py benchmarks/results/synth-retarget-v5/skinning \\
        benchmarks/results/synth-retarget-v5/isomap-refine --track cross \\
        --out benchmarks/results/studies/2026-12-06-v5_cross_by_garment.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

#: metric -> (scale to the printed unit, unit)
METRICS = {"p2s": (1000.0, "mm"), "ed": (1000.0, "mm"), "ir": (100.0, "%")}


def per_garment(a: Path, b: Path, metric: str, track: str | None) -> tuple[pd.DataFrame, pd.Series]:
    """Per-garment mean of ``b - a`` (columns garment_id, category, mean, size) and
    the per-pair differences, in the metric's printed unit; pairs present in both only."""
    from dressmeup.bench.scoring.results import load_result

    scale = METRICS[metric][0]
    res_a, res_b = load_result(a), load_result(b)
    if res_a.summary["edition"]["hash"] != res_b.summary["edition"]["hash"]:
        raise SystemExit(f"{a} and {b} were scored on different editions")
    ra, rb = res_a.table.set_index("sample_id"), res_b.table.set_index("sample_id")
    if track:
        ra = ra[ra["track"] == track]
    ids = ra.index.intersection(rb.index)
    if ids.empty:
        raise SystemExit(f"no pair of track {track!r} in both {a} and {b}")
    diff = (rb.loc[ids, metric] - ra.loc[ids, metric]) * scale
    frame = ra.loc[ids, ["garment_id", "category"]].assign(diff=diff)
    by = frame.groupby(["garment_id", "category"])["diff"].agg(["mean", "size"]).reset_index()
    return by.sort_values("mean"), diff


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a", type=Path, help="result folder of method A (the reference)")
    ap.add_argument("b", type=Path, help="result folder of method B")
    ap.add_argument("--metric", default="p2s", choices=sorted(METRICS))
    ap.add_argument("--track", default="cross", help="track of the pairs ('' for all)")
    ap.add_argument("--out", type=Path, required=True, help="PNG to write")
    args = ap.parse_args()
    by, diff = per_garment(args.a, args.b, args.metric, args.track or None)
    unit = METRICS[args.metric][1]
    colours = {"topwear": "tab:blue", "bottomwear": "tab:orange", "dress": "tab:green"}
    fig, ax = plt.subplots(figsize=(max(6.0, 0.28 * len(by)), 4.2))
    ax.bar(range(len(by)), by["mean"], color=[colours.get(c, "grey") for c in by["category"]])
    ax.set_xticks(range(len(by)), by["garment_id"], rotation=90, fontsize=7)
    ax.axhline(0, color="black", lw=0.8)
    ax.axhline(diff.mean(), color="red", lw=1, ls="--", label=f"mean of the pairs {diff.mean():+.2f} {unit}")
    ax.axhline(diff.median(), color="purple", lw=1, ls=":",
               label=f"median of the pairs {diff.median():+.2f} {unit}")
    for cat, col in colours.items():
        if cat in set(by["category"]):
            ax.bar([0], [0], color=col, label=cat)
    ax.set_ylabel(f"{args.b.name} - {args.a.name}, {args.metric.upper()} [{unit}]")
    ax.set_title(f"{args.track or 'all'} pairs of {args.a.parent.name} ({len(diff)}), per test garment: "
                 f"below 0, {args.b.name} is closer", fontsize=9)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out} ({len(by)} garments, {len(diff)} pairs)")  # noqa: T201


if __name__ == "__main__":
    main()
