"""Inference: apply a trained neural UV model to any discretisation of its shape.

Steps (all timed in ``UVResult.info``): normalise the mesh, compute its DiffusionNet
operators (mass, eigenbasis, gradients), run PatchNet, turn probabilities into disk charts,
pool each chart's code psi, run the forward MLP on every (chart, vertex) row, orient each
chart counter-clockwise and scale it to its 3D area, pack the charts with xatlas.
"""

from __future__ import annotations

import time

import numpy as np

from dressmeup.geometry.mesh import as_arrays, face_areas
from dressmeup.geometry.uv_atlas import orient_chart_uv, signed_uv_areas
from dressmeup.geometry.uv_packing import pack_charts
from dressmeup.methods.nn.diffusion_ops import compute_operators
from dressmeup.methods.uvparam.base import UVResult
from dressmeup.methods.uvparam.neural.model import NeuralUVModel
from dressmeup.methods.uvparam.neural.patchnet import (
    assign_charts,
    normalize_vertices,
    patchnet_inputs,
)
from dressmeup.methods.uvparam.neural.train import chart_codes, chart_rows

__all__ = ["infer", "chart_uvs", "cluster_decimate"]


def chart_uvs(uv_rows: np.ndarray, Vn: np.ndarray, F: np.ndarray, row_vertex: np.ndarray,
              row_chart: np.ndarray, row_faces: np.ndarray, chart_ids: np.ndarray) -> np.ndarray:
    """Orient every chart counter-clockwise and scale it so its UV area equals its 3D area.

    Returns
    -------
    (N, 2) float64 ndarray (rows as ``uv_rows``)
    """
    out = np.array(uv_rows, dtype=np.float64)
    a3 = np.bincount(chart_ids, weights=face_areas(Vn, F))
    order = np.argsort(row_chart, kind="stable")
    starts = np.searchsorted(row_chart[order], np.arange(len(a3) + 1))
    for c in range(len(a3)):
        rows = order[starts[c]:starts[c + 1]]
        faces = row_faces[chart_ids == c] - rows.min()
        # rows of a chart are contiguous (chart_rows builds them chart by chart)
        uvc = orient_chart_uv(out[rows], faces)
        a2 = np.abs(signed_uv_areas(uvc, faces)).sum()
        if a2 > 0:
            uvc = (uvc - uvc.mean(axis=0)) * np.sqrt(a3[c] / a2)
        out[rows] = uvc
    return out


def _vertex_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Barycentric lumped vertex areas (n,) float64."""
    a = face_areas(V, F) / 3.0
    return np.bincount(F.reshape(-1), weights=np.repeat(a, 3), minlength=len(V))


def cluster_decimate(V: np.ndarray, F: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertex-clustering decimation to about ``n_vertices`` (fast; the inference proxy).

    Vertices are grouped by a regular grid whose cell size ``h = sqrt(1.4 area / n_vertices)``
    gives about ``n_vertices`` occupied cells on a surface; each group becomes its mean
    position; faces that collapse or repeat are dropped. Much faster than edge collapse (0.1 s
    instead of ~1 s at 100k vertices) and good enough for PatchNet's smooth outputs; surfaces
    closer than ``h`` may be merged.

    Returns
    -------
    V : (n2, 3) float64
    F : (m2, 3) int64
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    # a surface cuts ~1.4 area / h^2 grid cells (cells meet it obliquely)
    h = float(np.sqrt(1.4 * face_areas(V, F).sum() / max(int(n_vertices), 1))) or 1.0
    cell = np.floor((V - V.min(axis=0)) / h).astype(np.int64)
    dims = cell.max(axis=0) + 1
    key = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    _, group = np.unique(key, return_inverse=True)
    group = group.reshape(-1)
    count = np.bincount(group)
    Vc = np.stack([np.bincount(group, weights=V[:, k]) for k in range(3)], axis=1) / count[:, None]
    Fc = group[F]
    Fc = Fc[(Fc[:, 0] != Fc[:, 1]) & (Fc[:, 1] != Fc[:, 2]) & (Fc[:, 2] != Fc[:, 0])]
    _, first = np.unique(np.sort(Fc, axis=1), axis=0, return_index=True)
    Fc = Fc[np.sort(first)]
    used = np.unique(Fc)
    remap = np.full(len(Vc), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return Vc[used], remap[Fc]


def _patchnet_on(model: NeuralUVModel, Vn: np.ndarray, F: np.ndarray, use_operator_cache: bool,
                 **operator_options):
    """PatchNet's probabilities (n, K) and last hidden features (n, d) on a mesh."""
    # heavy: torch (~1.1 s to import)
    import torch

    ops = compute_operators(Vn, F, k_eig=model.config.k_eig, use_cache=use_operator_cache,
                            **operator_options)
    tops = ops.to_torch()
    x = torch.from_numpy(patchnet_inputs(Vn, F))
    with torch.no_grad():
        h = model.patchnet.features(x, tops)
        probs = torch.softmax(model.patchnet.last(h), dim=-1).numpy()
    return probs, h.numpy(), ops


def _proxy(V: np.ndarray, F: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A proxy of about ``n`` vertices (:func:`cluster_decimate`), normalised as the full
    mesh is (its bounding box's centre and diagonal), so that both share one frame."""
    Vp, Fp = cluster_decimate(V, F, n)
    lo, hi = V.min(axis=0), V.max(axis=0)
    return (Vp - 0.5 * (lo + hi)) / (float(np.linalg.norm(hi - lo)) or 1.0), Fp


def infer(model: NeuralUVModel, V, F, use_operator_cache: bool = True, pack: bool = True,
          threads: int | None = None, proxy_vertices: int | None = 5000) -> UVResult:
    """Parameterise a mesh with a trained model (no training).

    Parameters
    ----------
    model : NeuralUVModel
    V : (n, 3) float array
    F : (m, 3) int array
    use_operator_cache : bool
        Reuse cached operators (pass False to time operators honestly).
    pack : bool
        Pack charts with xatlas into [0, 1]^2.
    threads : int, optional
        torch intra-op threads for this call.
    proxy_vertices : int or None
        Meshes with more than twice this many vertices run PatchNet on a proxy of about this
        many vertices (:func:`cluster_decimate`) (the network is discretisation-agnostic; its patch
        probabilities and features are smooth) and take each vertex's values from the
        nearest proxy vertex; charts, codes psi (mass-weighted on the full mesh) and the UV
        MLP are evaluated on the full mesh. The proxy's eigenbasis uses the two-level
        Galerkin solver (``n_coarse`` = 400). ``None`` runs PatchNet on the full mesh.

    Returns
    -------
    UVResult
        ``info`` has per-stage seconds and the number of charts.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    t0, c0 = time.perf_counter(), time.process_time()
    V, F = as_arrays(V, F)
    cfg = model.config
    old_threads = torch.get_num_threads()
    if threads:
        torch.set_num_threads(int(threads))
    try:
        Vn = normalize_vertices(V)
        proxy = bool(proxy_vertices) and len(V) > 2 * int(proxy_vertices)
        if proxy:
            # heavy: scipy.spatial
            from scipy.spatial import cKDTree

            Vpn, Fp = _proxy(V, F, int(proxy_vertices))
            t1, c1 = time.perf_counter(), time.process_time()
            probs_p, feats_p, ops = _patchnet_on(model, Vpn, Fp, use_operator_cache,
                                                 exact_limit=1000, n_coarse=400)
            nearest = cKDTree(Vpn).query(Vn)[1]
            probs, feats = probs_p[nearest], feats_p[nearest]
            mass = _vertex_areas(Vn, F)
        else:
            t1, c1 = time.perf_counter(), time.process_time()
            probs, feats, ops = _patchnet_on(model, Vn, F, use_operator_cache)
            mass = ops.mass
        t2, c2 = time.perf_counter(), time.process_time()
        chart_ids = assign_charts(Vn, F, probs, cfg.consolidation_steps, cfg.min_chart_fraction)
        psi = chart_codes(feats, mass, F, chart_ids)
        row_vertex, row_chart, row_faces = chart_rows(F, chart_ids)
        t3, c3 = time.perf_counter(), time.process_time()
        inp = torch.cat([torch.from_numpy(Vn[row_vertex].astype(np.float32)),
                         torch.from_numpy(psi[row_chart])], dim=1)
        with torch.no_grad():
            uv = model.forward_mlp(inp).numpy().astype(np.float64)
        t4, c4 = time.perf_counter(), time.process_time()
        uv = chart_uvs(uv, Vn, F, row_vertex, row_chart, row_faces, chart_ids)
        uv_faces = row_faces
        if pack:
            uv, uv_faces = pack_charts(uv, uv_faces)
        t5, c5 = time.perf_counter(), time.process_time()
    finally:
        torch.set_num_threads(old_threads)
    return UVResult(uv, uv_faces, chart_ids, t5 - t0, {
        "n_charts": int(chart_ids.max()) + 1, "cpu_seconds": c5 - c0, "proxy_vertices": int(len(Vpn)) if proxy else 0,
        "seconds_decimate": t1 - t0, "seconds_operators": ops.seconds,
        "seconds_patchnet": t2 - t1 - ops.seconds, "seconds_charts": t3 - t2, "seconds_mlp": t4 - t3,
        "seconds_pack": t5 - t4, "operators_cached": ops.seconds == 0.0,
        "cpu_stages": {"decimate": c1 - c0, "operators+patchnet": c2 - c1, "charts": c3 - c2,
                       "mlp": c4 - c3, "pack": c5 - c4}})
