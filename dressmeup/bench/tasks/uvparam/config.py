"""UV parameterisation task: metrics and default options (docs/spec.md section 1)."""

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
    MetricSpec("seam_length", "Seams", "", 1.0, "lower", 2,
               "3D length of the seam edges (interior mesh edges whose faces give their end "
               "points different UVs) / sqrt(surface area); 0 without cuts"),
    MetricSpec("charts", "Charts", "", 1.0, "lower", 0,
               "connected components of faces across the mesh edges that are not seams"),
    MetricSpec("packing", "Packing", "%", 100.0, "higher", 1,
               "UV triangle area / area of the square the atlas is scaled into (its bounding "
               "box with the longer side 1)"),
)

#: Metrics whose trade-off the leaderboard shows: a method is on the Pareto front when no
#: other method is at least as good on both and better on one (distortion against cutting).
PARETO = ("qce", "seam_length")

#: Tracks of editions that have them: ``pretrained`` (the method never saw the test meshes:
#: no optimisation or training on them) and ``per-mesh`` (optimisation on each mesh allowed).
TRACKS = ("pretrained", "per-mesh")

DEFAULT_OPTIONS: dict = {
    "size_limit_mb": 256,          # per-file size limit of a submission
    "overlap_resolution": 1024,    # grid resolution of the overlap estimate
}

EXTRA_COLUMNS = ("n_charts",)

#: Result column of the factor bootstrap intervals resample: the mesh (one item per mesh).
UNIT_COLUMNS = ("sample_id",)

#: A submission declares its track (``per-mesh`` or ``pretrained``): leaderboards rank
#: within each track, never a track's only entry above another track's methods.
TRACK_LEVEL = "submission"
#: QCE and ASE are skewed by a few hard meshes: tables print mean / median.
SHOW_MEDIAN = True
