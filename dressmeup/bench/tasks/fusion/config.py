"""Fusion task (capture -> mesh): metrics and default options (docs/spec.md section 1)."""

from __future__ import annotations

from dressmeup.bench.tasks.base import MetricSpec

METRICS: tuple[MetricSpec, ...] = (
    MetricSpec("accuracy", "Accuracy", "mm", 1000.0, "lower", 2,
               "mean distance from prediction samples to the ground-truth surface"),
    MetricSpec("completeness", "Completeness", "mm", 1000.0, "lower", 2,
               "mean distance from ground-truth samples to the prediction"),
    MetricSpec("chamfer_l1", "Chamfer-L1", "mm", 1000.0, "lower", 2,
               "(accuracy + completeness) / 2"),
    MetricSpec("fscore_1mm", "F@1mm", "%", 100.0, "higher", 1, "F-score at 1 mm"),
    MetricSpec("fscore_2mm", "F@2mm", "%", 100.0, "higher", 1, "F-score at 2 mm"),
    MetricSpec("fscore_5mm", "F@5mm", "%", 100.0, "higher", 1, "F-score at 5 mm"),
    MetricSpec("fscore_10mm", "F@10mm", "%", 100.0, "higher", 1, "F-score at 10 mm"),
)
DEFAULT_OPTIONS: dict = {"n_samples": 100_000, "seed": 0, "size_limit_mb": 256}
EXTRA_COLUMNS: tuple[str, ...] = ()
THRESHOLDS = {"fscore_1mm": 0.001, "fscore_2mm": 0.002, "fscore_5mm": 0.005,
              "fscore_10mm": 0.01}

#: Result columns of the factors the items share, resampled together by the bootstrap:
#: the subject, the garment and the pose of each captured sample.
UNIT_COLUMNS = ("subject_id", "garment_id", "pose_id")
