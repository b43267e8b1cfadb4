"""Correspondence task (per-vertex embedding -> Richness): metrics and options."""

from __future__ import annotations

from dressmeup.bench.tasks.base import MetricSpec

METRICS: tuple[MetricSpec, ...] = (
    MetricSpec("richness", "Richness", "", 1.0, "lower", 4,
               "rank agreement of embedding and geodesic neighbourhoods (thesis eq. 4.15-4.17)"),
)
DEFAULT_OPTIONS: dict = {
    "k": 10,                  # near/far neighbourhood size
    "max_vertices": 1000,     # Richness on a seeded subset of vertices (geodesics are n x n)
    "seed": 0,
    "size_limit_mb": 256,
}
EXTRA_COLUMNS: tuple[str, ...] = ()

#: Result columns of the factors the items share, resampled together by the bootstrap:
#: the garment and the subject wearing it.
UNIT_COLUMNS = ("garment_id", "subject_id")
