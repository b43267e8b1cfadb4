"""Run a retargeting method over a dataset's pairs, and gather training triplets.

Library side of ``dressmeup baseline retarget`` / ``train-retarget`` (the CLI only parses
arguments and writes the submission).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from dressmeup.body import get_body_model
from dressmeup.cache import hash_arrays
from dressmeup.errors import InputError
from dressmeup.executors import LocalExecutor, in_order
from dressmeup.geometry.mesh import edges as mesh_edges
from dressmeup.progress import progress

log = logging.getLogger(__name__)

__all__ = [
    "body_model_for", "predict_pairs", "RetargetPairJob", "training_triplets",
    "garment_fingerprints", "check_split_leakage"
]


def body_model_for(params, cache: dict | None = None):
    """The body model named by ``params.model`` (one instance per name in ``cache``)."""

    cache = {} if cache is None else cache
    if params.model not in cache:
        cache[params.model] = get_body_model(params.model)
    return cache[params.model]


#: body models loaded in this process (a pool or Dask worker keeps them across pairs)
_MODELS: dict[str, Any] = {}


class RetargetPairJob:
    """One pair's job for an executor: ``job(pair) -> ((n, 3) float64 vertices, seconds)``.

    Picklable when ``method`` is (it travels to pool or Dask workers with the job); body
    models are loaded once per process.
    """

    __name__ = "retarget_pair"

    def __init__(self, method: Any) -> None:
        self.method = method

    def __call__(self, pair: Any) -> tuple[np.ndarray, float]:
        garment = pair.source.garment()
        src, tgt = pair.source.body(), pair.target.body()
        if src is None or tgt is None:
            raise InputError(f"pair {pair.pair_id}: a sample has no body.npz (needed by every "
                             f"retargeting method)")
        model = body_model_for(src, _MODELS)
        t0 = time.perf_counter()
        V = np.asarray(self.method.retarget(garment.vertices, garment.faces, src, tgt, model),
                       dtype=np.float64)
        return V, time.perf_counter() - t0


def predict_pairs(method, pairs: Sequence[Any], limit: int | None = None,
                  executor: Any = None) -> tuple[dict[str, np.ndarray], list[float]]:
    """Retarget the source garment of every pair onto its target body.

    Parameters
    ----------
    method : a retargeting method (``get_method(...)``).
    pairs : sequence of :class:`dressmeup.data.RetargetPair`.
    limit : only the first ``limit`` pairs (None: all).
    executor : where the per-pair jobs (:class:`RetargetPairJob`) run
        (:mod:`dressmeup.executors`; default: one after the other in this process).

    Returns
    -------
    predictions : pair id -> (n, 3) float64 vertices, in pair order.
    seconds : wall time of each prediction.

    Raises
    ------
    Exception
        The first pair's error (in pair order), after every pair has run.
    """

    pairs = list(pairs)[: limit if limit else None]
    executor = executor or LocalExecutor(1)
    preds: dict[str, np.ndarray] = {}
    seconds: list[float] = []
    errors: list[BaseException] = []
    done = progress(executor.run(RetargetPairJob(method), pairs),
                    desc=f"retarget ({getattr(method, 'name', 'method')})", total=len(pairs))
    for i, res in in_order(done):
        if isinstance(res, BaseException):
            errors.append(res)
            continue
        preds[pairs[i].pair_id], sec = res
        seconds.append(sec)
    if errors:
        raise errors[0]
    return preds, seconds


def training_triplets(dataset, split: str = "train", max_triplets: int | None = None, seed: int = 0,
                      exclude_garments: Sequence[str] = (), with_truth: bool = False):
    """Training triplets (garment, source body, target body) of a split.

    Every ordered pair of every garment in ``split``, shuffled with ``seed`` and cut to
    ``max_triplets``. Without ``with_truth`` no ground truth is read (only the source garment
    and the two bodies: self-supervised training); with it the target garment is appended
    (the supervised variant, validation curves).

    Returns
    -------
    triplets : list of (garment_V (n, 3), garment_F (m, 3), source BodyParams, target BodyParams
        [, target garment vertices (n, 3)])
    body_model : the body model of the first sample.
    """

    pairs = [p for p in dataset.retarget_pairs(split) if p.source.garment_id not in set(exclude_garments)]
    if not pairs:
        raise InputError(f"dataset {dataset.root}: no retargeting pairs in split {split!r}")
    order = np.random.default_rng(seed).permutation(len(pairs))
    if max_triplets:
        order = order[:max_triplets]
    triplets, models = [], {}
    for i in order:
        p = pairs[int(i)]
        g = p.source.garment()
        src, tgt = p.source.body(), p.target.body()
        item = (np.asarray(g.vertices), np.asarray(g.faces), src, tgt)
        if with_truth:
            truth = np.asarray(p.target.garment().vertices, dtype=np.float64)
            if truth.shape != item[0].shape:
                raise InputError(f"pair {p.pair_id}: target garment has {len(truth)} vertices, source "
                                 f"{len(item[0])}; supervised training needs one topology per garment")
            item = (*item, truth)
        triplets.append(item)
        body_model_for(src, models)
    if len(models) > 1:
        raise InputError(f"split {split!r} mixes body models {sorted(models)}; train one model per body model")
    return triplets, next(iter(models.values()))


def garment_fingerprints(dataset, split: str) -> dict[str, dict[str, Any]]:
    """Content fingerprints of every garment of a split (ids play no part).

    Returns
    -------
    garment id -> {"samples": set of sample content hashes (vertices rounded to 0.01 mm and
    faces), "topology": hash of the faces, "lengths": (e,) float64 edge lengths of its first
    sample (metres), "split": split}.
    """

    out: dict[str, dict[str, Any]] = {}
    for s in dataset.filter(split=split).samples():
        g = s.garment()
        V, F = np.asarray(g.vertices, dtype=np.float64), np.asarray(g.faces, dtype=np.int64)
        rec = out.setdefault(s.garment_id, {"samples": set(), "topology": hash_arrays(F), "lengths": None,
                                            "split": split})
        rec["samples"].add(hash_arrays(np.round(V, 5), F))
        if rec["lengths"] is None:
            E = mesh_edges(F)
            rec["lengths"] = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    return out


def check_split_leakage(dataset, train_split: str = "train", other_splits: Sequence[str] = ("val", "test"),
                        length_tolerance: float = 0.01) -> dict[str, Any]:
    """Refuse training data whose garments appear, by content, in another split.

    A train garment leaks when one of its samples has the same content hash as a sample of
    another split, or when it has the same face list as a garment of another split and its
    edge lengths differ from that garment's by less than ``length_tolerance`` (median relative
    difference: the same garment under another id, draped in another pose).

    Returns
    -------
    dict: ``train_garments``, ``compared_garments`` (per other split), ``closest`` (the smallest
    median relative edge-length difference met between same-topology garments, or None).

    Raises
    ------
    InputError
        Naming the leaking garment ids.
    """

    train = garment_fingerprints(dataset, train_split)
    others: dict[str, dict[str, Any]] = {}
    for sp in other_splits:
        for g, rec in garment_fingerprints(dataset, sp).items():
            others[f"{sp}:{g}"] = rec
    closest = None
    for g, rec in train.items():
        for og, orec in others.items():
            if rec["samples"] & orec["samples"]:
                raise InputError(f"garment {g!r} of split {train_split!r} has a sample identical in content to "
                                 f"one of {og}: training would leak; remove it from the training split")
            if rec["topology"] == orec["topology"] and len(rec["lengths"]) == len(orec["lengths"]):
                rel = float(np.median(np.abs(rec["lengths"] - orec["lengths"])
                                      / np.maximum(orec["lengths"], 1e-12)))
                closest = rel if closest is None else min(closest, rel)
                if rel < length_tolerance:
                    raise InputError(f"garment {g!r} of split {train_split!r} has the faces of {og} and edge "
                                     f"lengths within {100 * rel:.2f} %: the same garment under another id; "
                                     "training would leak")
    return {"train_garments": sorted(train), "compared_garments": sorted(others), "closest": closest}
