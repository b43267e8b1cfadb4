"""``rigid``: move the garment with the bodies' root joints (the lower bound of the leaderboard)."""

from __future__ import annotations

import numpy as np

from dressmeup.methods.retarget.base import RetargetMethod, body_context, check_garment

__all__ = ["RigidRetarget", "root_alignment"]


def root_alignment(source, target) -> np.ndarray:
    """Similarity transform taking the source root frame onto the target root frame.

    ``x -> p_t + (s_t / s_s) R_t R_s^T (x - p_s)`` with ``p`` the root joint position (world),
    ``R`` the root rotation and ``s`` the body scale.

    Parameters
    ----------
    source, target : BodyContext

    Returns
    -------
    (4, 4) float64 matrix acting on homogeneous world points.
    """
    Rs = source.transforms[0, :3, :3]
    Rt = target.transforms[0, :3, :3]
    M = np.eye(4)
    M[:3, :3] = (target.scale / source.scale) * Rt @ Rs.T
    M[:3, 3] = target.joints[0] - M[:3, :3] @ source.joints[0]
    return M


class RigidRetarget(RetargetMethod):
    """Align the garment by the root joints (position, orientation, scale) and nothing else.

    Parameters
    ----------
    rotate : bool
        Apply the root rotation change too (``False``: translation and scale only).
    """

    name = "rigid"

    def __init__(self, rotate: bool = True) -> None:
        self.rotate = rotate

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """See :mod:`dressmeup.methods.retarget.base`; returns (n, 3) float64."""
        V, _ = check_garment(garment_V, garment_F)
        s, t = body_context(body_model, source), body_context(body_model, target)
        M = root_alignment(s, t)
        if not self.rotate:
            M[:3, :3] = (t.scale / s.scale) * np.eye(3)
            M[:3, 3] = t.joints[0] - M[:3, :3] @ s.joints[0]
        return V @ M[:3, :3].T + M[:3, 3]
