"""The precomputed inference path of ``isomap-refine`` (:mod:`dressmeup.methods.retarget.refine`):
what depends only on the garment and its source body (the coarse stage's preparation, the
garment's PointNet code, the embedding's share of the first layer) is computed once and
memoised, so that a new target costs posing it, a gather, one k-NN search and the rest of the
network.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.methods.retarget.base import body_context, check_garment
from dressmeup.methods.retarget.refine_losses import subsample

__all__ = ["retarget_prepared", "garment_partial"]


def retarget_prepared(method: Any, garment_V, garment_F, source, target, body_model) -> np.ndarray:
    """``method.retarget`` with ``precompute``: (n, 3) float64 world positions.

    ``method`` is a fitted or loaded :class:`~dressmeup.methods.retarget.refine.IsomapRefine`.
    The garment's preparation (coarse-stage data of ``method.prepared``) and its network
    partial (:func:`garment_partial`) are memoised per garment and source body; each call
    poses the target, gathers the coarse points, finds the k nearest target vertices and runs
    the body PointNet and the decoder. Sets ``method.last_timing_`` (seconds per stage).
    """
    # heavy: torch (~1.1 s to import)
    import torch

    from dressmeup.methods.retarget.refine_net import decode_with_partial

    V, F = check_garment(garment_V, garment_F)
    t0 = time.perf_counter()
    s = body_context(body_model, source)
    t1 = time.perf_counter()
    emb = method.embedding(body_model)
    prep = method.prepared(V, F, s, emb)
    part = garment_partial(method, prep, V, s)
    t2 = time.perf_counter()
    t = body_context(body_model, target)
    t3 = time.perf_counter()
    center = t.joints[0]
    TV = t.skin_vertices - center
    x = (prep.with_offset(t.skin_vertices, t.skin_normals()) if method.config.carry_offset
         else prep.coarse(t.skin_vertices)) - center
    if method.config.correspondence_noise:
        x = x + np.random.default_rng(method.config.seed).normal(0.0, float(method.config.correspondence_noise), size=x.shape)
    x = x.astype(np.float32)
    k = int(min(method.config.k_neighbors, len(TV)))
    _, nb = cKDTree(TV).query(x, k=k, workers=torch.get_num_threads())  # exact at any count
    # the gather on torch (threaded): the same float32 values as numpy's single-threaded ``TV[nb]``
    x_t = torch.from_numpy(x)
    nb_t = torch.from_numpy(np.ascontiguousarray(nb, dtype=np.int64).reshape(-1))
    neighbors = (torch.from_numpy(TV.astype(np.float32)).index_select(0, nb_t).view(len(x), k, 3)
                 - x_t[:, None, :]).reshape(len(x), 3 * k)
    t4 = time.perf_counter()
    dev = torch.device(method.device)
    net = method.network_
    with torch.no_grad():
        body_pts = torch.as_tensor(subsample(TV, method.config.n_points, method.config.seed + 1).astype(np.float32), device=dev)
        code = torch.cat([part["garment_code"], net.encoder_body(body_pts)])
        dx = decode_with_partial(net.decoder, x_t.to(dev), neighbors.to(dev), part["phi_term"], code)
    t5 = time.perf_counter()
    method.last_timing_ = {"source_posing": t1 - t0, "preparation": t2 - t1,
                           "target_posing": t3 - t2, "correspondence": t4 - t3, "network": t5 - t4}
    return x.astype(np.float64) + dx.cpu().numpy().astype(np.float64) + center


def garment_partial(method: Any, prep: Any, V: np.ndarray, s: Any) -> dict:
    """Per-garment network inputs: the garment's PointNet code and ``phi W_phi^T`` (memoised)."""
    # heavy: torch (~1.1 s to import)
    import torch

    key = (prep.key, id(method.network_), int(method.config.n_points), int(method.config.seed))
    memo = method.__dict__.setdefault("_partial_memo", {})
    if key not in memo:
        if len(memo) >= 8:
            memo.pop(next(iter(memo)))
        dev = torch.device(method.device)
        net = method.network_
        d = int(method.config.dim)
        with torch.no_grad():
            gp = torch.as_tensor(subsample(V - s.joints[0], method.config.n_points, method.config.seed).astype(np.float32),
                                 device=dev)
            W = net.decoder.layers[0].weight
            phi_term = torch.as_tensor(prep.phi.astype(np.float32), device=dev) @ W[:, 3:3 + d].T
            memo[key] = {"garment_code": net.encoder_garment(gp), "phi_term": phi_term}
    return memo[key]
