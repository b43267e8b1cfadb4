"""Per-item cost and worker memory of each job type the executors run (docs/scale-out.md).

Each job type runs in a fresh process, serially, on small real inputs; the script prints the
CPU seconds per item and the process's peak resident memory (what one Dask worker or pool
worker needs for that job type), with the load average. These figures feed the capacity
plan of docs/scale-out.md.

    python benchmarks/perf/scale_out.py                       # every job type
    python benchmarks/perf/scale_out.py --jobs score build    # some
    python benchmarks/perf/scale_out.py --score-data DIR      # score on this v2 data root

Job types: ``score`` (one retarget pair of synth-retarget-v2: 100,000 samples, six metrics;
needs its data, see benchmarks/perf/scoring.py), ``build`` (build-dataset: one synthetic
7-camera 640x576 capture session fused at 4 mm, garments extracted, UV-mapped and textured
at 1024 px; body source none, registration excluded), ``synth1`` (generator 1.1.0, anny:
one sample) and ``synth2`` (generator 2.x, anny: one garment on 2 subjects x 2 poses).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

JOBS = ("score", "build", "synth1", "synth2")


def _cpu() -> float:
    """CPU seconds of this process and its finished children (generator 2.x computes in
    spawned workers)."""
    r = [resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)]
    return sum(x.ru_utime + x.ru_stime for x in r)


def _vm_hwm_mb() -> float:
    """Peak resident memory of this process in MB (VmHWM: ru_maxrss would include the peak
    of the parent that started it). Spawned workers (generator 2.x) are not counted."""
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", nargs="+", default=list(JOBS), choices=JOBS)
    ap.add_argument("--score-data", default=None, help="synth-retarget-v2 data root")
    ap.add_argument("--one", default=None, help=argparse.SUPPRESS)  # child process
    args = ap.parse_args()
    if args.one:
        print(json.dumps(measure(args.one, args.score_data)))
        return
    for job in args.jobs:
        cmd = [sys.executable, __file__, "--one", job]
        if args.score_data:
            cmd += ["--score-data", args.score_data]
        out = subprocess.run(cmd, capture_output=True, text=True,
                             env={**os.environ, "DRESSMEUP_NO_PROGRESS": "1",
                                  "OMP_NUM_THREADS": "1"})
        lines = [ln for ln in out.stdout.splitlines() if ln.startswith("{")]
        if out.returncode or not lines:
            print(f"{job}: FAILED\n{out.stderr[-2000:]}")
            continue
        r = json.loads(lines[-1])
        print(f"{job:7s} {r['what']}: {r['cpu_per_item_s']:.2f} CPU-s per item "
              f"({r['items']} items, {r['wall_s']:.0f} s wall), peak RSS {r['peak_rss_mb']:.0f} MB "
              f"(load {r['load']})")


def measure(job: str, score_data: str | None) -> dict:
    tmp = Path(tempfile.mkdtemp(prefix=f"perf-scale-{job}-"))
    if job == "score":
        import numpy as np

        from dressmeup.bench import load_edition, write_submission
        from dressmeup.bench.scoring.validate import validate_submission
        from dressmeup.bench.tasks.retarget.evaluate import jobs as make_jobs
        from dressmeup.bench.tasks.retarget.evaluate import score_job
        from dressmeup.cache import cache_dir
        from dressmeup.data import Dataset

        ed = load_edition("synth-retarget-v2")
        root = Path(score_data) if score_data else cache_dir("bench") / "data" / ed.name
        pairs = Dataset(root).retarget_pairs(ed.split)
        rng = np.random.default_rng(0)
        preds = {p.pair_id: p.target.garment().vertices + rng.normal(0, 0.002, (1, 3))
                 for p in pairs}
        sub = write_submission(tmp / "sub", preds, edition=ed, method="gt+noise")
        rep = validate_submission(sub, ed, root)
        todo = make_jobs(ed, root, rep.files, rep.items)[:8]
        t, c = time.perf_counter(), _cpu()
        for j in todo:
            score_job(j)
        n, what = len(todo), "retarget pair (synth-retarget-v2, 100k samples, 6 metrics)"
    elif job == "build":
        from dressmeup.cli import main as cli
        from dressmeup.data.from_captures import build_session
        from dressmeup.extraction.pipeline import ExtractionConfig
        from dressmeup.fusion.pipeline import FusionConfig

        cli(["synth-capture", "mannequin", "--out", str(tmp / "s"), "--seed", "1"])
        t, c = time.perf_counter(), _cpu()
        build_session({"session": str(tmp / "s"), "fusion": FusionConfig(),
                       "extraction": ExtractionConfig(), "body": "none",
                       "body_model": "anny"})
        n, what = 1, "capture session (7 x 640x576 RGBD, 4 mm TSDF, 2 garments, no body)"
    elif job == "synth1":
        from dressmeup.data.synth import generate_dataset

        t, c = time.perf_counter(), _cpu()
        generate_dataset(tmp / "d", subjects=1, garments=1, poses=2, body_model="anny")
        n, what = 2, "sample (generator 1.1.0, anny)"
    else:
        from dressmeup.data.synth import generate_dataset

        t, c = time.perf_counter(), _cpu()
        generate_dataset(tmp / "d", version="2.1.0", subjects=2, poses=2,
                         garments_per_split=(1, 0, 0), categories=["topwear"],
                         body_model="anny")
        n, what = 4, "sample (generator 2.x, anny, 1 garment x 2 subjects x 2 poses)"
    cpu = _cpu() - c
    return {"job": job, "what": what, "items": n, "cpu_per_item_s": cpu / n,
            "wall_s": time.perf_counter() - t,
            "peak_rss_mb": _vm_hwm_mb(),
            "load": "{:.1f}/{:.1f}/{:.1f}".format(*os.getloadavg())}


if __name__ == "__main__":
    main()
