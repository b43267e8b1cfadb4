"""The standard metrics, exactly as docs/spec.md section 1 defines them (docs/metrics.md explains
each one, its units and how it differs from other toolkits' conventions).

Every function takes plain arrays or a ``trimesh.Trimesh`` (meshes may also be given as a
``(vertices, faces)`` tuple), validates them at the entry and returns a float; ``*_details``
variants return the per-element values behind the figure. Distances are float64, in the
input's units (metres in the toolkit).

=============================  =====================================  =========
metric                         function                               better
=============================  =====================================  =========
P2S                            :func:`p2s`, :func:`p2s_bidirectional`  lower
Chamfer (squared, sum of means) :func:`chamfer`                        lower
ED                             :func:`euclidean`                      lower
NC                             :func:`normal_consistency`             higher
IR                             :func:`interpenetration_ratio`         lower
penetrating vertices           :func:`penetrating_vertex_fraction`    lower
QCE                            :func:`qce`                            lower (1 ideal)
ASE                            :func:`ase`                            lower (0 ideal)
UV validity                    :func:`uv_validity`                    lower
seams / charts / packing       :func:`uv_seams`                       lower / - / higher
Richness                       :func:`richness`                       lower
fusion quality / F-score       :func:`fusion_quality`, :func:`fscore`  see docs
=============================  =====================================  =========
"""

from dressmeup.metrics._common import TopologyMismatchError
from dressmeup.metrics.distance import (
    chamfer,
    chamfer_details,
    euclidean,
    euclidean_details,
    p2s,
    p2s_bidirectional,
    p2s_details,
)
from dressmeup.metrics.normals import (
    NormalConsistency,
    normal_consistency,
    normal_consistency_details,
)
from dressmeup.metrics.penetration import (
    Interpenetration,
    interpenetration_details,
    interpenetration_ratio,
    penetrating_vertex_fraction,
    signed_distance,
)
from dressmeup.metrics.reconstruction import (
    DEFAULT_FSCORE_THRESHOLDS,
    FusionQuality,
    accuracy,
    chamfer_l1,
    completeness,
    fscore,
    fusion_quality,
)
from dressmeup.metrics.report import MetricValue, compare_meshes, uv_report
from dressmeup.metrics.richness import RichnessResult, richness, richness_details
from dressmeup.metrics.uv import (
    ASEResult,
    QCEResult,
    ase,
    ase_details,
    qce,
    qce_details,
    uv_jacobian_singular_values,
)
from dressmeup.metrics.uv_layout import (
    UVSeams,
    UVValidity,
    uv_seams,
    uv_validity,
)

__all__ = [
    "ASEResult",
    "DEFAULT_FSCORE_THRESHOLDS",
    "FusionQuality",
    "Interpenetration",
    "NormalConsistency",
    "QCEResult",
    "RichnessResult",
    "TopologyMismatchError",
    "MetricValue",
    "UVValidity",
    "compare_meshes",
    "uv_report",
    "accuracy",
    "ase",
    "ase_details",
    "chamfer",
    "chamfer_details",
    "chamfer_l1",
    "completeness",
    "euclidean",
    "euclidean_details",
    "fscore",
    "fusion_quality",
    "interpenetration_details",
    "interpenetration_ratio",
    "normal_consistency",
    "normal_consistency_details",
    "p2s",
    "p2s_bidirectional",
    "p2s_details",
    "penetrating_vertex_fraction",
    "qce",
    "qce_details",
    "richness",
    "richness_details",
    "signed_distance",
    "uv_jacobian_singular_values",
    "uv_seams",
    "UVSeams",
    "uv_validity",
]
