"""Retargeting task: score one pair (runs in worker processes).

Per pair (docs/spec.md sections 1 and 4):

- ``p2s``: mean distance from ``n_samples`` uniform surface samples of the prediction (seeded)
  to the ground-truth surface; ``p2s_bi`` averages it with ground truth -> prediction.
- ``chamfer``: Chamfer distance between the two sample sets (squared by default).
- ``ed``: mean per-vertex distance, only where the ground truth keeps the source topology;
  otherwise NaN and the row's ``note`` says why.
- ``nc``: normal consistency (per vertex for the same topology, sample-based otherwise).
- ``ir``: interpenetration ratio of the prediction against the TARGET body, posed from the
  target sample's body parameters with its body model (skin component); ``ir_gt`` is the
  ground truth's own IR against the same body, for reference.

The prediction and the ground truth are sampled with the same seed, so a prediction equal to
the ground truth scores exactly P2S = Chamfer = ED = 0 and NC = 1.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup import metrics as M
from dressmeup.bench.tasks.base import STATUS_OK, Item
from dressmeup.bench.tasks.retarget.data import _sample, open_dataset, read_prediction
from dressmeup.body import get_body_model
from dressmeup.cache import cache_dir, hash_arrays
from dressmeup.geometry.sampling import sample_surface
from dressmeup.geometry.topology import largest_component_faces
from dressmeup.io.atomic import atomic_path
from dressmeup.metrics import interpenetration_ratio
from dressmeup.progress import progress


# ------------------------------------------------------------------------ main process side
def largest_component(F: np.ndarray, n_vertices: int) -> np.ndarray:
    """Faces ``(k, 3)`` of the largest connected component (by face count) of a mesh."""
    F = np.asarray(F, dtype=np.int64)
    return F[largest_component_faces(F, n_vertices)]


def posed_body_file(params: Any, models: dict[str, Any]) -> Path:
    """Pose the body of ``params`` (a ``BodyParams``) once and cache its skin mesh on disk.

    The file ``<cache>/bench-bodies/<key>.npz`` holds ``vertices (n, 3) float64`` and
    ``faces (m, 3) int64`` of the largest connected component (the skin, docs/spec.md section 2);
    the key hashes the model name, gender and every parameter, so it is reused by every pair
    and every later run that shares the target.

    Parameters
    ----------
    params : BodyParams of the target sample.
    models : cache of body models by name, filled on first use.
    """

    key = hash_arrays(np.asarray(params.shape, np.float64), np.asarray(params.pose, np.float64),
                      np.asarray(params.transl, np.float64),
                      np.asarray([params.scale], np.float64),
                      extra=f"{params.model}|{params.gender}|skin-v1")
    path = cache_dir("bench-bodies") / f"{key}.npz"
    if path.is_file():
        return path
    if params.model not in models:
        models[params.model] = get_body_model(params.model)
    model = models[params.model]
    out = model.posed(params)
    V = np.asarray(out.vertices, dtype=np.float64).reshape(-1, 3)
    F = largest_component(np.asarray(model.faces), V.shape[0])
    with atomic_path(path) as tmp:
        np.savez(tmp, vertices=V, faces=F)
    return path


def jobs(edition: Any, data_root: Path, files: Mapping[str, Path],
         items: Sequence[Item], show_progress: bool | None = None) -> list[dict[str, Any]]:
    """Build one picklable job per pair; poses each distinct target body once (cached)."""

    ds = open_dataset(str(Path(data_root).resolve()))
    by_id = {s.sample_id: s for s in ds}
    need_body = "ir" in edition.metrics or "p2s_body" in edition.metrics
    bodies: dict[str, str] = {}
    models: dict[str, Any] = {}
    if need_body:
        targets = sorted({it.meta["target_id"] for it in items})
        for tid in progress(targets, desc="posing target bodies",
                            disable=None if show_progress is None else not show_progress):
            bodies[tid] = str(posed_body_file(by_id[tid].body(), models))
    out = []
    for it in items:
        out.append({
            "item_id": it.item_id, "category": it.category, "meta": dict(it.meta),
            "pred_path": str(files[it.item_id]),
            "body_path": bodies.get(it.meta["target_id"]),
            "metrics": list(edition.metrics), "options": dict(edition.options),
        })
    # Group by target so that a worker's ground-truth cache is hit.
    out.sort(key=lambda j: (j["meta"]["target_id"], j["item_id"]))
    return out


# ---------------------------------------------------------------------------- worker side
@functools.lru_cache(maxsize=8)
def _garment(root: str, sample_id: str) -> tuple[np.ndarray, np.ndarray]:
    g = _sample(open_dataset(root), sample_id).garment()
    return np.asarray(g.vertices, np.float64), np.asarray(g.faces, np.int64)


@functools.lru_cache(maxsize=8)
def _body(path: str) -> tuple[np.ndarray, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return np.asarray(z["vertices"], np.float64), np.asarray(z["faces"], np.int64)


@functools.lru_cache(maxsize=8)
def _gt_samples(root: str, sample_id: str, n: int, seed: int) -> np.ndarray:
    V, F = _garment(root, sample_id)
    return sample_surface(V, F, n, seed=seed)[0]


@functools.lru_cache(maxsize=8)
def _gt_ir(root: str, sample_id: str, body_path: str) -> float:
    V, F = _garment(root, sample_id)
    return float(interpenetration_ratio((V, F), _body(body_path)))


@functools.lru_cache(maxsize=8)
def _gt_p2s_body(root: str, sample_id: str, body_path: str) -> float:
    V, _ = _garment(root, sample_id)
    return float(M.p2s(V, _body(body_path)))


def evaluate_pair(pred_V: np.ndarray, src_F: np.ndarray, gt_V: np.ndarray, gt_F: np.ndarray,
                  body: tuple[np.ndarray, np.ndarray] | None, metrics: Sequence[str],
                  options: Mapping[str, Any], gt_points: np.ndarray | None = None
                  ) -> tuple[dict[str, float], list[str]]:
    """Score one retargeted garment against its ground truth.

    Parameters
    ----------
    pred_V : (n, 3) float64 predicted vertices (source topology ``src_F``).
    src_F : (m, 3) int64 source garment faces.
    gt_V, gt_F : (n', 3) float64 / (m', 3) int64 ground-truth garment.
    body : (vertices (b, 3), faces (k, 3)) of the posed target body, or None (no IR).
    metrics : names among ``p2s, p2s_bi, chamfer, ed, nc, ir, p2s_body``.
    options : ``n_samples``, ``seed``, ``chamfer_squared``.
    gt_points : (n_samples, 3) precomputed samples of the ground truth (same seed), optional.

    Returns
    -------
    values : metric name -> float (metres, ratios); ``ed`` NaN when topologies differ.
    notes : human-readable notes (why a value is NaN).
    """

    n, seed = int(options["n_samples"]), int(options["seed"])
    pred, gt = (pred_V, src_F), (gt_V, gt_F)
    values: dict[str, float] = {}
    notes: list[str] = []
    pred_pts = sample_surface(pred_V, src_F, n, seed=seed)[0]
    if gt_points is None:
        gt_points = sample_surface(gt_V, gt_F, n, seed=seed)[0]
    d_pg = d_gp = None
    if "p2s" in metrics or "p2s_bi" in metrics:
        d_pg = float(M.p2s(pred_pts, gt))
        values["p2s"] = d_pg
    if "p2s_bi" in metrics:
        d_gp = float(M.p2s(gt_points, pred))
        values["p2s_bi"] = 0.5 * (d_pg + d_gp)
    if "chamfer" in metrics:
        values["chamfer"] = float(M.chamfer(pred_pts, gt_points,
                                            squared=bool(options.get("chamfer_squared", True))))
    same_topology = pred_V.shape == gt_V.shape and src_F.shape == gt_F.shape \
        and np.array_equal(src_F, gt_F)
    if "ed" in metrics:
        if same_topology:
            values["ed"] = float(M.euclidean(pred_V, gt_V))
        else:
            values["ed"] = math.nan
            notes.append("ed: the ground truth does not share the source topology")
    if "nc" in metrics:
        values["nc"] = float(M.normal_consistency(pred, gt, n_samples=n, seed=seed))
    if "ir" in metrics:
        if body is None:
            values["ir"] = math.nan
            notes.append("ir: no target body")
        else:
            values["ir"] = float(M.interpenetration_ratio(pred, body))
    if "p2s_body" in metrics:
        if body is None:
            values["p2s_body"] = math.nan
            notes.append("p2s_body: no target body")
        else:
            values["p2s_body"] = float(M.p2s(pred_V, body))
    return {k: values[k] for k in metrics if k in values}, notes


def score_job(job: Mapping[str, Any]) -> dict[str, Any]:
    """Score one pair job (see :func:`jobs`); errors propagate to the scorer, which records them."""

    t0 = time.perf_counter()
    meta = job["meta"]
    root = meta["data_root"]
    opts = job["options"]
    pred_V, _ = read_prediction(Path(job["pred_path"]))
    pred_V = np.asarray(pred_V, np.float64)
    _, src_F = _garment(root, meta["source_id"])
    gt_V, gt_F = _garment(root, meta["target_id"])
    body = _body(job["body_path"]) if job.get("body_path") else None
    gt_pts = _gt_samples(root, meta["target_id"], int(opts["n_samples"]), int(opts["seed"]))
    values, notes = evaluate_pair(pred_V, src_F, gt_V, gt_F, body, job["metrics"], opts,
                                  gt_points=gt_pts)
    row: dict[str, Any] = {"sample_id": job["item_id"], "category": job["category"],
                           "source_id": meta["source_id"], "target_id": meta["target_id"],
                           "garment_id": meta["garment_id"],
                           **{k: meta[k] for k in ("track", "source_subject", "target_subject",
                                                   "target_pose") if k in meta}, **values}
    if "ir" in job["metrics"] and body is not None:
        row["ir_gt"] = _gt_ir(root, meta["target_id"], job["body_path"])
    if "p2s_body" in job["metrics"] and body is not None:
        row["p2s_body_gt"] = _gt_p2s_body(root, meta["target_id"], job["body_path"])
    row["status"] = STATUS_OK
    row["error"] = ""
    row["note"] = "; ".join(notes)
    row["seconds"] = time.perf_counter() - t0
    return row
