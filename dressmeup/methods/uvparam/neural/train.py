"""Per-object training of the neural UV parameterisation: PatchNet first, then the UV MLPs.

:func:`train` takes one mesh (usually a low-resolution version, ~2-3k vertices) and returns a
:class:`~dressmeup.methods.uvparam.neural.model.NeuralUVModel` that
:func:`dressmeup.methods.uvparam.neural.infer.infer` applies to any discretisation of the same
shape. The model, its configuration and its checkpoints live in
:mod:`dressmeup.methods.uvparam.neural.model`; their names are importable from here too.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from dressmeup.geometry.mesh import as_arrays, face_areas, face_normals
from dressmeup.geometry.uv_atlas import split_charts
from dressmeup.methods.nn.diffusion_ops import compute_operators
from dressmeup.methods.uvparam.neural import losses as L
from dressmeup.methods.uvparam.neural.model import (
    NeuralConfig,
    NeuralUVModel,
    build_modules,
    get_config,
)
from dressmeup.methods.uvparam.neural.patchnet import (
    assign_charts,
    normalize_vertices,
    patchnet_inputs,
)
from dressmeup.progress import progress as bar

__all__ = ["train", "chart_codes", "chart_rows"]

log = logging.getLogger(__name__)


def _edge_graph(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    n = len(V)
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    key = np.unique(e[:, 0] * n + e[:, 1])
    a, b = key // n, key % n
    w = np.maximum(np.linalg.norm(V[a] - V[b], axis=1), 1e-12)
    return sp.coo_matrix((np.r_[w, w], (np.r_[a, b], np.r_[b, a])), shape=(n, n)).tocsr()


def chart_codes(features: np.ndarray, mass: np.ndarray, F: np.ndarray, chart_ids: np.ndarray) -> np.ndarray:
    """The code psi of every chart: mass-weighted mean of the DiffusionNet features over its
    vertices, scaled to unit RMS (so it does not depend on the resolution).

    Parameters
    ----------
    features : (n, d) float array
    mass : (n,) float array
    F : (m, 3) int array
    chart_ids : (m,) int array, ids 0..c-1

    Returns
    -------
    (c, d) float32 ndarray
    """
    c = int(chart_ids.max()) + 1
    rows = np.repeat(chart_ids, 3)
    cols = F.reshape(-1)
    member = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(c, len(mass))).tocsr()
    member.data[:] = 1.0  # duplicates summed -> indicator
    w = member @ sp.diags(mass)
    psi = np.asarray(w @ features) / np.asarray(w.sum(axis=1))
    rms = np.sqrt((psi**2).mean(axis=1, keepdims=True)) + 1e-8
    return (psi / rms).astype(np.float32)


def chart_rows(F: np.ndarray, chart_ids: np.ndarray):
    """Duplicate seam vertices per chart.

    Returns
    -------
    row_vertex : (N,) int64, the mesh vertex of each row
    row_chart : (N,) int64, the chart of each row
    row_faces : (m, 3) int64, each face's corners as rows (same face order)
    """

    rv, rc = [], []
    row_faces = np.zeros_like(F)
    off = 0
    for ch in split_charts(F, chart_ids):
        rv.append(ch.vertices)
        rc.append(np.full(len(ch.vertices), ch.chart_id, dtype=np.int64))
        row_faces[ch.faces] = ch.local_faces + off
        off += len(ch.vertices)
    return np.concatenate(rv), np.concatenate(rc), row_faces


def _iso_pairs(Vn: np.ndarray, row_vertex: np.ndarray, row_chart: np.ndarray, row_faces: np.ndarray,
               sigma: float):
    """Row pairs (i < j) of the same chart with edge-graph geodesic (inside the chart) < sigma."""

    G = _edge_graph(Vn[row_vertex], row_faces)  # rows of different charts are disconnected
    D = dijkstra(G, directed=False, limit=sigma)
    D = sp.csr_matrix(np.where(np.isfinite(D), D, 0.0)) if D.shape[0] <= 6000 else None
    if D is None:  # pragma: no cover - large training meshes: per-source rows
        raise ValueError("training mesh too large for the isometric pairs; decimate it first")
    D = sp.triu(D, k=1).tocoo()
    keep = D.data > 0
    return np.stack([D.row[keep], D.col[keep]], axis=1), D.data[keep]


def train(V, F, config: str | NeuralConfig = "fast", progress: bool = True,
          patchnet_only: bool = False, threads: int | None = 1, init_patchnet: Any = None,
          **overrides: Any) -> NeuralUVModel:
    """Train PatchNet and the UV MLPs on one mesh.

    Parameters
    ----------
    V : (n, 3) float array
        The training mesh (decimate large meshes first, see ``NeuralConfig.train_vertices``).
    F : (m, 3) int array
    config : {"fast", "reference"} or NeuralConfig
    progress : bool
        Show progress bars.
    patchnet_only : bool
        Stop after PatchNet (the UV MLPs stay untrained).
    init_patchnet : torch.nn.Module, optional
        A PatchNet already trained on this mesh (same configuration): its training is
        skipped (used by the loss ablation to compare UV losses on identical charts).
    threads : int or None
        torch intra-op threads while training (default 1: the networks are small, and extra
        threads only contend on a shared CPU; ``None`` keeps torch's setting).
    **overrides
        Fields of :class:`NeuralConfig`.

    Returns
    -------
    NeuralUVModel
        ``history`` holds the loss curves (``patch_total``, ``cos``, ``geo``, ``uv_total``,
        ``cycle``, ``iso``, ``angle``, ``area``) and timings.

    Raises
    ------
    ValueError
        Invalid mesh or configuration.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    old = torch.get_num_threads()
    if threads:
        torch.set_num_threads(int(threads))
    try:
        return _train(V, F, get_config(config, **overrides), progress, patchnet_only, init_patchnet)
    finally:
        torch.set_num_threads(old)


def _train(V, F, cfg: NeuralConfig, progress: bool, patchnet_only: bool,
           init_patchnet: Any = None) -> NeuralUVModel:
    # heavy: torch (~1.1 s to import)
    import torch

    V, F = as_arrays(V, F)
    t0 = time.perf_counter()
    Vn = normalize_vertices(V)
    ops = compute_operators(Vn, F, k_eig=cfg.k_eig)
    tops = ops.to_torch()
    x = torch.from_numpy(patchnet_inputs(Vn, F))
    patchnet, fwd, bwd = build_modules(cfg)
    if init_patchnet is not None:
        patchnet.load_state_dict(init_patchnet.state_dict())
    hist: dict = {k: [] for k in ("patch_total", "cos", "geo", "uv_total", "cycle", "iso", "angle", "area")}
    n_patch_iters = 0 if init_patchnet is not None else cfg.patch_iters
    _fit_patchnet(patchnet, x, tops, Vn, F, ops.mass, cfg, n_patch_iters, hist, progress)
    t1 = time.perf_counter()
    model = NeuralUVModel(cfg, patchnet.eval(), fwd, bwd, hist)
    hist["seconds_patchnet"] = t1 - t0
    if patchnet_only:
        return model
    _fit_uv_mlps(patchnet, fwd, bwd, x, tops, Vn, F, ops.mass, cfg, hist, progress)
    hist["seconds_uv"] = time.perf_counter() - t1
    hist["seconds_total"] = time.perf_counter() - t0
    model.forward_mlp = fwd.eval()
    model.backward_mlp = bwd.eval()
    return model


def _fit_patchnet(patchnet: Any, x: Any, tops: dict, Vn: np.ndarray, F: np.ndarray,
                  mass: np.ndarray, cfg: NeuralConfig, n_iters: int, hist: dict,
                  progress: bool) -> None:
    """``n_iters`` Adam steps of PatchNet on the cosine and geodesic losses (the geodesic one
    on ``cfg.geo_landmarks`` landmark vertices drawn with ``cfg.seed``); appends the loss
    curves to ``hist``."""
    # heavy: torch (~1.1 s to import)
    import torch

    rng = np.random.default_rng(cfg.seed)
    n = len(Vn)
    lm = np.sort(rng.choice(n, size=min(n, cfg.geo_landmarks), replace=False))
    G = dijkstra(_edge_graph(Vn, F), directed=False, indices=lm)[:, lm]
    G = np.where(np.isfinite(G), G, 2.0 * np.nanmax(np.where(np.isfinite(G), G, 0.0)))
    Gt = torch.from_numpy(G.astype(np.float32))
    mass_lm = torch.from_numpy(mass[lm].astype(np.float32))
    fn = torch.from_numpy(face_normals(Vn, F).astype(np.float32))
    fa = torch.from_numpy(face_areas(Vn, F).astype(np.float32))
    Ft = torch.from_numpy(F)
    lm_t = torch.from_numpy(lm)
    opt = torch.optim.Adam(patchnet.parameters(), lr=cfg.patch_lr)
    for _ in bar(range(n_iters), desc="PatchNet", disable=not progress or None):
        probs = patchnet(x, tops)
        fprobs = probs[Ft].mean(dim=1)
        lc = L.cosine_loss(fprobs, fn, fa)
        lg = L.geodesic_loss(probs[lm_t], mass_lm, Gt)
        loss = cfg.lambda_cos * lc + cfg.lambda_geo * lg
        opt.zero_grad()
        loss.backward()
        opt.step()
        hist["patch_total"].append(float(loss.detach()))
        hist["cos"].append(float(lc.detach()))
        hist["geo"].append(float(lg.detach()))


def _fit_uv_mlps(patchnet: Any, fwd: Any, bwd: Any, x: Any, tops: dict, Vn: np.ndarray,
                 F: np.ndarray, mass: np.ndarray, cfg: NeuralConfig, hist: dict,
                 progress: bool) -> None:
    """Charts and codes from the trained PatchNet at the training resolution, then
    ``cfg.uv_iters`` Adam steps of the forward and backward MLPs on the cycle, isometric,
    angle and area losses; appends the loss curves to ``hist``."""
    # heavy: torch (~1.1 s to import)
    import torch

    with torch.no_grad():
        probs = patchnet(x, tops).numpy()
        feats = patchnet.features(x, tops).numpy()
    chart_ids = assign_charts(Vn, F, probs, cfg.consolidation_steps, cfg.min_chart_fraction)
    psi = chart_codes(feats, mass, F, chart_ids)
    row_vertex, row_chart, row_faces = chart_rows(F, chart_ids)
    pairs, gdist = _iso_pairs(Vn, row_vertex, row_chart, row_faces, cfg.sigma)
    hist["n_charts_train"] = int(chart_ids.max()) + 1
    hist["n_iso_pairs"] = len(pairs)

    xr = torch.from_numpy(Vn[row_vertex].astype(np.float32))
    psi_r = torch.from_numpy(psi[row_chart])
    inp = torch.cat([xr, psi_r], dim=1)
    rf = torch.from_numpy(row_faces)
    cos3d = L.triangle_cosines(xr, rf).detach()
    area3d = L.triangle_areas_3d(xr, rf).detach()
    pairs_t = torch.from_numpy(pairs)
    gd_t = torch.from_numpy(gdist.astype(np.float32))
    w = cfg.weights
    params = list(fwd.parameters()) + list(bwd.parameters())
    opt = torch.optim.Adam(params, lr=cfg.uv_lr)
    gen = torch.Generator().manual_seed(cfg.seed)
    for _ in bar(range(cfg.uv_iters), desc="UV MLPs", disable=not progress or None):
        uv = fwd(inp)
        rec = bwd(torch.cat([uv, psi_r], dim=1))
        lcyc = L.cycle_loss(xr, rec)
        if len(pairs_t) > cfg.pairs_per_iter:
            sel = torch.randint(len(pairs_t), (cfg.pairs_per_iter,), generator=gen)
            liso = L.isometric_loss(uv, pairs_t[sel], gd_t[sel])
        elif len(pairs_t):
            liso = L.isometric_loss(uv, pairs_t, gd_t)
        else:
            liso = uv.sum() * 0.0
        lang = L.angle_loss(uv, rf, cos3d)
        lar = L.area_loss(uv, rf, area3d)
        loss = w[0] * lcyc + w[1] * liso + w[2] * lang + w[3] * lar
        opt.zero_grad()
        loss.backward()
        opt.step()
        for k, v in (("uv_total", loss), ("cycle", lcyc), ("iso", liso), ("angle", lang), ("area", lar)):
            hist[k].append(float(v.detach()))
