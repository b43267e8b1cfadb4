"""Per-pose, per-subject and per-garment means of a scored synth-registration-v3 result.

    python benchmarks/registration_poses.py RESULT_DIR DATA_ROOT \
        > benchmarks/results/synth-registration-v3/poses.md

RESULT_DIR is a folder written by ``dressmeup score`` (``per_sample.parquet`` +
``summary.json``), DATA_ROOT the edition's data (pose names, subjects and garment types come
from its ``dataset.json`` and manifest). Errors in mm; each scan is one sample.
"""

from __future__ import annotations

import argparse
import sys


def tables(result_dir: str, data_root: str) -> str:
    """Markdown: one table per grouping (pose, subject, garment type), then every scan."""
    from dressmeup.bench.scoring.results import load_result
    from dressmeup.data import Dataset

    res = load_result(result_dir)
    ds = Dataset(data_root)
    m = ds.manifest.set_index("sample_id")
    t = res.table.copy()
    t["pose_id"] = [m.loc[s, "pose_id"] for s in t["sample_id"]]
    t["pose"] = [ds.info["poses"][p] for p in t["pose_id"]]
    t["subject"] = [f"{m.loc[s, 'subject_id']} {ds.info['subjects'][m.loc[s, 'subject_id']]['name']}"
                    for s in t["sample_id"]]
    t["garment"] = [m.loc[s, "garment_type"] for s in t["sample_id"]]
    metrics = [c for c in ("v2v", "mpjpe", "scan_p2s") if c in t]
    for c in metrics:
        t[c] = t[c] * 1000.0
    head = "| {} | scans | " + " | ".join(f"{c} mm" for c in metrics) + " |\n"
    rule = "|---|--:|" + "--:|" * len(metrics) + "\n"
    s = res.summary
    ed = s.get("edition", {})
    meth = s.get("method", {})
    hyper = meth.get("hyperparameters") or {}
    name = meth.get("method", "") + (f" {hyper}" if hyper else "")
    out = [f"# {ed.get('name', '')}: `{name}` by pose, subject and garment\n\n",
           f"CPU per scan {meth.get('runtime_per_sample_s', float('nan')):.1f} s "
           f"({meth.get('hardware', '')}). ",
           f"Edition hash `{str(ed.get('hash', ''))[:12]}`, {len(t)} scans; mean over the scans "
           f"of each group (mm). Made by `benchmarks/registration_poses.py RESULT DATA`.\n"]
    t = t.sort_values(["pose_id", "sample_id"])
    for key in ("pose", "subject", "garment"):
        out.append(f"\n### by {key}\n\n" + head.format(key) + rule)
        for name, g in t.groupby(key, sort=False):
            out.append(f"| {name} | {len(g)} | "
                       + " | ".join(f"{g[c].mean():.1f}" for c in metrics) + " |\n")
    out.append("\n### every scan\n\n| scan | pose | garment | " + " | ".join(
        f"{c} mm" for c in metrics) + " |\n|---|---|---|" + "--:|" * len(metrics) + "\n")
    for r in t.sort_values("sample_id").itertuples():
        out.append(f"| {r.sample_id} | {r.pose} | {r.garment} | "
                   + " | ".join(f"{getattr(r, c):.1f}" for c in metrics) + " |\n")
    return "".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("result", help="result folder written by dressmeup score")
    ap.add_argument("data", help="the edition's data root")
    args = ap.parse_args(argv)
    sys.stdout.write(tables(args.result, args.data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
