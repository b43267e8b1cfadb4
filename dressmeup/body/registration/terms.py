"""The terms of the registration objective: robust data term, pose and shape priors.

Data term (both directions, correspondences by nearest neighbour): residuals are measured
along the body's outward normal, ``r = (body - scan) . n``. A body point *outside* the scan
(``r > 0`` body-to-scan, or a scan point inside the body) costs a Geman-McClure penalty of
scale ``sigma_out``; *inside* (clothing, ``r < 0``) costs ``inside_weight`` times a
Geman-McClure of the smaller scale ``sigma_in``, which saturates for cloth a few
centimetres off the skin, so loose clothing does not inflate the body. A point-to-point
term with a small weight keeps correspondences from sliding. Inside gaps larger than
``cloth_max`` (6 cm) are not clothing: their excess costs like an outside residual, so
limbs of the scan far from the body still pull it; with ``far_free`` (the registrar's
``far_cloth="free"`` rule, in the stages that turn it on) they stop pulling beyond
``cloth_max`` (a skirt's far cloth bent the legs into it). Body points the scan did not
see carry no body -> scan cost (:func:`unseen_free_weights`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: Soft limits (radians) on the axis-angle components (x, y, z) of the SMPL-like joints in
#: the SMPL frame (y up, facing +z, left on +x). Knees bend one way; elbows bend forward.
JOINT_LIMITS: dict[str, tuple[tuple[float, float], ...]] = {
    "left_hip": ((-2.6, 0.9), (-1.0, 1.0), (-0.5, 1.2)),
    "right_hip": ((-2.6, 0.9), (-1.0, 1.0), (-1.2, 0.5)),
    "left_knee": ((-0.15, 2.7), (-0.3, 0.3), (-0.3, 0.3)),
    "right_knee": ((-0.15, 2.7), (-0.3, 0.3), (-0.3, 0.3)),
    "left_elbow": ((-0.6, 0.6), (-2.7, 0.15), (-0.6, 0.6)),
    "right_elbow": ((-0.6, 0.6), (-0.15, 2.7), (-0.6, 0.6)),
    "spine1": ((-0.6, 1.0), (-0.5, 0.5), (-0.5, 0.5)),
    "spine2": ((-0.5, 0.7), (-0.5, 0.5), (-0.4, 0.4)),
    "spine3": ((-0.5, 0.7), (-0.5, 0.5), (-0.4, 0.4)),
    "neck": ((-0.7, 0.9), (-0.9, 0.9), (-0.6, 0.6)),
    "head": ((-0.6, 0.7), (-0.9, 0.9), (-0.6, 0.6)),
    "left_collar": ((-0.4, 0.4), (-0.5, 0.5), (-0.5, 0.5)),
    "right_collar": ((-0.4, 0.4), (-0.5, 0.5), (-0.5, 0.5)),
    "left_ankle": ((-0.8, 0.9), (-0.6, 0.6), (-0.5, 0.5)),
    "right_ankle": ((-0.8, 0.9), (-0.6, 0.6), (-0.5, 0.5)),
    "left_foot": ((-0.5, 0.5), (-0.3, 0.3), (-0.3, 0.3)),
    "right_foot": ((-0.5, 0.5), (-0.3, 0.3), (-0.3, 0.3)),
    "left_wrist": ((-1.2, 1.2), (-1.0, 1.0), (-1.5, 1.5)),
    "right_wrist": ((-1.2, 1.2), (-1.0, 1.0), (-1.5, 1.5)),
}

#: Joints whose skin decides the yaw candidate (limbs excluded: their pose is unknown yet).
CORE_JOINTS = ("pelvis", "spine1", "spine2", "spine3", "neck", "head", "left_collar",
               "right_collar")

#: Joints held at their current rotation during the first third of the pose stage, so the
#: trunk and the proximal limb joints settle before hands, feet and head follow.
DISTAL_JOINTS = ("left_ankle", "right_ankle", "left_foot", "right_foot", "left_wrist",
                 "right_wrist", "head")


#: Per-joint multipliers of the pose prior: toes and ankles move little in scans, and their
#: rotation is poorly seen by the data, so they are held closer to the rest pose.
PRIOR_SCALE: dict[str, float] = {
    "left_foot": 50.0, "right_foot": 50.0, "left_ankle": 10.0, "right_ankle": 10.0,
    "left_collar": 10.0, "right_collar": 10.0,
}


def geman_mcclure(r2, sigma: float):
    """Geman-McClure of squared residuals ``r2`` (torch), scaled to behave like r^2 near 0."""
    s2 = sigma * sigma
    return s2 * r2 / (r2 + s2)


def one_sided_cost(res, diff, weight, sigma_out: float, sigma_in: float, inside_weight: float,
                   point_weight: float, cloth_max: float | None = None, far_free: bool = False):
    """Weighted mean robust cost of signed residuals.

    Parameters
    ----------
    res : (k,) signed normal residuals (m), > 0 where the body is outside the scan.
    diff : (k, 3) body-minus-scan vectors (m) for the point-to-point term.
    weight : (k,) per-point weights (>= 0) or None.
    cloth_max : inside gaps beyond this (m) are not clothing: the excess costs like an
        outside residual (a T-pose scan's arms far from a body fitted with its arms down
        would otherwise cost almost nothing). None: no limit.
    far_free : with ``cloth_max``, inside gaps beyond it pull no more than a gap of
        ``cloth_max`` does: no excess cost, and the point-to-point term is capped at
        ``cloth_max`` (loose cloth a dress's width off the legs stops bending them into it).
    """
    # heavy: torch (~1.1 s to import)
    import torch

    inside = inside_weight * geman_mcclure(res * res, sigma_in)
    dist2 = (diff * diff).sum(-1)
    if cloth_max is not None and far_free:
        dist2 = torch.where(res > 0, dist2, dist2.clamp(max=cloth_max * cloth_max))
    elif cloth_max is not None:
        excess = torch.relu(-res - cloth_max)
        inside = inside + geman_mcclure(excess * excess, sigma_out)
    cost = torch.where(res > 0, geman_mcclure(res * res, sigma_out), inside)
    cost = cost + point_weight * geman_mcclure(dist2, sigma_out)
    if weight is None:
        return cost.mean()
    return (weight * cost).sum() / weight.sum().clamp_min(1e-9)


def pose_prior(pose, prior_scale, lim_ids, lim_lo, lim_hi, prior_weight: float,
               limit_weight: float):
    """Squared joint rotations (root excluded, per-joint ``prior_scale`` (j-1, 1)) plus
    squared violations of the soft joint limits (``lim_*``: limited joints and bounds)."""
    # heavy: torch (~1.1 s to import)
    import torch

    prior = prior_weight * (prior_scale * pose[1:] ** 2).sum()
    if len(lim_ids):
        p = pose[lim_ids]
        viol = torch.relu(lim_lo - p) + torch.relu(p - lim_hi)
        prior = prior + limit_weight * 1e2 * (viol ** 2).sum()
    return prior


def joint_skin_mask(model, joints, threshold: float = 0.5) -> np.ndarray:
    """(n,) bool: vertices whose skinning weights on ``joints`` sum above ``threshold``."""
    ids = [list(model.joint_names).index(n) for n in joints if n in model.joint_names]
    if not ids:
        return np.zeros(model.n_vertices, dtype=bool)
    return np.asarray(model.skinning_weights)[:, ids].sum(1) > threshold


def body_neighbourhoods(rest_points: np.ndarray, radius: float, most: int = 16) -> np.ndarray:
    """(b, most) int64: for each body point, the indices of the body points within ``radius``
    (m) of it on the rest body (itself included), padded with ``b`` (see
    :func:`unseen_free_weights`).

    Parameters
    ----------
    rest_points : (b, 3) the fit's body points on the rest body (m).
    radius : neighbourhood radius (m); most : at most this many neighbours (the nearest).
    """
    _, idx = cKDTree(rest_points).query(rest_points, k=min(most, len(rest_points)),
                                        distance_upper_bound=radius, workers=1)
    return np.asarray(idx, dtype=np.int64).reshape(len(rest_points), -1)


def unseen_free_weights(normals, nn_b2s, nn_s2b, neighbourhoods=None):
    """(b,) float weights of the body -> scan pairs: 0 where the body point's nearest scan
    point belongs to a surface of the body facing the other way (its own nearest body
    point's normal opposes this point's), i.e. where the scan did not see this part of the
    body (a side the capture missed, a hole), else 1.

    With ``neighbourhoods`` (:func:`body_neighbourhoods`), also 0 where no scan point has its
    nearest body point in the body point's neighbourhood: no scan surface lies over it. This
    frees the body points of a missing side near the scan's cut edge, whose normals agree with
    the edge's and which the facing test keeps pulling towards it.

    Parameters
    ----------
    normals : (b, 3) body normals (torch); nn_b2s : (b,) scan index of each body point;
    nn_s2b : (p,) body index of each scan point; neighbourhoods : None or (b, m) int64
        torch indices into the body points, padded with b.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    seen = (normals * normals[nn_s2b[nn_b2s]]).sum(-1) > 0
    if neighbourhoods is not None:
        hit = torch.zeros(len(normals) + 1, dtype=torch.bool, device=normals.device)
        hit[nn_s2b] = True  # hit[b], the padding, stays False
        seen = seen & hit[neighbourhoods].any(1)
    return seen.to(normals.dtype)
