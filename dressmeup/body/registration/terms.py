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
``far_cloth="free"`` rule, from the shape stage on) they stop pulling beyond ``cloth_max``
(a skirt's far cloth bent the legs into it). Each body point carries a weight (hands count
less: their many vertices would otherwise pull the arm).
"""

from __future__ import annotations

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
    import torch  # heavy: loaded when a fit runs

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
    import torch  # heavy: loaded when a fit runs

    prior = prior_weight * (prior_scale * pose[1:] ** 2).sum()
    if len(lim_ids):
        p = pose[lim_ids]
        viol = torch.relu(lim_lo - p) + torch.relu(p - lim_hi)
        prior = prior + limit_weight * 1e2 * (viol ** 2).sum()
    return prior
