"""Scoring throughput: serial vs the local process pool vs a Dask LocalCluster, in one run.

Scores one submission (ground truth + 2 mm Gaussian noise per vertex, so every metric does
its full work) on a retargeting edition three ways, back to back: in-process (1 worker), the
local process pool (``--workers``, default 2) and a Dask LocalCluster of the same size on
127.0.0.1 (``--executor dask``). Prints wall seconds, pairs/s, CPU seconds per pair, the peak
memory of one worker, the ratios (goal: LocalCluster within 15 % of the pool and >= 1.7x
serial on 2 idle cores) and the LocalCluster start-up time, with the load average beside
every figure (other work on the machine slows every wall-clock figure).

    python benchmarks/perf/scoring.py                         # synth-retarget-v2 (60 pairs)
    python benchmarks/perf/scoring.py --edition synth-retarget-v3 --data /path/to/v3/data
    python benchmarks/perf/scoring.py --procedural            # 12 pairs of 50k-vertex tubes

The edition's data are generated into the toolkit cache when ``--data`` is not given (v2:
about 20 min on 2 cores). Per-pair CPU seconds feed the capacity plan in docs/scale-out.md.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
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


def load() -> str:
    return "load {:.1f}/{:.1f}/{:.1f}".format(*os.getloadavg())


def cpu_s() -> float:
    r = [resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    return sum(x.ru_utime + x.ru_stime for x in r)


def _own_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _peak_rss_mb() -> float:
    """Peak resident memory of the calling process in MB: VmHWM (ru_maxrss would carry the
    parent's peak over into a spawned child on Linux)."""
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def procedural_edition(tmp: Path, args: argparse.Namespace) -> tuple[Path, Path]:
    root = build(tmp / "data", args.body, args.garments, args.poses)
    ed = {"schema": "dressmeup-edition/1", "name": "perf-scoring-v1", "version": 1,
          "task": "retarget",
          "dataset": {"kind": "generated", "generator": "perf-scoring", "generator_version": "1",
                      "params": {"garments": args.garments, "poses": args.poses,
                                 "body": args.body}, "seed": 0},
          "split": "test", "metrics": ["p2s", "p2s_bi", "chamfer", "ed", "nc", "ir"],
          "options": {"n_samples": args.samples, "seed": 0}}
    (tmp / "ed.json").write_text(json.dumps(ed))
    return root, tmp / "ed.json"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--edition", default="synth-retarget-v2",
                    help="retarget edition to score (default synth-retarget-v2: 60 pairs)")
    ap.add_argument("--data", default=None, help="its data root (default: generate into the "
                                                  "toolkit cache)")
    ap.add_argument("--procedural", action="store_true",
                    help="instead: a procedural dataset of 50k-vertex tube garments")
    ap.add_argument("--body", default="procedural", help="--procedural: body model")
    ap.add_argument("--garments", type=int, default=2, help="--procedural: garments")
    ap.add_argument("--poses", type=int, default=3, help="--procedural: poses per garment")
    ap.add_argument("--samples", type=int, default=100_000, help="--procedural: samples")
    ap.add_argument("--workers", type=int, default=2, help="pool and LocalCluster size")
    ap.add_argument("--modes", nargs="+", default=["serial", "pool", "dask"],
                    choices=["serial", "pool", "dask"])
    args = ap.parse_args()
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")

    from dressmeup.bench import load_edition, score_submission, write_submission
    from dressmeup.data import Dataset
    from dressmeup.executors import LocalExecutor

    tmp = Path(tempfile.mkdtemp(prefix="perf-scoring-"))
    t0 = time.perf_counter()
    if args.procedural:
        root, edition = procedural_edition(tmp, args)
    else:
        from dressmeup import runs
        from dressmeup.cache import cache_dir

        edition = load_edition(args.edition)
        root = Path(args.data) if args.data else runs.build_data(
            edition, cache_dir("bench") / "data" / edition.name, log=print)
    ed = load_edition(edition)
    ds = Dataset(root)
    try:
        from dressmeup.bench.tasks.retarget.data import edition_pairs

        pairs = edition_pairs(ed, ds)
    except ImportError:  # toolkits before per-track pair sampling
        pairs = ds.retarget_pairs(ed.split)
    n_v = int(ds.manifest["garment_vertices"].median())
    print(f"edition {ed.name}: {len(pairs)} pairs, garments of ~{n_v} vertices, data {root} "
          f"(ready in {time.perf_counter() - t0:.0f} s)")
    rng = np.random.default_rng(0)
    preds = {}
    for p in pairs:
        V = p.target.garment().vertices
        preds[p.pair_id] = V + rng.normal(0, 0.002, V.shape)
    sub = write_submission(tmp / "sub", preds, edition=ed, method="gt+noise")

    print(f"{load()} on {os.cpu_count()} cores before scoring")
    wall, cpu, mem, loads, tables = {}, {}, {}, {}, {}
    startup = None
    for mode in args.modes:
        if mode == "dask":
            from dressmeup.executors.dask_executor import DaskExecutor

            ex = DaskExecutor(args.workers, log=None)
            t = time.perf_counter()
            ex.__enter__()
            startup = (time.perf_counter() - t, load())
        else:
            ex = LocalExecutor(1 if mode == "serial" else args.workers)
        t, c = time.perf_counter(), cpu_s()
        if mode == "dask":
            c_workers = sum(ex.client.run(_own_cpu_s).values())
        res = score_submission(sub, ed, root, tmp / f"res-{mode}", executor=ex,
                               show_progress=False)
        wall[mode], loads[mode] = time.perf_counter() - t, load()
        if mode == "dask":
            # this process (client + scheduler) and the workers (not its children)
            cpu[mode] = cpu_s() - c + sum(ex.client.run(_own_cpu_s).values()) - c_workers
            mem[mode] = max(ex.client.run(_peak_rss_mb).values())
            ex.__exit__(None, None, None)
        else:
            cpu[mode] = cpu_s() - c
            # pool workers are gone by now: their peak is not measured
            mem[mode] = _peak_rss_mb() if mode == "serial" else float("nan")
        tables[mode] = res.table
        assert res.summary["counts"]["failed"] == 0, res.summary["counts"]
        print(f"{mode:6s}: {len(pairs)} pairs in {wall[mode]:6.1f} s wall = "
              f"{len(pairs) / wall[mode]:5.2f} pairs/s; CPU {cpu[mode]:6.1f} s = "
              f"{cpu[mode] / len(pairs):5.2f} CPU-s/pair; peak RSS of a worker {mem[mode]:5.0f} MB "
              f"({loads[mode]})")
    if startup:
        print(f"LocalCluster start-up ({args.workers} workers): {startup[0]:.1f} s ({startup[1]})")
    metrics = list(ed.metrics)
    for mode in tables:
        if mode != args.modes[0]:
            a = tables[args.modes[0]].sort_values("sample_id")[metrics].to_numpy()
            b = tables[mode].sort_values("sample_id")[metrics].to_numpy()
            same = np.array_equal(a, b, equal_nan=True)
            print(f"per-item metrics {mode} vs {args.modes[0]}: "
                  f"{'bit-identical' if same else 'DIFFERENT'}")
    if "serial" in wall and "pool" in wall:
        print(f"ratio pool vs serial: {wall['serial'] / wall['pool']:.2f}x faster")
    if "serial" in wall and "dask" in wall:
        print(f"ratio LocalCluster vs serial: {wall['serial'] / wall['dask']:.2f}x faster "
              f"(goal >= 1.7x on 2 idle cores); with start-up "
              f"{wall['serial'] / (wall['dask'] + startup[0]):.2f}x")
    if "pool" in wall and "dask" in wall:
        print(f"LocalCluster vs pool: {100 * (wall['dask'] / wall['pool'] - 1):+.1f} % wall "
              f"(goal within 15 %); with start-up "
              f"{100 * ((wall['dask'] + startup[0]) / wall['pool'] - 1):+.1f} %")


if __name__ == "__main__":
    main()
