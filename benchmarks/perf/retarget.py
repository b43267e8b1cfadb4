"""Per-new-target time of ``isomap-refine`` and of the non-learned path on a ~30k-vertex
garment: today's general path beside the prepared (precomputed) paths, measured in one run.

    python benchmarks/perf/retarget.py --body anny --vertices 30000 --threads 2

The garment is a cut of the body's torso and arms, offset 1 cm along the normals and
subdivided (midpoint, k times) so that it has about ``--vertices`` vertices. Paths:

- old general path (``precompute=False``): per target, eq. 4.1 (3D k-NN on the source skin),
  eq. 4.4 (128-d k-NN over the template skin), the target neighbours, the whole network; for
  the non-learned path also the factorisation of the detail-transfer system;
- prepared path (``precompute=True``, the default): eq. 4.1, the k-NN of eq. 4.4, the garment's
  PointNet code and its embedding's share of the network's first layer once per garment and
  source body; per new target a gather, the target neighbours, the body PointNet and the rest
  of the network; the non-learned path is the gather + one back-substitution of the
  prefactored Laplacian system (``DetailTransfer``).

Each per-target figure is the median over ``--targets`` poses (after a warm-up), with the
1-minute load average beside it (the machine may be shared: figures are pessimistic there).
Goals (issue 15): ``isomap-refine`` <= 1 s, non-learned <= 50 ms per new target after the
garment's preparation. The network's weights do not change its cost: without shipped weights
a freshly initialised network of the same shape is timed.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def _garment(model, params, n_min: int):
    import trimesh

    from dressmeup.methods.retarget.base import body_context

    ctx = body_context(model, params)
    y = model.template_vertices[:, 1]
    skin = np.zeros(model.n_vertices, dtype=bool)
    skin[ctx.skin_ids] = True
    # a band above mid-height holding about n_min / 4^k vertices, so that k midpoint
    # subdivisions (x4 vertices each) land near n_min
    band = skin & (y > np.percentile(y, 50)) & (y < np.percentile(y, 80))
    k = max(0, int(np.ceil(np.log(n_min / band.sum()) / np.log(4))))
    want = n_min / 4 ** k
    ys = np.sort(y[skin & (y > np.percentile(y, 50))])
    top = ys[min(len(ys) - 1, int(want * 1.02))]
    sel = skin & (y > np.percentile(y, 50)) & (y <= top)
    idx = np.flatnonzero(sel)
    remap = -np.ones(model.n_vertices, dtype=np.int64)
    remap[idx] = np.arange(len(idx))
    F = remap[model.faces[sel[model.faces].all(axis=1)]]
    normals = np.zeros((model.n_vertices, 3))
    normals[ctx.skin_ids] = ctx.skin_normals()
    V = ctx.vertices[idx] + 0.01 * normals[idx]
    for _ in range(k):
        V, F = trimesh.remesh.subdivide(V, F)
    return np.asarray(V), np.asarray(F)


def _load() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


def _targets(model, src, n: int):
    """``n`` target poses: the arms and elbows bent by different seeded angles."""
    rng = np.random.default_rng(0)
    out = []
    for _ in range(n):
        t = src.copy()
        t.pose = np.array(t.pose, dtype=np.float64, copy=True)
        for j, sign in ((16, -1.0), (17, 1.0)):
            t.pose[j] = [0.0, 0.0, sign * rng.uniform(0.2, 0.9)]
        for j in (18, 19):
            t.pose[j] = [0.0, rng.uniform(-0.8, 0.0), 0.0]
        out.append(t)
    return out


def _median_per_target(fn, targets, warmup: bool = True) -> tuple[float, float]:
    """Median seconds of ``fn(target)`` over the targets (after one warm-up), and the load."""
    if warmup:
        fn(targets[0])
    times = []
    for t in targets:
        t0 = time.perf_counter()
        fn(t)
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), os.getloadavg()[0]


def _learned(args, model, V, F, src, targets, row) -> tuple[float, float, float]:
    """Time isomap-refine's old and prepared paths and the fast network: (old, new, fast) seconds."""
    from dressmeup.methods.retarget import get_method

    kw = {"weights": args.weights} if args.weights else {}
    old = get_method("isomap-refine", precompute=False, **kw)
    new = get_method("isomap-refine", **kw)
    try:
        old.ensure_network(model)
        new.ensure_network(model)
        net_label = "trained weights"
    except Exception:  # noqa: BLE001  (no weights: a fresh network costs the same)
        for m in (old, new):
            m.network_ = m.new_network().eval()
            m.body_model_name_ = model.name
        net_label = "fresh network"
    print(f"isomap-refine: width {new.config.width}, codes {new.config.code_dim}, PointNet hidden {new.config.pointnet_hidden} "  # noqa: T201
          f"({net_label})")
    new.embedding(model)  # the template embedding is a one-off per template (cached)
    # the old path caches nothing per garment: no warm-up needed (the template embedding is built above)
    t_old, l_old = _median_per_target(lambda t: old.retarget(V, F, src, t, model), targets[:2], warmup=False)
    row("isomap-refine, old general path (both k-NN + whole network per target)", t_old, l_old)
    t0 = time.perf_counter()
    new.retarget(V, F, src, targets[0], model)
    row("isomap-refine, one-time preparation of the garment (first call)", time.perf_counter() - t0,
        os.getloadavg()[0])
    t_new, l_new = _median_per_target(lambda t: new.retarget(V, F, src, t, model), targets)
    row("isomap-refine, prepared path per new target", t_new, l_new)
    split = new.last_timing_
    print("    split of the last call: " + ", ".join(f"{k} {v:.3f}" for k, v in split.items()))  # noqa: T201

    # the fast preset's size (a fresh network: the shipped file may carry another size)
    fast = get_method("isomap-refine-fast", **({"width": args.fast_width} if args.fast_width else {}))
    fast.network_ = fast.new_network().eval()
    fast.body_model_name_ = model.name
    t_fast, l_fast = _median_per_target(lambda t: fast.retarget(V, F, src, t, model), targets)
    c = fast.config
    row(f"isomap-refine-fast (width {c.width}, codes {c.code_dim}, {c.k_neighbors} neighbours), "
        "prepared path per new target", t_fast, l_fast)

    return t_old, t_new, t_fast


def main() -> None:
    import torch

    from dressmeup.body import get_body_model
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.base import body_context
    from dressmeup.methods.retarget.detail import DetailTransfer, detail_transfer
    from dressmeup.methods.retarget.prepared import prepare_garment

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--body", default="anny")
    ap.add_argument("--vertices", type=int, default=30000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--targets", type=int, default=5, help="new targets timed per path (median)")
    ap.add_argument("--weights", default=None, help="isomap-refine checkpoint (default: shipped, else fresh)")
    ap.add_argument("--fast-width", type=int, default=None,
                    help="decoder width of the 'fast' network timed too (default: its preset's)")
    ap.add_argument("--skip-learned", action="store_true", help="time the non-learned paths only")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    model = get_body_model(args.body)
    src = model.default_params()
    V, F = _garment(model, src, args.vertices)
    targets = _targets(model, src, args.targets)
    print(f"body {args.body}; garment {len(V)} vertices, {len(F)} faces; torch threads {args.threads}; "  # noqa: T201
          f"{len(targets)} new targets (median); {_load()}")
    rows = []

    def row(label, sec, load):
        rows.append((label, sec, load))
        print(f"  {label}: {sec:.4f} s (load {load:.1f})", flush=True)  # noqa: T201

    t_old = t_new = t_fast = float("nan")
    new = get_method("isomap-refine")
    if not args.skip_learned:
        t_old, t_new, t_fast = _learned(args, model, V, F, src, targets, row)

    # ---- non-learned: coarse + detail transfer
    def old_nonlearned(t):
        x = get_method("isomap", precompute=False).retarget(V, F, src, t, model)
        return detail_transfer(V, F, x)

    t_old_nl, l_old_nl = _median_per_target(old_nonlearned, targets[:2], warmup=False)
    row("isomap+detail, old path (k-NN searches + factorisation per target)", t_old_nl, l_old_nl)
    emb = new.embedding(model)
    s = body_context(model, src)
    t0 = time.perf_counter()
    prep = prepare_garment(V, F, s.skin_vertices, s.skin_normals(), emb.embedding, use_cache=False)
    detail = DetailTransfer(V, F)
    row("non-learned one-time preparation (eq. 4.1, k-NN of eq. 4.4, LU of the detail system)",
        time.perf_counter() - t0, os.getloadavg()[0])
    posed = {id(t): body_context(model, t) for t in targets}
    t_nl, l_nl = _median_per_target(lambda t: detail.apply(prep.coarse(posed[id(t)].skin_vertices)), targets)
    row("isomap+detail, prepared: gather + back-substitution per new (posed) target", t_nl, l_nl)
    t_nlo, l_nlo = _median_per_target(
        lambda t: detail.apply(prep.with_offset(posed[id(t)].skin_vertices, posed[id(t)].skin_normals())), targets)
    row("isomap-offset+detail, prepared (incl. target skin normals)", t_nlo, l_nlo)
    t_pose, l_pose = _median_per_target(lambda t: body_context(model, t), targets)
    row(f"posing the target body ({args.body}; the input of every path, not included above)", t_pose, l_pose)

    print("\n| path | seconds per new target | load (1 min) |\n|---|---:|---:|")  # noqa: T201
    for label, sec, load in rows:
        print(f"| {label} | {sec:.4f} | {load:.1f} |")  # noqa: T201
    print(f"\nratio old / prepared, isomap+detail: {t_old_nl / t_nl:.0f}x")  # noqa: T201
    if not args.skip_learned:
        print(f"ratio old / prepared, isomap-refine: {t_old / t_new:.1f}x")  # noqa: T201
        print(f"goal isomap-refine <= 1 s per new target: {'met' if t_new <= 1 else 'NOT met'} "  # noqa: T201
              f"({t_new:.2f} s; 'fast' {t_fast:.2f} s)")
    print(f"goal non-learned <= 50 ms per new target: {'met' if t_nl <= 0.05 else 'NOT met'} "  # noqa: T201
          f"({1000 * t_nl:.1f} ms; with the offset variant {1000 * t_nlo:.1f} ms)")


if __name__ == "__main__":
    main()
