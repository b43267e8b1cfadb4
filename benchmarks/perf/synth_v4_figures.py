"""The v4 ground truth's figures, measured on generated generator-3.x data.

1. **Plausibility** from every sample's ``generator/stats/*.json``: share of the garment's
   area inside the body (face centroids, winding number; median, mean, max), self-intersecting
   faces (pymeshlab; median, mean, max), edge strain, the solver's end state (residual,
   unconverged samples, iterations), per garment type and pose.
2. **Sensitivity**: for one seeded sample of each chosen test garment, the garment is
   dressed again (a) with the solver run twice as long (twice the intermediate bodies, half
   the tolerances; :meth:`DressSettings.longer`) and (b) from a start moved by 5 mm per
   vertex in a random direction, in worker processes with the generator's canonical numerics;
   the figure is the per-vertex distance to the stored ground truth (median over all those
   vertices, mean, 95th percentile, and per sample).

    python benchmarks/perf/synth_v4_figures.py --data DIR [--garments 12] [--workers 2]
        [--out benchmarks/results/studies/YYYY-MM-DD-synth-retarget-v4_figures]

Goals of the v4 editions: inside area median <= 0.3 % (max <= 2 %), median self-intersecting
faces <= 5, sensitivity <= 1 mm median per vertex. The load average is printed beside every
timing.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time
import zlib
from pathlib import Path

import numpy as np

from dressmeup.data.synth.stats import read_stats

GOALS = {"inside_median": 0.3, "inside_max": 2.0, "self_int_median": 5, "sensitivity_mm": 1.0}


def load() -> str:
    return f"{os.getloadavg()[0]:.1f}"


def plausibility(root: Path) -> dict:
    """Figures over every sample's stats (module docstring, item 1)."""
    rows = read_stats(root)
    inside = np.array([r["inside_area_pct"] for r in rows])
    selfint = np.array([r["self_intersecting_faces"] for r in rows])

    def by(key):
        out = {}
        for r in rows:
            out.setdefault(r[key], []).append(r)
        return {k: {"n": len(v),
                    "inside_median": float(np.median([r["inside_area_pct"] for r in v])),
                    "inside_max": float(np.max([r["inside_area_pct"] for r in v])),
                    "self_int_median": float(np.median([r["self_intersecting_faces"]
                                                        for r in v]))}
                for k, v in sorted(out.items())}

    return {"n": len(rows),
            "inside_median": float(np.median(inside)), "inside_mean": float(inside.mean()),
            "inside_max": float(inside.max()),
            "self_int_median": float(np.median(selfint)),
            "self_int_mean": float(selfint.mean()), "self_int_max": int(selfint.max()),
            "strain_mean": float(np.mean([r["strain_mean"] for r in rows])),
            "grad_norm_median": float(np.median([r["grad_norm"] for r in rows])),
            "grad_norm_max": float(np.max([r["grad_norm"] for r in rows])),
            "unconverged": int(sum(not r["converged"] for r in rows)),
            "iterations_mean": float(np.mean([r["iterations"] for r in rows])),
            "by_type": by("garment_type"), "by_pose": by("pose")}


def chosen_samples(root: Path, n_garments: int, seed: int = 0) -> list[tuple[str, str, str]]:
    """``(garment, subject, pose)`` of one seeded sample per test garment (the first
    ``n_garments`` test garments)."""
    info = json.loads((root / "dataset.json").read_text())
    test = sorted(g for g, v in info["garments"].items() if v["split"] == "test")[:n_garments]
    subjects, poses = sorted(info["subjects"]), sorted(info["poses"])
    out = []
    for g in test:
        rng = np.random.default_rng([seed, zlib.crc32(g.encode())])
        out.append((g, subjects[rng.integers(len(subjects))], poses[rng.integers(len(poses))]))
    return out


def redress(root: Path, samples: list[tuple[str, str, str]], settings, workers: int) -> dict:
    """The chosen samples dressed again with ``settings`` (generator workers, canonical
    numerics): sample id -> vertices ``(n, 3)``."""
    from dressmeup.data.synth.common import GarmentItem, PlanJob
    from dressmeup.data.synth.generator3 import DressJob
    from dressmeup.data.synth.jobs import run_jobs

    info = json.loads((root / "dataset.json").read_text())
    p = info["generator"]["params"]
    plan = {"subjects": info["subjects"], "poses": info["poses"], "garments": info["garments"]}
    job = DressJob(body_model=p["body_model"], **PlanJob.of_plan(plan), edge=p["edge_length"],
                   seed=info["generator"]["seed"], texture_size=p["texture_size"],
                   write_scan=False, scan_body=p.get("scan_body", "whole"), settings=settings)
    items = [GarmentItem(g, info["garments"][g], ((s, q),)) for g, s, q in samples]
    out = {}
    for res in run_jobs(job, items, workers):
        for smp in res.samples:
            out[f"{smp.sid}-{res.gid}-{smp.pid}"] = smp.V
    return out


def sensitivity(root: Path, n_garments: int, workers: int) -> dict:
    """Per-vertex moves of the chosen samples under each variant (module docstring, item 2)."""
    from dressmeup.data import Dataset
    from dressmeup.data.synth.quasistatic import DressSettings

    info = json.loads((root / "dataset.json").read_text())
    base = DressSettings.from_dict(info["generator"]["params"].get("dress", {}))
    samples = chosen_samples(root, n_garments)
    ds = Dataset(root)
    out = {}
    for name, settings in (("longer", base.longer(2.0)),
                           ("perturbed", dataclasses.replace(base, start_jitter=0.005,
                                                             start_seed=1))):
        t0 = time.perf_counter()
        again = redress(root, samples, settings, workers)
        moved, per = [], {}
        for sid, V in again.items():
            d = np.linalg.norm(V - ds[sid].garment().vertices, axis=1) * 1000
            moved.append(d)
            per[sid] = {"median_mm": float(np.median(d)), "mean_mm": float(d.mean()),
                        "max_mm": float(d.max())}
        m = np.concatenate(moved)
        out[name] = {"median_mm": float(np.median(m)), "mean_mm": float(m.mean()),
                     "p95_mm": float(np.quantile(m, 0.95)), "samples": per,
                     "wall_s": round(time.perf_counter() - t0, 1), "load": load()}
        print(f"sensitivity {name}: median {out[name]['median_mm']:.3f} mm, mean "
              f"{out[name]['mean_mm']:.3f}, p95 {out[name]['p95_mm']:.3f} over {len(per)} "
              f"samples ({out[name]['wall_s']} s wall, load {load()})", flush=True)
    return out


def report(fig: dict, sens: dict) -> str:
    """Markdown of the figures against the goals."""
    def ok(v, goal):
        return "met" if v <= goal else "missed"

    worst = max((s["median_mm"] for s in sens.values()), default=float("nan"))
    lines = ["| figure | value | goal | |", "|---|---|---|---|",
             f"| garment area inside the body, median | {fig['inside_median']:.2f} % | <= 0.3 % "
             f"| {ok(fig['inside_median'], GOALS['inside_median'])} |",
             f"| garment area inside the body, max | {fig['inside_max']:.2f} % | <= 2 % | "
             f"{ok(fig['inside_max'], GOALS['inside_max'])} |",
             f"| self-intersecting faces, median | {fig['self_int_median']:g} | <= 5 | "
             f"{ok(fig['self_int_median'], GOALS['self_int_median'])} |"]
    for name, s in sens.items():
        lines.append(f"| sensitivity ({name}), median per vertex | {s['median_mm']:.3f} mm "
                     f"(mean {s['mean_mm']:.2f}, p95 {s['p95_mm']:.2f}) | <= 1 mm | "
                     f"{ok(s['median_mm'], GOALS['sensitivity_mm'])} |")
    lines += ["", f"{fig['n']} samples; mean inside {fig['inside_mean']:.2f} %, mean "
              f"self-intersecting faces {fig['self_int_mean']:.1f} (max {fig['self_int_max']}), "
              f"mean edge strain {fig['strain_mean']:.4f}; solver residual median "
              f"{fig['grad_norm_median']:.4f}, max {fig['grad_norm_max']:.3f}, "
              f"{fig['unconverged']} samples whose last solve missed its tolerance; "
              f"{fig['iterations_mean']:.0f} iterations a sample. Sensitivity: the larger "
              f"median is {worst:.3f} mm.", "",
              "| garment type | n | inside median % | inside max % | self-int. median |",
              "|---|---|---|---|---|"]
    for k, v in fig["by_type"].items():
        lines.append(f"| {k} | {v['n']} | {v['inside_median']:.2f} | {v['inside_max']:.2f} | "
                     f"{v['self_int_median']:g} |")
    lines += ["", "| pose | n | inside median % | inside max % | self-int. median |",
              "|---|---|---|---|---|"]
    for k, v in fig["by_pose"].items():
        lines.append(f"| {k} | {v['n']} | {v['inside_median']:.2f} | {v['inside_max']:.2f} | "
                     f"{v['self_int_median']:g} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="generated generator-3.x data (full part)")
    ap.add_argument("--garments", type=int, default=12,
                    help="test garments whose sensitivity is measured (0: none)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=None, help="write OUT.md and OUT.json")
    args = ap.parse_args()
    root = Path(args.data)
    fig = plausibility(root)
    sens = sensitivity(root, args.garments, args.workers) if args.garments else {}
    md = report(fig, sens)
    print(md)
    if args.out:
        Path(args.out + ".md").write_text(md)
        Path(args.out + ".json").write_text(json.dumps({"plausibility": fig,
                                                        "sensitivity": sens}, indent=1) + "\n")


if __name__ == "__main__":
    main()
