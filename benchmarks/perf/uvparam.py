"""Speed of the neural UV method's inference against xatlas, side by side, on one new mesh.

The must-hold of issue 8: end-to-end inference of the trained neural method on a new
100k-vertex mesh (DiffusionNet operators computed, not read from a cache; PatchNet; charts;
MLP; xatlas packing) is faster than xatlas on the same mesh. Goals reported (met or not):
under 5 s, QCE within 15 % of per-chart LSCM's, flips under 1 %.

    python benchmarks/perf/uvparam.py                      # blob, fast config, 100k
    python benchmarks/perf/uvparam.py --config reference --shape torus --resolution 30k

Writes benchmarks/results/perf_uvparam_<shape>_<config>.md and prints the table.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from dressmeup.cache import cache_dir
from dressmeup.io.atomic import atomic_write_text
from dressmeup.methods.uvparam import get_method
from dressmeup.methods.uvparam.evaluate import markdown_table, score_uv
from dressmeup.methods.uvparam.neural.infer import infer
from dressmeup.methods.uvparam.neural.train import load_model, save_model, train
from dressmeup.methods.uvparam.shapes import make_test_mesh

RESULTS = Path(__file__).resolve().parents[1] / "results"


def trained_model(shape: str, config: str, train_res: str = "2.5k", seed: int = 0, **overrides):
    """Train (or reuse from the cache) a model on ``<shape>-<train_res>``."""
    key = f"{shape}-{train_res}-{config}-s{seed}" + "".join(f"-{k}{v}" for k, v in sorted(overrides.items()))
    path = cache_dir("uvparam_models") / f"{key}.pt"
    if path.exists():
        return load_model(path), path
    V, F = make_test_mesh(f"{shape}-{train_res}")
    model = train(V, F, config, progress=True, seed=seed, **overrides)
    save_model(model, path)
    return model, path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shape", default="blob")
    ap.add_argument("--resolution", default="100k")
    ap.add_argument("--config", default="fast", choices=("fast", "reference"))
    ap.add_argument("--threads", type=int, default=2, help="torch threads for neural inference")
    ap.add_argument("--skip-lscm", action="store_true")
    ap.add_argument("--skip-xatlas", action="store_true",
                    help="measure the neural inference only (no must-hold verdict)")
    ap.add_argument("--uv-iters", type=int, default=None,
                    help="override the configuration's UV training steps (inference time does not depend on it)")
    args = ap.parse_args()
    mesh_id = f"{args.shape}-{args.resolution}"
    overrides = {"uv_iters": args.uv_iters} if args.uv_iters else {}
    model, ckpt = trained_model(args.shape, args.config, **overrides)
    V, F = make_test_mesh(mesh_id)
    print(f"{mesh_id}: {len(V)} vertices, {len(F)} faces; model {ckpt.name} "
          f"(trained in {model.history.get('seconds_total', float('nan')):.1f} s)")
    rows = []
    t, c = time.perf_counter(), time.process_time()
    res_n = infer(model, V, F, use_operator_cache=False, threads=args.threads)
    wall_n, cpu_n = time.perf_counter() - t, time.process_time() - c
    r = score_uv(V, F, res_n)
    r.update(method=f"neural ({args.config}, inference)", wall=wall_n, cpu=cpu_n,
             stages=", ".join(f"{k[8:]} {v:.2f}" for k, v in res_n.info.items() if k.startswith("seconds_")))
    rows.append(r)
    print(r, flush=True)
    if args.skip_xatlas:
        cols = [("method", "method", "{}"), ("wall", "wall time (s) ↓", "{:.2f}"), ("cpu", "CPU time (s) ↓", "{:.2f}"),
                ("qce", "QCE ↓", "{:.3f}"), ("flipped", "flipped ↓", "{:.2%}"), ("stages", "stages (s)", "{}")]
        text = (f"# Neural UV inference on {mesh_id} ({args.config} configuration"
                f"{', ' + str(args.uv_iters) + ' UV steps' if args.uv_iters else ''})\n\n"
                f"Parameters: {model.n_parameters}; no xatlas run.\n\n" + markdown_table(rows, cols))
        RESULTS.mkdir(parents=True, exist_ok=True)
        atomic_write_text(RESULTS / f"perf_uvparam_{mesh_id}_{args.config}.md", text)
        print(text)
        return
    t, c = time.perf_counter(), time.process_time()
    res_x = get_method("xatlas").parameterize(V, F)
    wall_x, cpu_x = time.perf_counter() - t, time.process_time() - c
    r = score_uv(V, F, res_x)
    r.update(method="xatlas", wall=wall_x, cpu=cpu_x, stages="")
    rows.append(r)
    print(r, flush=True)
    if not args.skip_lscm:
        t, c = time.perf_counter(), time.process_time()
        res_l = get_method("lscm").parameterize(V, F)
        r = score_uv(V, F, res_l)
        r.update(method="lscm (per chart)", wall=time.perf_counter() - t, cpu=time.process_time() - c,
                 stages=", ".join(f"{k[8:]} {v:.2f}" for k, v in res_l.info.items() if k.startswith("seconds_")))
        rows.append(r)
    cols = [("method", "method", "{}"), ("wall", "wall time (s) ↓", "{:.2f}"), ("cpu", "CPU time (s) ↓", "{:.2f}"), ("qce", "QCE ↓", "{:.3f}"),
            ("ase", "ASE ↓", "{:.3f}"), ("flipped", "flipped ↓", "{:.2%}"), ("overlap", "overlap ↓", "{:.2%}"),
            ("n_charts", "charts", "{}"), ("stages", "stages (s)", "{}")]
    table = markdown_table(rows, cols)
    ratio = wall_x / wall_n
    checks = [f"- neural inference faster than xatlas on {mesh_id}: "
              f"{'MET' if wall_n < wall_x else 'NOT MET'} ({wall_n:.2f} s vs {wall_x:.2f} s wall, xatlas/neural = {ratio:.1f}x; "
              f"CPU time {cpu_n:.2f} s vs {cpu_x:.2f} s, {cpu_x / cpu_n:.1f}x)",
              f"- under 5 s: {'MET' if wall_n < 5 else 'NOT MET'} ({wall_n:.2f} s)",
              f"- flips under 1 %: {'MET' if rows[0]['flipped'] < 0.01 else 'NOT MET'} ({rows[0]['flipped']:.2%})"]
    if not args.skip_lscm:
        rel = rows[0]["qce"] / rows[2]["qce"] - 1
        checks.append(f"- QCE within 15 % of per-chart LSCM: {'MET' if rel <= 0.15 else 'NOT MET'} "
                      f"({rows[0]['qce']:.3f} vs {rows[2]['qce']:.3f}, {rel:+.1%})")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    text = (f"# Neural UV inference vs xatlas on {mesh_id}\n\n{len(V)} vertices, {len(F)} faces; model trained on "
            f"{args.shape}-2.5k with the {args.config} configuration{' (' + str(args.uv_iters) + ' UV steps)' if args.uv_iters else ''}; operators computed (no cache); "
            f"torch threads {args.threads}; 1-min load average at the end {load:.1f} on {os.cpu_count()} cores.\n\n"
            + table + "\n" + "\n".join(checks) + "\n")
    RESULTS.mkdir(parents=True, exist_ok=True)
    atomic_write_text(RESULTS / f"perf_uvparam_{mesh_id}_{args.config}.md", text)
    print(text)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
