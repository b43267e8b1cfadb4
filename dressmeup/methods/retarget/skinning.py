"""``skinning``: the classical baseline. Transfer the source body's skinning weights to the
garment, unpose it with the source pose, move it with the body's shape change, and repose it
with the target pose (linear blend skinning)."""

from __future__ import annotations

import numpy as np

from dressmeup.body.skinning import closest_surface_points, lbs, transfer_weights, unpose
from dressmeup.geometry.mesh import vertex_normals
from dressmeup.methods.retarget.base import RetargetMethod, body_context, check_garment

__all__ = ["SkinningRetarget"]


class SkinningRetarget(RetargetMethod):
    """Skinning-weight transfer + unpose + shape offset + repose.

    Parameters
    ----------
    smooth_iterations : int
        Uniform smoothing steps of the transferred weights over the garment mesh (removes
        seams where neighbouring garment vertices snap to different body parts).
    shape_transfer : bool
        Add, at each garment vertex, the rest-pose displacement of its closest body point
        between the source and the target shapes.
    normal_check : bool
        Reject closest body points that face away from the garment vertex (an arm resting on
        the torso would otherwise carry the torso's cloth away with it when the arm moves).
    """

    name = "skinning"

    def __init__(self, smooth_iterations: int = 10, shape_transfer: bool = True,
                 normal_check: bool = True) -> None:
        self.smooth_iterations = smooth_iterations
        self.shape_transfer = shape_transfer
        self.normal_check = normal_check

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """See :mod:`dressmeup.methods.retarget.base`; returns (n, 3) float64."""

        V, F = check_garment(garment_V, garment_F)
        s, t = body_context(body_model, source), body_context(body_model, target)
        W_body = np.asarray(body_model.skinning_weights, dtype=np.float64)
        # weights from the posed source skin (world frame, where the garment is)
        normals = vertex_normals(V, F) if self.normal_check else None
        W = transfer_weights(s.skin_vertices, s.skin_faces, W_body[s.skin_ids], V, faces=F,
                             smooth_iterations=int(self.smooth_iterations),
                             point_normals=normals)
        rest = unpose((V - s.transl) / s.scale, W, s.transforms)
        if self.shape_transfer:
            _, _, fid, bary = closest_surface_points(s.rest_vertices[s.skin_ids], s.skin_faces, rest)
            delta = (t.rest_vertices - s.rest_vertices)[s.skin_ids]
            rest = rest + np.einsum("pk,pkc->pc", bary, delta[s.skin_faces[fid]])
        return t.scale * lbs(rest, W, t.transforms) + t.transl
