"""Retargeting task: metrics and default options (docs/spec.md sections 1 and 4)."""

from __future__ import annotations

from dressmeup.bench.tasks.base import MetricSpec

METRICS: tuple[MetricSpec, ...] = (
    MetricSpec("p2s", "P2S", "mm", 1000.0, "lower", 2,
               "mean distance from surface samples of the prediction to the ground-truth "
               "surface (point-to-triangle)"),
    MetricSpec("p2s_bi", "P2S-bi", "mm", 1000.0, "lower", 2,
               "mean of P2S prediction->ground truth and ground truth->prediction"),
    MetricSpec("chamfer", "Chamfer", "mm²", 1e6, "lower", 2,
               "squared Chamfer distance between surface samples (sum of the two means)"),
    MetricSpec("ed", "ED", "mm", 1000.0, "lower", 2,
               "mean per-vertex Euclidean distance (only where the ground truth keeps the "
               "source topology; NaN otherwise)"),
    MetricSpec("nc", "NC", "", 1.0, "higher", 4,
               "normal consistency: mean signed cosine between matching normals"),
    MetricSpec("ir", "IR", "%", 100.0, "lower", 2,
               "share of garment surface area inside the target body (winding number)"),
    MetricSpec("p2s_body", "P2S-body", "mm", 1000.0, "lower", 2,
               "the thesis' P2S (section 4.4.5): mean distance from each garment vertex to the "
               "target body surface, not to the ground truth (a garment sunk into the body "
               "scores low: read it with IR and with the ground truth's own value, p2s_body_gt)"),
)

#: Defaults every retarget edition starts from (an edition may override each).
DEFAULT_OPTIONS: dict = {
    "n_samples": 100_000,     # surface samples per mesh for P2S, Chamfer, NC (different topology)
    "seed": 0,                # seed of the surface samples (same for prediction and ground truth)
    "size_limit_mb": 256,     # per-file size limit of a submission
    "chamfer_squared": True,  # Chamfer of squared distances (pytorch3d convention)
}

#: Extra per-pair columns written beside the metrics (not ranked).
EXTRA_COLUMNS = ("ir_gt", "p2s_body_gt")

#: Result columns of the factors the pairs share, resampled together by the bootstrap: the
#: garment (its pairs are correlated), and the bodies and poses every garment is worn in.
UNIT_COLUMNS = ("garment_id", "target_subject", "target_pose")
