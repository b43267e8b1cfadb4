"""Aggregates of the generator's per-sample statistics (``generator/stats/*.json``)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np


def summarize_stats(root: str | os.PathLike,
                    sample_ids: list[str] | None = None) -> dict[str, Any]:
    """Aggregate the generator's per-sample statistics (``generator/stats/*.json``).

    Hidden files (temporary files of an interrupted atomic write) are ignored; with
    ``sample_ids`` only those samples' statistics count.

    Returns
    -------
    dict with millimetre figures: ``skinning_mean_mm`` (mean over samples of the mean
    distance between the skinned and the draped garment), ``skinning_max_mm``,
    ``min_signed_distance_mm`` (deepest vertex; negative is inside the body),
    ``stretch_mean`` (mean |l/L - 1| of edges after draping), ``skinned_stretch_mean`` and
    per garment type means of the skinning distance.
    """
    files = sorted((Path(root) / "generator" / "stats").glob("[!.]*.json"))
    if sample_ids is not None:
        wanted = set(sample_ids)
        files = [f for f in files if f.stem in wanted]
    rows = [json.loads(f.read_text()) for f in files]
    if not rows:
        return {}
    by_type: dict[str, list[float]] = {}
    for r in rows:
        by_type.setdefault(r["garment_type"], []).append(r["skinning_mean_m"] * 1000)
    return {
        "n": len(rows),
        "skinning_mean_mm": round(float(np.mean([r["skinning_mean_m"] for r in rows])) * 1000, 3),
        "skinning_max_mm": round(float(np.max([r["skinning_max_m"] for r in rows])) * 1000, 3),
        "min_signed_distance_mm": round(float(np.min([r["min_signed_distance_m"]
                                                       for r in rows])) * 1000, 3),
        "stretch_mean": round(float(np.mean([r["stretch_mean"] for r in rows])), 5),
        "skinned_stretch_mean": round(float(np.mean([r["skinned_stretch_mean"]
                                                      for r in rows])), 5),
        "skinning_mean_mm_by_type": {k: round(float(np.mean(v)), 3)
                                     for k, v in sorted(by_type.items())},
    }
