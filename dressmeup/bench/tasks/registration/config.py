"""Registration task (scan -> body parameters): metrics and options (docs/spec.md section 1)."""

from __future__ import annotations

from dressmeup.bench.tasks.base import MetricSpec

METRICS: tuple[MetricSpec, ...] = (
    MetricSpec("v2v", "V2V", "mm", 1000.0, "lower", 2,
               "mean per-vertex error of the posed body against the known body (same model)"),
    MetricSpec("mpjpe", "MPJPE", "mm", 1000.0, "lower", 2,
               "mean per-joint position error against the known body (same model)"),
    MetricSpec("scan_p2s", "Scan P2S", "mm", 1000.0, "lower", 2,
               "mean distance from scan surface samples to the fitted body surface"),
)
DEFAULT_OPTIONS: dict = {"n_samples": 100_000, "seed": 0, "size_limit_mb": 256}
EXTRA_COLUMNS: tuple[str, ...] = ()

#: Result columns of the factors the scans share, resampled together by the bootstrap:
#: the subject (fits of one body share its shape) and the pose.
UNIT_COLUMNS = ("subject_id", "pose_id")
