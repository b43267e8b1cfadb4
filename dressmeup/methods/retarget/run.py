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

log = logging.getLogger(__name__)

__all__ = ["body_model_for", "predict_pairs", "training_triplets", "parse_value"]


def body_model_for(params, cache: dict | None = None):
    """The body model named by ``params.model`` (one instance per name in ``cache``)."""
    from dressmeup.body import get_body_model

    cache = {} if cache is None else cache
    if params.model not in cache:
        cache[params.model] = get_body_model(params.model)
    return cache[params.model]


def predict_pairs(method, pairs: Sequence[Any], limit: int | None = None) -> tuple[dict[str, np.ndarray], list[float]]:
    """Retarget the source garment of every pair onto its target body.

    Parameters
    ----------
    method : a retargeting method (``get_method(...)``).
    pairs : sequence of :class:`dressmeup.data.RetargetPair`.
    limit : only the first ``limit`` pairs (None: all).

    Returns
    -------
    predictions : pair id -> (n, 3) float64 vertices.
    seconds : wall time of each prediction.
    """
    from dressmeup.errors import InputError
    from dressmeup.progress import progress

    models: dict[str, Any] = {}
    preds: dict[str, np.ndarray] = {}
    seconds: list[float] = []
    pairs = list(pairs)[: limit if limit else None]
    for pair in progress(pairs, desc=f"retarget ({getattr(method, 'name', 'method')})", total=len(pairs)):
        garment = pair.source.garment()
        src, tgt = pair.source.body(), pair.target.body()
        if src is None or tgt is None:
            raise InputError(f"pair {pair.pair_id}: a sample has no body.npz (needed by every retargeting method)")
        model = body_model_for(src, models)
        t0 = time.perf_counter()
        preds[pair.pair_id] = np.asarray(method.retarget(garment.vertices, garment.faces, src, tgt, model),
                                         dtype=np.float64)
        seconds.append(time.perf_counter() - t0)
    return preds, seconds


def training_triplets(dataset, split: str = "train", max_triplets: int | None = None, seed: int = 0,
                      exclude_garments: Sequence[str] = ()):
    """Self-supervised training triplets (garment, source body, target body) of a split.

    Every ordered pose pair of every garment in ``split`` (no ground truth is read: only the
    source garment and the two bodies), shuffled with ``seed`` and cut to ``max_triplets``.

    Returns
    -------
    triplets : list of (garment_V (n, 3), garment_F (m, 3), source BodyParams, target BodyParams)
    body_model : the body model of the first sample.
    """
    from dressmeup.errors import InputError

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
        triplets.append((np.asarray(g.vertices), np.asarray(g.faces), src, tgt))
        body_model_for(src, models)
    if len(models) > 1:
        raise InputError(f"split {split!r} mixes body models {sorted(models)}; train one model per body model")
    return triplets, next(iter(models.values()))


def parse_value(text: str) -> Any:
    """``"3" -> 3``, ``"0.5" -> 0.5``, ``"true" -> True``, ``"none" -> None``, else the string."""
    low = text.strip().lower()
    if low in ("true", "false"):
        return low == "true"
    if low in ("none", "null"):
        return None
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return text
