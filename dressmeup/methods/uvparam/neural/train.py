"""Per-object training of the neural UV parameterisation: PatchNet first, then the UV MLPs.

:func:`train` takes one mesh (usually a low-resolution version, ~2-3k vertices) and returns a
:class:`NeuralUVModel` that :func:`dressmeup.methods.uvparam.neural.infer.infer` applies to
any discretisation of the same shape. Checkpoints are plain ``torch.save`` dictionaries of
tensors and numbers (loaded with ``weights_only=True``).
"""

from __future__ import annotations

import io
import logging
import time
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from dressmeup.errors import InputError
from dressmeup.geometry.mesh import as_arrays, face_areas, face_normals
from dressmeup.geometry.uv_atlas import split_charts
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.methods.nn.checkpoint import load_checkpoint
from dressmeup.methods.nn.diffusion_ops import compute_operators
from dressmeup.methods.uvparam.neural import losses as L
from dressmeup.methods.uvparam.neural.patchnet import (
    assign_charts,
    build_patchnet,
    normalize_vertices,
    patchnet_inputs,
)
from dressmeup.methods.uvparam.neural.uv_mlp import build_mlp, count_parameters
from dressmeup.progress import progress as bar

__all__ = ["NeuralConfig", "CONFIGS", "NeuralUVModel", "train", "get_config", "plain_values",
           "chart_codes", "chart_rows", "save_model", "load_model"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class NeuralConfig:
    """Hyperparameters of the neural method (defaults: the thesis' reference configuration).

    Attributes
    ----------
    n_patches : int
        K, PatchNet's number of patches.
    patch_width, patch_blocks, k_eig : int
        DiffusionNet width (128), blocks (4) and eigenvectors (64).
    patch_iters, patch_lr : int, float
        PatchNet optimisation steps and Adam learning rate (1e-3).
    lambda_cos, lambda_geo : float
        PatchNet loss weights (1, 1).
    geo_landmarks : int
        Vertices used for the geodesic loss' distance matrix.
    mlp_width, mlp_depth : int
        UV MLP width and number of linear layers; 320 x 8 gives ~0.66M parameters per MLP,
        ~1.3M for the pair (the thesis' size).
    uv_iters, uv_lr : int, float
        UV MLP optimisation steps and learning rate (1e-3).
    weights : tuple of 4 floats
        (cycle, isometric, angle, area) = (1, 1, 0.001, 0.001) as in the thesis.
    sigma : float
        Geodesic threshold of the isometric loss (0.2, in units of the bounding-box diagonal).
    pairs_per_iter : int
        Random subset of the isometric pairs used per step.
    consolidation_steps, min_chart_fraction : int, float
        Face assignment: neighbour averaging steps, island merge threshold.
    train_vertices : int
        Meshes with more vertices are decimated to about this many for training.
    seed : int
    """

    n_patches: int = 8
    patch_width: int = 128
    patch_blocks: int = 4
    k_eig: int = 64
    patch_iters: int = 300
    patch_lr: float = 1e-3
    lambda_cos: float = 1.0
    lambda_geo: float = 1.0
    geo_landmarks: int = 1200
    mlp_width: int = 320
    mlp_depth: int = 8
    uv_iters: int = 1500
    uv_lr: float = 1e-3
    weights: tuple = (1.0, 1.0, 0.001, 0.001)
    sigma: float = 0.2
    pairs_per_iter: int = 40000
    consolidation_steps: int = 2
    min_chart_fraction: float = 0.01
    train_vertices: int = 2500
    seed: int = 0


#: named configurations: the thesis' sizes and a smaller, faster one
CONFIGS = {
    "reference": NeuralConfig(),
    "fast": NeuralConfig(patch_width=64, patch_blocks=4, mlp_width=128, mlp_depth=6,
                         patch_iters=200, uv_iters=800),
}


def get_config(config: str | NeuralConfig = "fast", **overrides: Any) -> NeuralConfig:
    """Resolve a configuration name (``"reference"``, ``"fast"``) and keyword overrides.

    Raises
    ------
    ValueError
        Unknown name or unknown override.
    """
    if isinstance(config, NeuralConfig):
        base = config
    elif config in CONFIGS:
        base = CONFIGS[config]
    else:
        raise ValueError(f"config: expected one of {', '.join(CONFIGS)} or a NeuralConfig, got {config!r}")
    names = {f.name for f in fields(NeuralConfig)}
    bad = sorted(set(overrides) - names)
    if bad:
        raise ValueError(f"unknown neural hyperparameter(s) {bad}; valid: {sorted(names)}")
    if "weights" in overrides:
        overrides["weights"] = tuple(float(w) for w in overrides["weights"])
    return replace(base, **overrides)


@dataclass
class NeuralUVModel:
    """A trained neural UV parameterisation (torch modules + configuration + training log)."""

    config: NeuralConfig
    patchnet: Any
    forward_mlp: Any
    backward_mlp: Any
    history: dict = field(default_factory=dict)

    @property
    def n_parameters(self) -> dict:
        return {"patchnet": count_parameters(self.patchnet),
                "forward_mlp": count_parameters(self.forward_mlp),
                "backward_mlp": count_parameters(self.backward_mlp)}


def _build_modules(cfg: NeuralConfig):
    patchnet = build_patchnet(cfg.n_patches, cfg.patch_width, cfg.patch_blocks, seed=cfg.seed)
    fwd = build_mlp(3 + cfg.patch_width, 2, cfg.mlp_width, cfg.mlp_depth, out_scale=1.0, seed=cfg.seed + 1)
    bwd = build_mlp(2 + cfg.patch_width, 3, cfg.mlp_width, cfg.mlp_depth, out_scale=1.0, seed=cfg.seed + 2)
    return patchnet, fwd, bwd


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
    rng = np.random.default_rng(cfg.seed)
    Vn = normalize_vertices(V)
    ops = compute_operators(Vn, F, k_eig=cfg.k_eig)
    tops = ops.to_torch()
    x = torch.from_numpy(patchnet_inputs(Vn, F))
    patchnet, fwd, bwd = _build_modules(cfg)
    if init_patchnet is not None:
        patchnet.load_state_dict(init_patchnet.state_dict())
    hist: dict = {k: [] for k in ("patch_total", "cos", "geo", "uv_total", "cycle", "iso", "angle", "area")}

    # --- PatchNet -------------------------------------------------------------------------
    n = len(Vn)
    lm = np.sort(rng.choice(n, size=min(n, cfg.geo_landmarks), replace=False))
    G = dijkstra(_edge_graph(Vn, F), directed=False, indices=lm)[:, lm]
    G = np.where(np.isfinite(G), G, 2.0 * np.nanmax(np.where(np.isfinite(G), G, 0.0)))
    Gt = torch.from_numpy(G.astype(np.float32))
    mass_lm = torch.from_numpy(ops.mass[lm].astype(np.float32))
    fn = torch.from_numpy(face_normals(Vn, F).astype(np.float32))
    fa = torch.from_numpy(face_areas(Vn, F).astype(np.float32))
    Ft = torch.from_numpy(F)
    lm_t = torch.from_numpy(lm)
    opt = torch.optim.Adam(patchnet.parameters(), lr=cfg.patch_lr)
    n_patch_iters = 0 if init_patchnet is not None else cfg.patch_iters
    for _ in bar(range(n_patch_iters), desc="PatchNet", disable=not progress or None):
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
    t1 = time.perf_counter()
    model = NeuralUVModel(cfg, patchnet.eval(), fwd, bwd, hist)
    hist["seconds_patchnet"] = t1 - t0
    if patchnet_only:
        return model

    # --- charts and codes at the training resolution ------------------------------------
    with torch.no_grad():
        probs = patchnet(x, tops).numpy()
        feats = patchnet.features(x, tops).numpy()
    chart_ids = assign_charts(Vn, F, probs, cfg.consolidation_steps, cfg.min_chart_fraction)
    psi = chart_codes(feats, ops.mass, F, chart_ids)
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
    hist["seconds_uv"] = time.perf_counter() - t1
    hist["seconds_total"] = time.perf_counter() - t0
    model.forward_mlp = fwd.eval()
    model.backward_mlp = bwd.eval()
    return model


def plain_values(value: Any) -> Any:
    """Loss histories as plain Python numbers/strings/lists (loadable with weights_only)."""
    if isinstance(value, dict):
        return {str(k): plain_values(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain_values(v) for v in value]
    if isinstance(value, (str, bool, int)) or value is None:
        return value
    return float(value)


def save_model(model: NeuralUVModel, path: str | Path, half: bool = False) -> None:
    """Write a checkpoint (configuration, state dicts, loss history) atomically.

    Parameters
    ----------
    model : NeuralUVModel
    path : str or Path
    half : bool
        Store the weights as float16 (half the size; :func:`load_model` restores float32).
        Used for the checkpoints shipped in the package.
    """

    # heavy: torch (~1.1 s to import)
    import torch

    def weights(module):
        sd = module.state_dict()
        return {k: (v.half() if half and v.is_floating_point() else v) for k, v in sd.items()}

    state = {"format": "dressmeup-neural-uv-v1", "config": asdict(model.config),
             "patchnet": weights(model.patchnet), "forward_mlp": weights(model.forward_mlp),
             "backward_mlp": weights(model.backward_mlp), "history": plain_values(model.history)}
    buf = io.BytesIO()
    torch.save(state, buf)
    atomic_write_bytes(path, buf.getvalue())


def load_model(path: str | Path) -> NeuralUVModel:
    """Read a checkpoint written by :func:`save_model`.

    Raises
    ------
    FileNotFoundError
        Missing file.
    InputError
        Not a neural-UV checkpoint (or over the limits of :mod:`dressmeup.limits`).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"neural UV checkpoint {path} does not exist (train one with "
                                "'dressmeup baseline train-uvparam')")
    state = load_checkpoint(path, "neural UV checkpoint", "dressmeup-neural-uv-v1",
                            ("config", "patchnet", "forward_mlp", "backward_mlp"))
    def weights(sd):  # float16 checkpoints (shipped ones) back to float32
        return {k: (v.float() if v.is_floating_point() else v) for k, v in sd.items()}

    try:
        c = dict(state["config"])
        c["weights"] = tuple(c["weights"])
        cfg = NeuralConfig(**c)
        patchnet, fwd, bwd = _build_modules(cfg)
        patchnet.load_state_dict(weights(state["patchnet"]))
        fwd.load_state_dict(weights(state["forward_mlp"]))
        bwd.load_state_dict(weights(state["backward_mlp"]))
    except (RuntimeError, ValueError, TypeError, KeyError, AttributeError) as exc:
        raise InputError(f"neural UV checkpoint {path}: damaged or of another version "
                         f"({str(exc).splitlines()[0][:200]})") from exc
    return NeuralUVModel(cfg, patchnet.eval(), fwd.eval(), bwd.eval(), state.get("history", {}))
