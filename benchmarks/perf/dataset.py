"""Speed of the data stage, side by side with a named alternative.

1. Loading one sample's garment (50k vertices, per-corner UVs, texture) through
   ``Dataset(...)[i].garment()`` versus ``trimesh.load`` of the same PLY file.
2. With ``--generate``: wall time of ``generate_dataset`` for 3 subjects x 4 garments x
   5 poses with the anny body (the target is under 5 minutes on 2 cores).
3. With ``--edition E [--workers N]``: wall and CPU time (this process and its workers) of
   generating an edition's data, with the load average at start and end; for
   ``synth-retarget-v3`` the goal is 45 minutes on 2 idle cores (``--workers 2``).

Run: ``python benchmarks/perf/dataset.py [--generate] [--body-model anny]
[--edition synth-retarget-v3 --workers 2 --out DIR]``
"""

from __future__ import annotations

import argparse
import logging
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np


def _garment_50k():
    import trimesh

    m = trimesh.creation.uv_sphere(count=[190, 190])  # about 50k vertices after opening it
    V, F = np.asarray(m.vertices), np.asarray(m.faces)
    keep = V[F].mean(1)[:, 2] < 0.6  # open it (a garment has holes)
    F = F[keep]
    used = np.unique(F)
    remap = -np.ones(len(V), int)
    remap[used] = np.arange(len(used))
    V, F = V[used], remap[F]
    uv = np.random.default_rng(0).uniform(size=(3 * len(F), 2))
    return V * 0.3, F, uv, np.arange(3 * len(F)).reshape(-1, 3)


def bench_load(repeats: int = 15) -> None:
    import trimesh

    from dressmeup.data import Dataset, DatasetWriter

    V, F, uv, uvf = _garment_50k()
    with tempfile.TemporaryDirectory() as d:
        w = DatasetWriter(d, {"name": "bench"})
        w.add_sample(subject_id="S01", garment_id="G01", pose_id="P1", category="topwear",
                     garment_type="t-shirt", split="test", garment=(V, F, uv, uvf),
                     texture=np.zeros((64, 64, 3), np.uint8))
        w.finalize()
        ds = Dataset(d)
        path = Path(d) / ds.manifest["garment_path"][0]
        ds[0].garment()  # warm the imports
        from dressmeup.io.mesh import load_mesh

        sample = ds[0]
        t_ours, t_tri, t_g, t_lm = [], [], [], []
        logging.getLogger("trimesh").setLevel(logging.CRITICAL)
        for _ in range(repeats):
            t0 = time.perf_counter()
            g = Dataset(d)[0].garment()
            t_ours.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            trimesh.load(path, process=False)
            t_tri.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            sample.garment()
            t_g.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            load_mesh(path)
            t_lm.append(time.perf_counter() - t0)
        a, b = statistics.median(t_ours), statistics.median(t_tri)
        print(f"garment with {len(g.vertices)} vertices, {len(g.faces)} faces, per-corner UVs")
        print(f"{'method':44s} {'median ms':>10s}")
        print(f"{'Dataset(root)[0].garment() (manifest + mesh)':44s} {a * 1e3:10.1f}")
        print(f"{'sample.garment() (dataset already open)':44s} "
              f"{statistics.median(t_g) * 1e3:10.1f}")
        print(f"{'dressmeup.io.mesh.load_mesh(garment.ply)':44s} "
              f"{statistics.median(t_lm) * 1e3:10.1f}")
        print(f"{'trimesh.load(garment.ply, process=False)':44s} {b * 1e3:10.1f}")
        print(f"ratio trimesh / ours: {b / a:.2f}x")


def bench_generate(body_model: str, out: str | None) -> None:
    import torch

    from dressmeup.data.synth import generate_dataset

    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as d:
        root = out or os.path.join(d, "synth")
        t0 = time.perf_counter()
        generate_dataset(root, subjects=3, garments=4, poses=5, seed=0, body_model=body_model)
        dt = time.perf_counter() - t0
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        print(f"generate_dataset 3x4x5 ({body_model}): {dt:.1f} s "
              f"(target < 300 s on 2 cores; 1-min load average at the end {load:.1f})")


def bench_edition(edition: str, workers: int, out: str | None) -> None:
    import resource

    from dressmeup.bench.edition import load_edition
    from dressmeup.data.synth import generate_dataset

    pin = load_edition(edition).dataset
    kw = {"workers": workers} if str(pin.params.get("version", "")).startswith("2.") else {}
    with tempfile.TemporaryDirectory() as d:
        root = out or os.path.join(d, "synth")
        load0 = os.getloadavg()
        t0 = time.perf_counter()
        generate_dataset(root, seed=pin.seed, **pin.params, **kw)
        dt = time.perf_counter() - t0
        me = resource.getrusage(resource.RUSAGE_SELF)
        kids = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime
        print(f"{edition} with {workers} worker(s): {dt / 60:.1f} min wall, {cpu / 60:.1f} CPU "
              f"min (this process + workers); load average {load0[0]:.1f} at start, "
              f"{os.getloadavg()[0]:.1f} at the end (goal for synth-retarget-v3: 45 min "
              "on 2 idle cores)")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--generate", action="store_true", help="also time the 3x4x5 generation")
    p.add_argument("--body-model", default="anny")
    p.add_argument("--out", default=None, help="keep the generated dataset here")
    p.add_argument("--edition", default=None, help="time generating this edition's data")
    p.add_argument("--workers", type=int, default=2, help="worker processes (generator 2.x)")
    args = p.parse_args()
    if args.edition:
        bench_edition(args.edition, args.workers, args.out)
        return
    bench_load()
    if args.generate:
        bench_generate(args.body_model, args.out)


if __name__ == "__main__":
    main()
