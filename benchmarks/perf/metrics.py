"""Speed of dressmeup.metrics against the naive alternative a user would otherwise write.

Run:  python benchmarks/perf/metrics.py  [--quick]

Each line times one metric at the sizes of issue 2 (100k query points / 100k-face meshes,
a 50k-face garment on a 100k-face body, 1M faces for QCE+ASE, 6,890 vertices for Richness)
and the naive alternative on a subset, extrapolated linearly to the full size (the naive
cost is linear in the number of queries / faces / rows it is run on). It also checks that
both give the same numbers on the subset. Timings are wall-clock, best of ``--repeat`` runs.

Naive alternatives:
- P2S: trimesh.proximity.closest_point (what PIFu-style evaluators call).
- Chamfer: brute-force nearest neighbours with numpy (chunked distance matrices).
- IR: trimesh ``contains`` on face centroids (ray parity; needs a watertight body).
- QCE+ASE: a Python loop with numpy.linalg.svd per face.
- Richness: per row, two full argsorts and a Python loop over the 2k neighbours.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
import trimesh

CPU = {}


def best_of(fn, repeat: int):
    """Best wall-clock time of ``repeat`` runs; the CPU time of that run goes to CPU["last"]."""
    best, out = np.inf, None
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        wall = time.perf_counter() - t
        if wall < best:
            best, CPU["last"] = wall, time.process_time() - c
    return best, out


def bumpy_sphere(n_faces: int, seed: int, radius: float = 0.3, noise: float = 0.01):
    """A closed UV-sphere-like mesh with about ``n_faces`` faces and smooth bumps."""
    c = int(np.sqrt(n_faces / 4)) + 1  # uv_sphere(count=[c, c]) has about 4 c^2 faces
    m = trimesh.creation.uv_sphere(radius=radius, count=[c, c])
    V = np.asarray(m.vertices)
    rng = np.random.default_rng(seed)
    k = rng.normal(size=(8, 3))
    bump = 1 + noise / radius * np.sin(V @ k.T / radius * 3).sum(1) / 3
    return V * bump[:, None], np.asarray(m.faces)


def row(name, size, t_fast, t_naive, target, note=""):
    ratio = t_naive / t_fast if t_fast > 0 else np.inf
    ok = "yes" if target is None or t_fast <= target else "NO"
    tgt = "-" if target is None else f"<= {target:g} s"
    cpu = CPU.get("last", float("nan"))
    print(
        f"{name:<11}{size:<30}{t_fast:>8.3f} s{cpu:>8.3f} s{t_naive:>10.1f} s{ratio:>8.0f}x  "
        f"{tgt:<10}{ok:<5}{note}",
        flush=True,
    )


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument(
        "--quick", action="store_true", help="smaller naive subsets (faster, noisier ratios)"
    )
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    import torch

    torch.set_num_threads(1)
    from dressmeup import metrics as M
    from dressmeup.geometry.sampling import sample_surface

    sub = 0.5 if args.quick else 1.0
    print(
        f"dressmeup metrics speed | {platform.processor() or platform.machine()} | {os.cpu_count()} cores | "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    print(
        f"{'metric':<11}{'size':<30}{'wall':>10}{'cpu':>10}{'naive':>12}{'ratio':>9}  "
        f"{'target':<10}{'met':<5}note"
    )

    surf = bumpy_sphere(100_000, 0)
    pred = bumpy_sphere(100_000, 1, radius=0.305)
    pts = sample_surface(*pred, 100_000, seed=0)[0]
    M.p2s(pts[:10], surf)  # warm-up: imports open3d

    # ---- P2S
    t_fast, val = best_of(lambda: M.p2s(pts, surf), args.repeat)
    n_sub = int(500 * sub)
    tm = trimesh.Trimesh(*surf, process=False)
    t0 = time.perf_counter()
    _, d_naive, _ = trimesh.proximity.closest_point(tm, pts[:n_sub])
    t_naive = (time.perf_counter() - t0) * len(pts) / n_sub
    d_ours = M.p2s_details(pts[:n_sub], surf)
    worst = int(np.argmax(np.abs(d_ours - d_naive)))
    err = abs(d_ours[worst] - d_naive[worst])
    # brute force over every face for the worst point: which of the two is right?
    from dressmeup.geometry.proximity import closest_point_on_triangles

    V_, F_ = surf
    P_ = np.repeat(pts[worst : worst + 1], len(F_), 0)
    d_brute = np.linalg.norm(
        closest_point_on_triangles(P_, V_[F_[:, 0]], V_[F_[:, 1]], V_[F_[:, 2]]) - P_, axis=1
    ).min()
    err_brute = abs(d_ours[worst] - d_brute)
    row(
        "P2S",
        f"100k pts, {len(surf[1]) // 1000}k faces",
        t_fast,
        t_naive,
        0.5,
        f"trimesh on {n_sub} pts; max diff {err:.1e} m; ours vs brute force {err_brute:.0e} m",
    )

    # ---- Chamfer
    a = sample_surface(*surf, 100_000, seed=1)[0]
    b = pts
    t_fast, val = best_of(lambda: M.chamfer(a, b), args.repeat)
    n_sub = int(2000 * sub)

    def brute(q, ref):
        out = np.empty(len(q))
        rr = (ref**2).sum(1)
        for s in range(0, len(q), 500):
            c = q[s : s + 500]
            d2 = (c**2).sum(1)[:, None] + rr[None] - 2 * c @ ref.T
            out[s : s + 500] = np.maximum(d2.min(1), 0)
        return out

    t0 = time.perf_counter()
    d_sub = brute(a[:n_sub], b)
    t_naive = (time.perf_counter() - t0) * 2 * len(a) / n_sub
    d_fast = M.chamfer_details(a[:n_sub], b)[0] ** 2
    row(
        "Chamfer",
        "100k <-> 100k pts",
        t_fast,
        t_naive,
        0.5,
        f"numpy brute force on {n_sub} pts; max diff {np.abs(d_sub - d_fast).max():.1e} m^2",
    )

    # ---- IR
    body = bumpy_sphere(100_000, 2)
    gV, gF = bumpy_sphere(50_000, 3, radius=0.31)
    gV = np.where(gV[:, 2:3] < 0, gV * 0.93, gV)  # lower half pushed into the body
    garment = (gV, gF)
    t_fast, val = best_of(lambda: M.interpenetration_ratio(garment, body), args.repeat)
    n_sub = int(100 * sub)
    bm = trimesh.Trimesh(*body, process=False)
    cent = gV[gF].mean(1)
    t0 = time.perf_counter()
    inside_naive = bm.contains(cent[:n_sub])
    t_naive = (time.perf_counter() - t0) * len(gF) / n_sub
    agree = np.mean(inside_naive == M.interpenetration_details((gV, gF[:n_sub]), body).inside)
    row(
        "IR",
        f"{len(gF) // 1000}k-face garment, {len(body[1]) // 1000}k body",
        t_fast,
        t_naive,
        0.5,
        f"trimesh contains on {n_sub} centroids; agree {agree:.2%}; IR {val:.3f}",
    )

    # ---- QCE + ASE
    big = bumpy_sphere(1_000_000, 4)
    V, F = big
    uv = np.c_[np.arctan2(V[:, 1], V[:, 0]), V[:, 2] / 0.3]  # cylindrical-ish projection
    t_fast, _ = best_of(lambda: (M.qce(V, F, uv), M.ase(V, F, uv)), args.repeat)
    n_sub = int(10_000 * sub)

    def naive_qce_ase(Fs):
        q, a3, auv = [], [], []
        for f in Fs:
            E = np.stack([V[f[1]] - V[f[0]], V[f[2]] - V[f[0]]], 1)
            U = np.stack([uv[f[1]] - uv[f[0]], uv[f[2]] - uv[f[0]]], 1)
            s = np.linalg.svd(U @ np.linalg.pinv(E), compute_uv=False)
            q.append(s[0] / s[1] if s[1] > 0 else np.inf)
            a3.append(0.5 * np.linalg.norm(np.cross(E[:, 0], E[:, 1])))
            auv.append(0.5 * abs(np.linalg.det(U)))
        return np.array(q), np.array(a3), np.array(auv)

    t0 = time.perf_counter()
    q_naive, _, _ = naive_qce_ase(F[:n_sub])
    t_naive = (time.perf_counter() - t0) * len(F) / n_sub
    q_fast = M.qce_details(V, F[:n_sub], uv).per_face
    fin = np.isfinite(q_naive) & np.isfinite(q_fast)
    rel = np.nanmax(np.abs(q_fast[fin] - q_naive[fin]) / q_naive[fin])
    row(
        "QCE + ASE",
        f"{len(F) / 1e6:.2f}M faces",
        t_fast,
        t_naive,
        1.0,
        f"SVD loop on {n_sub} faces; max rel diff {rel:.1e}",
    )

    # ---- Richness
    n = 6890
    rng = np.random.default_rng(5)
    X = rng.normal(size=(n, 3))
    G = np.linalg.norm(X[:, None] - X[None], axis=2)  # stands in for a geodesic matrix
    # a 128-D embedding (as the thesis' isomap embeddings) close to the 3D layout
    Emb = np.c_[X + rng.normal(size=(n, 3)) * 0.1, rng.normal(size=(n, 125)) * 0.05]
    t_fast, val = best_of(lambda: M.richness(G, Emb, k=10), 1)
    n_sub = int(100 * sub)

    def naive_richness(rows, k=10):
        from scipy.spatial.distance import cdist

        out = []
        for i in rows:
            g = G[i].copy()
            g[i] = -np.inf
            e = cdist(Emb[i : i + 1], Emb)[0]
            e[i] = -np.inf
            og = np.argsort(g, kind="stable")
            oe = np.argsort(e, kind="stable")
            re = np.empty(n, int)
            re[oe] = np.arange(n)
            rn = sum(
                min(abs(p - re[j]), k) for p, j in zip(range(1, k + 1), og[1 : k + 1], strict=True)
            )
            rf = sum(
                min(abs(p - re[j]), k) for p, j in zip(range(n - k, n), og[n - k :], strict=True)
            )
            out.append((rn + rf) / (2 * k * k))
        return np.array(out)

    t0 = time.perf_counter()
    r_naive = naive_richness(range(n_sub))
    t_naive = (time.perf_counter() - t0) * n / n_sub
    r_fast = M.richness_details(G[:], Emb, k=10).per_vertex[:n_sub]
    row(
        "Richness",
        "6,890 vertices, 128-D, k = 10",
        t_fast,
        t_naive,
        20.0,
        f"argsort loop on {n_sub} rows; max diff {np.abs(r_fast - r_naive).max():.1e}",
    )
    print(
        "wall: best wall-clock time of dressmeup (the target applies to it); cpu: process CPU time"
    )
    print(
        "of that run, all threads (a loaded machine inflates wall, not cpu); naive: wall time on the"
    )
    print("subset in the note, extrapolated linearly to the full size; ratio = naive / wall.")


if __name__ == "__main__":
    main()
