"""Aggregates of the generator's per-sample statistics (``generator/stats/*.json``)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np


def read_stats(root: str | os.PathLike,
               sample_ids: list[str] | None = None) -> list[dict[str, Any]]:
    """Every sample's statistics (``generator/stats/<sample>.json``) in sample order; hidden
    files (temporary files of an interrupted atomic write) are ignored; with ``sample_ids``
    only those samples'."""
    files = sorted((Path(root) / "generator" / "stats").glob("[!.]*.json"))
    if sample_ids is not None:
        wanted = set(sample_ids)
        files = [f for f in files if f.stem in wanted]
    return [json.loads(f.read_text()) for f in files]


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
    rows = read_stats(root, sample_ids)
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


def summarize_dress_stats(root: str | os.PathLike,
                          sample_ids: list[str] | None = None) -> dict[str, Any]:
    """Aggregate generator 3.x's per-sample statistics (``generator/stats/*.json``).

    Returns
    -------
    dict: ``n``; ``inside_area_pct`` and ``self_intersecting_faces`` (median, mean, max);
    ``strain_mean`` (mean); the solver's end state over samples: ``grad_norm_max``,
    ``unconverged`` (samples whose last solve missed its tolerance), ``iterations_mean``;
    per garment type the median inside area and self-intersecting faces.
    """
    rows = read_stats(root, sample_ids)
    if not rows:
        return {}

    def trio(key: str) -> dict[str, float]:
        a = np.array([r[key] for r in rows], float)
        return {"median": round(float(np.median(a)), 4), "mean": round(float(a.mean()), 4),
                "max": round(float(a.max()), 4)}

    by_type: dict[str, list[dict]] = {}
    for r in rows:
        by_type.setdefault(r["garment_type"], []).append(r)
    return {
        "n": len(rows),
        "inside_area_pct": trio("inside_area_pct"),
        "self_intersecting_faces": trio("self_intersecting_faces"),
        "strain_mean": round(float(np.mean([r["strain_mean"] for r in rows])), 5),
        "grad_norm_max": round(float(np.max([r["grad_norm"] for r in rows])), 6),
        "unconverged": int(sum(not r["converged"] for r in rows)),
        "iterations_mean": round(float(np.mean([r["iterations"] for r in rows])), 1),
        "by_type": {t: {"inside_area_pct_median": round(float(np.median(
                            [r["inside_area_pct"] for r in v])), 4),
                        "self_intersecting_faces_median": float(np.median(
                            [r["self_intersecting_faces"] for r in v]))}
                    for t, v in sorted(by_type.items())},
    }
