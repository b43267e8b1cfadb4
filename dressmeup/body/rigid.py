"""Rigid motions of a whole body expressed in its parameters.

A body's vertices are ``scale * model(shape, pose) + transl`` (docs/body-models.md), and the
root joint's rotation ``pose[0]`` turns the body about the shaped rest root joint ``J0``.
Rotating the posed body by ``R`` about the origin therefore only changes ``pose[0]`` and
``transl``:

    R (s (R0 X + J0) + t) = s ((R R0) X + J0) + s (R J0 - J0) + R t

so ``pose[0] <- R R0`` and ``transl <- R t + s (R - I) J0``. Shape, the other joints and the
scale stay (pose correctives depend on the non-root joints only).
"""

from __future__ import annotations

import numpy as np

from dressmeup.body.params import BodyParams


def rotate_params(params: BodyParams, model, R: np.ndarray) -> BodyParams:
    """Parameters of the same body rotated by ``R`` about the origin.

    Parameters
    ----------
    params : the body; model : its body model (for the rest root joint of ``params.shape``).
    R : (3, 3) rotation matrix (proper: determinant +1).

    Returns
    -------
    New :class:`BodyParams` whose posed vertices are ``vertices @ R.T`` of ``params``'.
    """
    # heavy: scipy.spatial
    from scipy.spatial.transform import Rotation

    R = np.asarray(R, dtype=np.float64)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9) \
            or np.linalg.det(R) < 0:
        raise ValueError(f"R: expected a (3, 3) rotation matrix, got {R}")
    j0 = model.posed(BodyParams(params.model, shape=params.shape,
                                pose=np.zeros_like(params.pose),
                                gender=params.gender)).rest_joints[0]
    out = params.copy()
    out.pose[0] = (Rotation.from_matrix(R) * Rotation.from_rotvec(params.pose[0])).as_rotvec()
    out.transl = R @ params.transl + params.scale * (R @ j0 - j0)
    return out
