"""UV parameterisation task: metrics and default options (SPEC.md section 1)."""

from __future__ import annotations

from dressmeup.bench.tasks.base import MetricSpec

METRICS: tuple[MetricSpec, ...] = (
    MetricSpec("qce", "QCE", "", 1.0, "lower", 3,
               "quasi-conformal error, 3D-area-weighted mean of sigma_max/sigma_min (1 ideal)"),
    MetricSpec("qce_max", "QCE max", "", 1.0, "lower", 2, "largest finite per-face QCE"),
    MetricSpec("ase", "ASE", "", 1.0, "lower", 3,
               "area scaling error, 3D-area-weighted mean |log(A_uv s / A_3d)| (0 ideal)"),
    MetricSpec("flip", "Flipped", "%", 100.0, "lower", 2,
               "share of faces whose UV orientation is opposite to the majority"),
    MetricSpec("overlap", "Overlap", "%", 100.0, "lower", 2,
               "share of the covered UV area covered more than once"),
    MetricSpec("zero_area", "Zero-area", "%", 100.0, "lower", 2,
               "share of 3D area whose UV triangles have zero area (infinite QCE)"),
    MetricSpec("time", "Time", "s", 1.0, "lower", 2,
               "wall time of the method on the mesh, as reported in the submission file"),
)

DEFAULT_OPTIONS: dict = {
    "size_limit_mb": 256,          # per-file size limit of a submission
    "overlap_resolution": 1024,    # grid resolution of the overlap estimate
}

EXTRA_COLUMNS = ("n_charts",)
