"""Batched, differentiable linear blend skinning in torch.

Conventions: rotations are axis-angle vectors (Rodrigues); a joint's local transform rotates
about the joint's rest position; ``transforms`` are the LBS matrices ``A_j = G_j @ [I, -J_j]``
that map a rest-pose point rigidly attached to joint ``j`` to its posed position.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    import torch


def axis_angle_to_matrix(axis_angle: torch.Tensor) -> torch.Tensor:
    """Convert axis-angle vectors to rotation matrices (Rodrigues' formula).

    Parameters
    ----------
    axis_angle : (..., 3) float tensor, rotation axis times angle in radians.

    Returns
    -------
    (..., 3, 3) tensor of rotation matrices, differentiable (also at the zero rotation).
    """
    # heavy: torch (~1.1 s to import)
    import torch

    angle = torch.sqrt((axis_angle * axis_angle).sum(-1, keepdim=True) + 1e-16)
    axis = axis_angle / angle
    x, y, z = axis.unbind(-1)
    zero = torch.zeros_like(x)
    K = torch.stack([zero, -z, y, z, zero, -x, -y, x, zero], dim=-1).reshape(
        axis_angle.shape[:-1] + (3, 3)
    )
    s = torch.sin(angle)[..., None]
    c = torch.cos(angle)[..., None]
    eye = torch.eye(3, dtype=axis_angle.dtype, device=axis_angle.device)
    return eye + s * K + (1.0 - c) * (K @ K)


def matrix_to_axis_angle(R: torch.Tensor) -> torch.Tensor:
    """Convert rotation matrices to axis-angle vectors (inverse of :func:`axis_angle_to_matrix`).

    Parameters
    ----------
    R : (..., 3, 3) rotation matrices.

    Returns
    -------
    (..., 3) axis-angle vectors with angle in [0, pi].
    """
    # heavy: torch (~1.1 s to import)
    import torch

    # Through the quaternion for numerical stability near 0 and pi.
    m = R
    tr = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    qw = torch.sqrt(torch.clamp(1.0 + tr, min=1e-12)) / 2
    qx = torch.sqrt(torch.clamp(1.0 + m[..., 0, 0] - m[..., 1, 1] - m[..., 2, 2], min=0)) / 2
    qy = torch.sqrt(torch.clamp(1.0 - m[..., 0, 0] + m[..., 1, 1] - m[..., 2, 2], min=0)) / 2
    qz = torch.sqrt(torch.clamp(1.0 - m[..., 0, 0] - m[..., 1, 1] + m[..., 2, 2], min=0)) / 2
    qx = torch.copysign(qx, m[..., 2, 1] - m[..., 1, 2])
    qy = torch.copysign(qy, m[..., 0, 2] - m[..., 2, 0])
    qz = torch.copysign(qz, m[..., 1, 0] - m[..., 0, 1])
    v = torch.stack([qx, qy, qz], -1)
    sin_half = torch.linalg.norm(v, dim=-1, keepdim=True)
    angle = 2 * torch.atan2(sin_half, qw[..., None])
    return v / torch.clamp(sin_half, min=1e-12) * angle


def forward_kinematics(
    rotations: torch.Tensor, rest_joints: torch.Tensor, parents
) -> tuple[torch.Tensor, torch.Tensor]:
    """Chain local joint rotations along the kinematic tree.

    Parameters
    ----------
    rotations : (b, j, 3, 3) local rotation of every joint relative to its parent.
    rest_joints : (b, j, 3) joint positions in the rest pose.
    parents : (j,) int sequence, parent index of each joint (-1 for the root); parents come
        before their children.

    Returns
    -------
    posed_joints : (b, j, 3) joint positions after posing.
    transforms : (b, j, 4, 4) LBS matrices mapping rest-pose points to posed points.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    b, j = rotations.shape[:2]
    parents = [int(p) for p in parents]
    idx = torch.tensor([max(p, 0) for p in parents], device=rest_joints.device)
    has_parent = torch.tensor([0.0 if p < 0 else 1.0 for p in parents],
                              dtype=rest_joints.dtype, device=rest_joints.device)
    rel = rest_joints - rest_joints[:, idx] * has_parent[None, :, None]
    bottom = torch.zeros(b, j, 1, 4, dtype=rotations.dtype, device=rotations.device)
    bottom[..., 0, 3] = 1.0
    local = torch.cat([torch.cat([rotations, rel[..., None]], dim=-1), bottom], dim=-2)
    chain: list[torch.Tensor] = []
    for k in range(j):
        p = parents[k]
        chain.append(local[:, k] if p < 0 else chain[p] @ local[:, k])
    G = torch.stack(chain, dim=1)  # (b, j, 4, 4) global joint frames
    posed_joints = G[..., :3, 3]
    # A = G @ [I, -J_rest]: translation t - R J_rest.
    t = posed_joints - (G[..., :3, :3] @ rest_joints[..., None])[..., 0]
    A = torch.cat([torch.cat([G[..., :3, :3], t[..., None]], dim=-1), G[..., 3:, :]], dim=-2)
    return posed_joints, A


def skin_points(points: torch.Tensor, weights: torch.Tensor, transforms: torch.Tensor) -> torch.Tensor:
    """Apply linear blend skinning.

    Parameters
    ----------
    points : (b, n, 3) rest-pose points.
    weights : (n, j) or (b, n, j) skinning weights (rows sum to 1).
    transforms : (b, j, 4, 4) LBS matrices.

    Returns
    -------
    (b, n, 3) posed points.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    flat = transforms[..., :3, :].reshape(transforms.shape[0], transforms.shape[1], 12)
    if weights.dim() == 2:
        T = torch.einsum("nj,bjk->bnk", weights, flat)
    else:
        T = torch.einsum("bnj,bjk->bnk", weights, flat)
    T = T.reshape(points.shape[0], points.shape[1], 3, 4)
    return (T[..., :3] @ points[..., None])[..., 0] + T[..., 3]
