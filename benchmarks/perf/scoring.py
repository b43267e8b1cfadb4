"""Scoring throughput of the retarget benchmark on 50k-vertex garments.

Builds a small dataset of large garments (open tubes of about 50,000 vertices / 100,000
faces, deformed per pose) on a body model, writes a ground-truth + noise submission, and
scores it with the default protocol (100,000 surface samples per mesh, all six metrics) once
in-process (1 worker) and once with the process pool (2 workers). Prints samples/s, the
ratio pool / serial, and the projected time of a 250-pair edition.

    python benchmarks/perf/scoring.py                     # procedural body, 12 pairs
    python benchmarks/perf/scoring.py --body anny --pairs-per-garment 6 --garments 2
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np


def tube(radius, y0, y1, nu, nv):
    u = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    v = np.linspace(y0, y1, nv)
    uu, vv = np.meshgrid(u, v)
    V = np.stack([radius * np.cos(uu), vv, radius * np.sin(uu)], -1).reshape(-1, 3)
    j, i = np.meshgrid(np.arange(nv - 1), np.arange(nu), indexing="ij")
    a = (j * nu + i).ravel()
    b = (j * nu + (i + 1) % nu).ravel()
    c, d = a + nu, b + nu
    F = np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)])
    return V, F.astype(np.int64)


def build(root: Path, body: str, garments: int, poses: int) -> Path:
    from dressmeup.body import get_body_model
    from dressmeup.data.writer import DatasetWriter

    model = get_body_model(body)
    base = model.posed(model.default_params()).vertices
    lo, hi = base.min(0), base.max(0)
    h = hi[1] - lo[1]
    w = DatasetWriter(root, {"name": "perf-scoring", "version": "1",
                             "generator": {"name": "perf-scoring", "version": "1",
                                           "params": {"garments": garments, "poses": poses,
                                                      "body": body}, "seed": 0}})
    for g in range(garments):
        V0, F = tube(0.2 * h / 1.8, lo[1] + 0.45 * h, lo[1] + 0.8 * h, 250, 200)
        V0[:, [0, 2]] += (base[:, [0, 2]].mean(0))
        for p in range(poses):
            params = model.default_params()
            params.pose[16, 2] = -0.3 * p
            params.pose[17, 2] = 0.3 * p
            V = V0 + 0.01 * p * np.sin(5 * V0[:, [1, 2, 0]] + g)
            w.add_sample(subject_id="S01", garment_id=f"G{g:02d}", pose_id=f"P{p}",
                         category=("topwear", "bottomwear", "dress")[g % 3],
                         garment_type="tube", split="test", garment=(V, F), body=params)
    w.finalize()
    return root


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--body", default="procedural", help="body model (procedural, anny)")
    ap.add_argument("--garments", type=int, default=2)
    ap.add_argument("--poses", type=int, default=3)
    ap.add_argument("--samples", type=int, default=100_000)
    ap.add_argument("--skip-serial", action="store_true")
    args = ap.parse_args()
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")
    import json

    from dressmeup.bench import score_submission, write_submission
    from dressmeup.data import Dataset

    tmp = Path(tempfile.mkdtemp(prefix="perf-scoring-"))
    t0 = time.perf_counter()
    root = build(tmp / "data", args.body, args.garments, args.poses)
    ds = Dataset(root)
    pairs = ds.retarget_pairs("test")
    n_v = ds.manifest["garment_vertices"].iloc[0]
    n_f = ds.manifest["garment_faces"].iloc[0]
    print(f"dataset: {len(pairs)} pairs, garments of {n_v} vertices / {n_f} faces, "
          f"body {args.body} (built in {time.perf_counter() - t0:.1f} s)")
    ed = {"schema": "dressmeup-edition/1", "name": "perf-scoring-v1", "version": 1,
          "task": "retarget",
          "dataset": {"kind": "generated", "generator": "perf-scoring", "generator_version": "1",
                      "params": {"garments": args.garments, "poses": args.poses,
                                 "body": args.body}, "seed": 0},
          "split": "test", "metrics": ["p2s", "p2s_bi", "chamfer", "ed", "nc", "ir"],
          "options": {"n_samples": args.samples, "seed": 0}}
    (tmp / "ed.json").write_text(json.dumps(ed))
    rng = np.random.default_rng(0)
    preds = {p.pair_id: p.target.garment().vertices + rng.normal(0, 0.002, (n_v, 3))
             for p in pairs}
    sub = write_submission(tmp / "sub", preds, edition=tmp / "ed.json", method="gt+noise")
    import resource

    def cpu() -> float:
        r = [resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
        return sum(x.ru_utime + x.ru_stime for x in r)

    print(f"load average before scoring: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores "
          "(other work on the machine slows every wall-clock figure below)")
    times, cpus = {}, {}
    for workers in ([1, 2] if not args.skip_serial else [2]):
        t, c = time.perf_counter(), cpu()
        res = score_submission(sub, tmp / "ed.json", root, tmp / f"res-{workers}",
                               workers=workers, show_progress=False)
        times[workers] = time.perf_counter() - t
        cpus[workers] = cpu() - c
        assert res.summary["counts"]["failed"] == 0
        print(f"workers={workers}: {len(pairs)} pairs in {times[workers]:.1f} s wall "
              f"= {len(pairs) / times[workers]:.2f} pairs/s; CPU {cpus[workers]:.1f} s "
              f"= {cpus[workers] / len(pairs):.2f} CPU-s per pair (validation, body posing "
              f"and pool start-up included)")
    rate = len(pairs) / times[2]
    print(f"projected 250-pair edition, 2 workers, at this load: {250 / rate / 60:.1f} min; "
          f"on 2 idle cores (CPU-bound): {250 * cpus[2] / len(pairs) / 2 / 60:.1f} min "
          f"(target < 5 min)")
    if 1 in times:
        print(f"ratio: process pool (2 workers) vs in-process serial: "
              f"{times[1] / times[2]:.2f}x faster")


if __name__ == "__main__":
    main()
