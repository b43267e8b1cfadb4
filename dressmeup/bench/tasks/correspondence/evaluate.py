"""Correspondence task: Richness of a per-vertex embedding on a seeded vertex subset."""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.tasks.base import STATUS_OK
from dressmeup.bench.tasks.common import load_npz_arrays, open_dataset
from dressmeup.geometry.geodesic import geodesic_distances
from dressmeup.metrics import richness


def richness_on_subset(V: np.ndarray, F: np.ndarray, E: np.ndarray, k: int, max_vertices: int,
                       seed: int) -> float:
    """Richness over ``min(n, max_vertices)`` vertices drawn with ``seed``.

    Geodesics (heat method) from the subset to every vertex, restricted to the subset and
    symmetrised; the embedding rows of the subset. With ``n <= max_vertices`` every vertex
    is used.
    """

    n = V.shape[0]
    idx = np.arange(n) if n <= max_vertices else np.sort(
        np.random.default_rng(seed).choice(n, max_vertices, replace=False))
    G = geodesic_distances(V, F, idx, method="heat")[:, idx]
    G = 0.5 * (G + G.T)
    return float(richness(G, E[idx], k=k))


def score_job(job: Mapping[str, Any]) -> dict[str, Any]:
    """Score one embedding."""

    t0 = time.perf_counter()
    g = open_dataset(job["meta"]["data_root"])[job["item_id"]].garment()
    E = load_npz_arrays(Path(job["pred_path"]), ("embedding",))["embedding"].astype(np.float64)
    o = job["options"]
    value = richness_on_subset(np.asarray(g.vertices, np.float64), np.asarray(g.faces, np.int64),
                               E, int(o["k"]), int(o["max_vertices"]), int(o["seed"]))
    row = {"sample_id": job["item_id"], "category": job["category"], "richness": value}
    row.update(status=STATUS_OK, error="", note="", seconds=time.perf_counter() - t0)
    return row
