"""Inference time of ``isomap-refine`` on a ~30k-vertex garment, split into correspondence
search and network, with side-by-side alternatives.

    python benchmarks/perf/retarget.py --body anny --vertices 30000 --threads 2

The garment is a cut of the body's torso and arms, offset 1 cm along the normals and
subdivided (midpoint, k times) so that it has about ``--vertices`` vertices. Stages:

- eq. 4.1 (garment embedding by 3D k-NN on the source skin, scipy cKDTree);
- eq. 4.4 (k-NN in the 128-d embedding over the target skin): scipy cKDTree (the
  implementation) vs brute force in torch (the named alternative);
- the k nearest target vertices of each coarse point (cKDTree);
- the network (6 x 512 MLP + two PointNets), one forward pass, at the requested threads vs 1.

The network's weights do not change its cost; a freshly initialised one is timed unless
``--weights`` is given. Goal (issue 6): under 3 s in total on 2 cores.
"""

from __future__ import annotations

import argparse
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


def _best(fn, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main() -> None:
    import torch
    from scipy.spatial import cKDTree

    from dressmeup.body import get_body_model
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget import isomap as iso
    from dressmeup.methods.retarget.base import body_context

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--body", default="anny")
    ap.add_argument("--vertices", type=int, default=30000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--weights", default=None)
    ap.add_argument("--skip-kdtree128", action="store_true", help="skip the slow brute-force alternative")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    model = get_body_model(args.body)
    src = model.default_params()
    tgt = src.copy()
    tgt.pose[16] = [0.0, 0.0, -0.6]
    tgt.pose[17] = [0.0, 0.0, 0.6]
    V, F = _garment(model, src, args.vertices)
    print(f"body {args.body}; garment {len(V)} vertices, {len(F)} faces; torch threads {args.threads}")  # noqa: T201

    method = (get_method("isomap-refine", weights=args.weights) if args.weights
              else get_method("isomap-refine"))
    emb = method.embedding(model)  # cached; building it is a one-off per template
    s, t = body_context(model, src), body_context(model, tgt)
    S, T, E = s.skin_vertices, t.skin_vertices, emb.embedding

    t_ext = _best(lambda: iso.extrapolate(E, S, V, k=32), args.repeat)
    phi = iso.extrapolate(E, S, V, k=32)
    t_place = _best(lambda: iso.knn_embedding(phi, E, k=32), args.repeat)
    x = iso.place(phi, E, T, k=32)
    t_nbr = _best(lambda: cKDTree(T).query(x, k=32), args.repeat)
    t_corr = t_ext + t_place + t_nbr
    rows = [("eq. 4.1 extrapolation (3D kNN, k=32)", t_ext), ("eq. 4.4 placement (128-d kNN, cKDTree)", t_place),
            ("target neighbours of coarse points (k=32)", t_nbr)]
    if not args.skip_kdtree128:
        t_kd = _best(lambda: iso.knn_embedding(phi, E, k=32, method="brute"), 1)
        rows.append(("  alternative: eq. 4.4 by torch brute force", t_kd))

    if args.weights:
        method.ensure_network(model)  # hyperparameters of the checkpoint, before preparing
    else:
        method.network_ = method.new_network().eval()
        method.body_model_name_ = model.name
    sample = method.prepare(V, F, src, tgt, model)
    feats, gp, bp = method.features(sample)

    def forward():
        with torch.no_grad():
            method.network_(feats, gp, bp)

    forward()
    t_net = _best(forward, args.repeat)
    torch.set_num_threads(1)
    t_net1 = _best(forward, 1)
    torch.set_num_threads(args.threads)
    t_total = _best(lambda: method.retarget(V, F, src, tgt, model), 1)
    timing = method.last_timing_

    print("\n| stage | seconds |\n|---|---:|")  # noqa: T201
    for label, sec in rows:
        print(f"| {label} | {sec:.3f} |")  # noqa: T201
    print(f"| correspondence search (sum) | {t_corr:.3f} |")  # noqa: T201
    print(f"| network forward ({args.threads} threads) | {t_net:.3f} |")  # noqa: T201
    print(f"|   alternative: network forward, 1 thread | {t_net1:.3f} |")  # noqa: T201
    print(f"| end-to-end retarget() (incl. body posing, features) | {t_total:.3f} |")  # noqa: T201
    print(f"\nretarget() split: correspondence {timing['correspondence']:.3f} s, "  # noqa: T201
          f"network {timing['network']:.3f} s")
    if not args.skip_kdtree128:
        print(f"ratio brute force / cKDTree for eq. 4.4: {rows[3][1] / t_place:.1f}x")  # noqa: T201
    print(f"ratio network 1 thread / {args.threads} threads: {t_net1 / t_net:.2f}x")  # noqa: T201
    print(f"goal < 3 s per 30k-vertex garment: {'met' if t_total < 3 else 'NOT met'} ({t_total:.2f} s)")  # noqa: T201


if __name__ == "__main__":
    main()
