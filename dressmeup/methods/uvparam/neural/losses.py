"""Losses of the thesis' chapter 3, written for soft patch assignments and batched charts.

Where the thesis' formulas are literal sums that would not train (eq. 3.1 sums cosines over
all face pairs inside the square; eq. 3.8 compares raw areas whose scale depends on the
mesh), the normalised reading used here is stated in each docstring and in docs/uvparam.md.
"""

from __future__ import annotations

__all__ = ["cosine_loss", "geodesic_loss", "cycle_loss", "isometric_loss", "angle_loss",
           "area_loss", "triangle_cosines", "triangle_areas_2d", "triangle_areas_3d"]


def cosine_loss(face_probs, face_normals, face_areas, eps: float = 1e-8):
    """Flatness loss (eq. 3.1), soft version.

    For patch k, with soft face weights ``w_f = p_fk a_f``, the mean pairwise cosine of its
    face normals equals ``|m_k|^2`` with ``m_k = sum_f w_f n_f / sum_f w_f``; the loss is
    ``(1/K) sum_k (1 - |m_k|^2)^2``: zero for flat patches, one for patches whose normals
    cancel (a closed surface in one patch).

    Parameters
    ----------
    face_probs : (m, K) tensor, rows sum to 1
    face_normals : (m, 3) tensor, unit
    face_areas : (m,) tensor

    Returns
    -------
    scalar tensor
    """
    w = face_probs * face_areas[:, None]
    mk = (w.transpose(0, 1) @ face_normals) / (w.sum(0)[:, None] + eps)
    return ((1.0 - (mk * mk).sum(1)) ** 2).mean()


def geodesic_loss(vertex_probs, mass, geodesic, eps: float = 1e-8):
    """Compactness loss (eq. 3.2), soft and area-weighted.

    ``sum_k (q_k^T G q_k) / (sum_i q_ik) / A`` with ``q_ik = p_ik m_i`` (vertex mass) and
    ``A`` the total area: the expected geodesic distance from a surface point to the points
    of its own patch. Penalises patches whose parts lie far apart.

    Parameters
    ----------
    vertex_probs : (s, K) tensor (the rows of the vertices ``geodesic`` refers to)
    mass : (s,) tensor
    geodesic : (s, s) tensor of geodesic distances

    Returns
    -------
    scalar tensor
    """
    q = vertex_probs * mass[:, None]
    num = ((geodesic @ q) * q).sum(0)
    return (num / (q.sum(0) + eps)).sum() / (mass.sum() + eps)


def cycle_loss(x, x_rec):
    """Cycle consistency (eq. 3.3): mean squared distance between input and reconstruction.

    Parameters
    ----------
    x, x_rec : (N, 3) tensors

    Returns
    -------
    scalar tensor
    """
    return ((x - x_rec) ** 2).sum(1).mean()


def isometric_loss(uv, pairs, geodesic):
    """Isometry (eq. 3.6): UV distances match geodesic distances below the threshold.

    Parameters
    ----------
    uv : (N, 2) tensor
    pairs : (p, 2) long tensor of rows of ``uv`` (already restricted to ``g < sigma``)
    geodesic : (p,) tensor of their geodesic distances

    Returns
    -------
    scalar tensor: mean squared difference.
    """
    d = (uv[pairs[:, 0]] - uv[pairs[:, 1]]).norm(dim=1)
    return ((d - geodesic) ** 2).mean()


def _corner_vectors(P, faces):
    a, b, c = P[faces[:, 0]], P[faces[:, 1]], P[faces[:, 2]]
    return (b - a, c - a), (c - b, a - b), (a - c, b - c)


def triangle_cosines(P, faces, eps: float = 1e-12):
    """Cosines of the three corner angles of each triangle, (f, 3), for 2D or 3D points."""
    # heavy: torch (~1.1 s to import)
    import torch

    out = []
    for u, v in _corner_vectors(P, faces):
        out.append((u * v).sum(1) / (u.norm(dim=1) * v.norm(dim=1) + eps))
    return torch.stack(out, dim=1)


def triangle_areas_2d(uv, faces):
    """Signed UV areas (f,)."""
    a, b, c = uv[faces[:, 0]], uv[faces[:, 1]], uv[faces[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def triangle_areas_3d(x, faces):
    """Triangle areas (f,)."""
    # heavy: torch (~1.1 s to import)
    import torch

    a, b, c = x[faces[:, 0]], x[faces[:, 1]], x[faces[:, 2]]
    return 0.5 * torch.linalg.cross(b - a, c - a).norm(dim=1)


def angle_loss(uv, faces, cos3d):
    """Angle preservation (eq. 3.7): mean over faces and corners of (cos_uv - cos_3d)^2.

    Parameters
    ----------
    uv : (N, 2) tensor
    faces : (f, 3) long tensor into ``uv``
    cos3d : (f, 3) tensor, the 3D corner cosines

    Returns
    -------
    scalar tensor
    """
    return ((triangle_cosines(uv, faces) - cos3d) ** 2).mean()


def area_loss(uv, faces, area3d):
    """Area preservation (eq. 3.8), relative: mean of ((|a_uv| - a_3d) / mean(a_3d))^2.

    The thesis writes the squared difference of raw areas; dividing by the mean 3D face area
    makes the loss independent of the mesh resolution (face areas shrink with it).

    Parameters
    ----------
    uv : (N, 2) tensor
    faces : (f, 3) long tensor
    area3d : (f,) tensor

    Returns
    -------
    scalar tensor
    """
    a2 = triangle_areas_2d(uv, faces).abs()
    return (((a2 - area3d) / (area3d.mean() + 1e-20)) ** 2).mean()
