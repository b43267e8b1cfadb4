"""A tiny procedural body for fast tests: same protocol and skeleton as the default model.

The skin is the zero level set of a smooth union of tapered capsules along the 22-joint
SMPL-like skeleton (T-pose, y up, facing +z, the body's left on +x), meshed once with
marching cubes (libigl) into one closed surface of a few thousand vertices. Skinning
weights are a soft assignment to the bones (Gaussian in the distance to each bone segment).
The 6-dim shape vector mimics the phenotype (gender, age, muscle, weight, height,
proportions; 0.5 average): each entry adds a fixed displacement field evaluated at the
rest vertices and joints, so shape is linear and differentiable.
"""

from __future__ import annotations

import functools

import numpy as np

from dressmeup.body.base import LBSBodyModel
from dressmeup.body.skeleton import PHENOTYPE_NAMES, SMPL22_JOINT_NAMES, SMPL22_PARENTS

# Rest joints of the average body (metres).
_J = {
    "pelvis": (0.0, 0.95, 0.0), "left_hip": (0.085, 0.88, 0.0), "right_hip": (-0.085, 0.88, 0.0),
    "spine1": (0.0, 1.06, -0.01), "left_knee": (0.095, 0.50, 0.01), "right_knee": (-0.095, 0.50, 0.01),
    "spine2": (0.0, 1.18, -0.01), "left_ankle": (0.10, 0.09, -0.02), "right_ankle": (-0.10, 0.09, -0.02),
    "spine3": (0.0, 1.30, -0.01), "left_foot": (0.11, 0.03, 0.10), "right_foot": (-0.11, 0.03, 0.10),
    "neck": (0.0, 1.49, -0.01), "left_collar": (0.06, 1.42, -0.01), "right_collar": (-0.06, 1.42, -0.01),
    "head": (0.0, 1.58, 0.0), "left_shoulder": (0.17, 1.42, -0.01),
    "right_shoulder": (-0.17, 1.42, -0.01), "left_elbow": (0.44, 1.42, -0.02),
    "right_elbow": (-0.44, 1.42, -0.02), "left_wrist": (0.68, 1.42, -0.01),
    "right_wrist": (-0.68, 1.42, -0.01),
}
# Extra end points (not joints) for the leaf bones.
_ENDS = {"head": (0.0, 1.72, 0.01), "left_foot": (0.11, 0.03, 0.17),
         "right_foot": (-0.11, 0.03, 0.17), "left_wrist": (0.84, 1.42, -0.01),
         "right_wrist": (-0.84, 1.42, -0.01)}

# Capsules: (start, end, radius at start, radius at end, depth squash, driving joint).
# Points are joint names or end-point keys prefixed by "end:".
_CAPSULES = [
    ("left_hip", "right_hip", 0.105, 0.105, 1.35, "pelvis"),
    ("pelvis", "spine1", 0.125, 0.12, 1.45, "pelvis"),
    ("spine1", "spine2", 0.12, 0.125, 1.5, "spine1"),
    ("spine2", "spine3", 0.125, 0.14, 1.55, "spine2"),
    ("spine3", "neck", 0.12, 0.05, 1.4, "spine3"),
    ("spine3", "left_collar", 0.09, 0.07, 1.4, "spine3"),
    ("spine3", "right_collar", 0.09, 0.07, 1.4, "spine3"),
    ("left_collar", "left_shoulder", 0.07, 0.06, 1.2, "left_collar"),
    ("right_collar", "right_shoulder", 0.07, 0.06, 1.2, "right_collar"),
    ("neck", "head", 0.05, 0.055, 1.0, "neck"),
    ("head", "end:head", 0.09, 0.085, 1.1, "head"),
    ("left_hip", "left_knee", 0.08, 0.055, 1.0, "left_hip"),
    ("right_hip", "right_knee", 0.08, 0.055, 1.0, "right_hip"),
    ("left_knee", "left_ankle", 0.055, 0.038, 1.0, "left_knee"),
    ("right_knee", "right_ankle", 0.055, 0.038, 1.0, "right_knee"),
    ("left_ankle", "left_foot", 0.038, 0.036, 1.0, "left_ankle"),
    ("right_ankle", "right_foot", 0.038, 0.036, 1.0, "right_ankle"),
    ("left_foot", "end:left_foot", 0.036, 0.03, 1.0, "left_foot"),
    ("right_foot", "end:right_foot", 0.036, 0.03, 1.0, "right_foot"),
    ("left_shoulder", "left_elbow", 0.055, 0.042, 1.0, "left_shoulder"),
    ("right_shoulder", "right_elbow", 0.055, 0.042, 1.0, "right_shoulder"),
    ("left_elbow", "left_wrist", 0.042, 0.032, 1.0, "left_elbow"),
    ("right_elbow", "right_wrist", 0.042, 0.032, 1.0, "right_elbow"),
    ("left_wrist", "end:left_wrist", 0.034, 0.03, 1.0, "left_wrist"),
    ("right_wrist", "end:right_wrist", 0.034, 0.03, 1.0, "right_wrist"),
]
_TORSO = {"pelvis", "spine1", "spine2", "spine3", "left_collar", "right_collar"}
_LIMB = {"left_hip", "right_hip", "left_knee", "right_knee", "left_shoulder", "right_shoulder",
         "left_elbow", "right_elbow"}


def _point(key: str) -> np.ndarray:
    return np.array(_ENDS[key[4:]] if key.startswith("end:") else _J[key], dtype=np.float64)


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, squash: float = 1.0):
    """Distance from points p (q,3) to segment ab, depth (z) scaled; returns (dist, t, foot)."""
    s = np.array([1.0, 1.0, squash])
    ps, as_, bs = p * s, a * s, b * s
    ab = bs - as_
    t = np.clip(((ps - as_) @ ab) / max(ab @ ab, 1e-12), 0.0, 1.0)
    foot = as_ + t[:, None] * ab
    return np.linalg.norm(ps - foot, axis=1), t, foot / s


def _sdf(points: np.ndarray, k: float = 0.025) -> np.ndarray:
    """Smooth-union signed distance of the capsules at points (q, 3)."""
    d = None
    for a, b, ra, rb, squash, _ in _CAPSULES:
        dist, t, _ = _segment_distance(points, _point(a), _point(b), squash)
        di = dist - (ra + t * (rb - ra))
        if d is None:
            d = di
        else:  # polynomial smooth minimum
            h = np.clip(0.5 + 0.5 * (di - d) / k, 0.0, 1.0)
            d = di * (1 - h) + d * h - k * h * (1 - h)
    return d


def _bone_fields(points: np.ndarray):
    """Distances (q, c) to every capsule axis and the radial unit vectors (q, c, 3)."""
    dists, radial = [], []
    for a, b, _, _, _, _ in _CAPSULES:
        dist, _, foot = _segment_distance(points, _point(a), _point(b))
        r = points - foot
        n = np.linalg.norm(r, axis=1, keepdims=True)
        dists.append(dist)
        radial.append(np.where(n > 1e-9, r / np.maximum(n, 1e-9), 0.0))
    return np.stack(dists, 1), np.stack(radial, 1)


def _shape_fields(points: np.ndarray, is_joint: bool) -> np.ndarray:
    """Displacement fields (6, q, 3) of the phenotype entries at rest points (q, 3)."""
    q = points.shape[0]
    fields = np.zeros((6, q, 3))
    x, y = points[:, 0], points[:, 1]
    # 0 gender (as anny: 0 male -> 1 female): narrower shoulders, wider hips, shorter.
    shoulder = np.clip((y - 1.2) / 0.2, 0, 1)
    hips = np.exp(-(((y - 0.92) / 0.12) ** 2))
    fields[0, :, 0] = -x * (0.16 * shoulder - 0.14 * hips * (np.abs(x) < 0.3))
    fields[0, :, 1] = -0.06 * y
    # 1 age (0 young -> 1 old): overall size grows with age (anny spans baby to old adult).
    fields[1] = 0.25 * points
    fields[1, :, 1] -= 0.05 * np.clip(y - 1.5, 0, None)  # relatively smaller head
    # 4 height: uniform scale about the ground point under the pelvis.
    fields[4] = 0.3 * points
    # 5 proportions: longer legs relative to the torso.
    fields[5, :, 1] = 0.16 * np.minimum(y, 0.9) - 0.06 * np.clip(y - 0.9, 0, None)
    if not is_joint:
        d, radial = _bone_fields(points)
        nearest = np.argmin(d, axis=1)
        r = radial[np.arange(q), nearest]
        drivers = [c[5] for c in _CAPSULES]
        torso = np.array([drivers[c] in _TORSO for c in nearest], dtype=np.float64)
        limb = np.array([drivers[c] in _LIMB for c in nearest], dtype=np.float64)
        fields[2] = 0.03 * (limb + 0.5 * torso)[:, None] * r  # 2 muscle
        fields[3] = (0.09 * torso + 0.03 * limb + 0.01)[:, None] * r  # 3 weight (girth)
        fields[1] += 0.02 * torso[:, None] * r
    return fields


def _skinning_weights(V: np.ndarray, sigma: float = 0.035) -> np.ndarray:
    d, _ = _bone_fields(V)
    drivers = [SMPL22_JOINT_NAMES.index(c[5]) for c in _CAPSULES]
    # Soft assignment: Gaussian falloff relative to the nearest bone.
    dmin = d.min(axis=1, keepdims=True)
    g = np.exp(-((d - dmin) / sigma) ** 2)
    W = np.zeros((V.shape[0], len(SMPL22_JOINT_NAMES)))
    for c, j in enumerate(drivers):
        W[:, j] += g[:, c]
    W[W < 1e-4] = 0.0
    return W / W.sum(axis=1, keepdims=True)


@functools.lru_cache(maxsize=4)
def _build(voxel: float) -> tuple[np.ndarray, ...]:
    # heavy: igl, scipy.sparse
    import igl
    import scipy.sparse as sp

    lo = np.array([-0.92, -0.04, -0.2])
    hi = np.array([0.92, 1.86, 0.28])
    n = np.ceil((hi - lo) / voxel).astype(int) + 1
    xs, ys, zs = (np.linspace(lo[i], lo[i] + (n[i] - 1) * voxel, n[i]) for i in range(3))
    Z, Y, X = np.meshgrid(zs, ys, xs, indexing="ij")  # x fastest, as libigl expects
    GV = np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1)
    S = _sdf(GV)
    V, F, _ = igl.marching_cubes(S, GV, int(n[0]), int(n[1]), int(n[2]), 0.0)
    # Drop duplicate vertices (marching cubes shares them by edge key already) and keep the
    # heavy: scipy.sparse
    from dressmeup.geometry.topology import largest_component

    keep, F = largest_component(np.asarray(F, dtype=np.int64), V.shape[0])
    V = np.asarray(V)[keep]
    # A few Taubin smoothing steps (uniform Laplacian) to remove marching-cubes stairs.
    L = igl.adjacency_matrix(F).astype(np.float64)
    L = sp.diags(1.0 / np.asarray(L.sum(1)).ravel()) @ L
    for _ in range(6):
        V = V + 0.5 * (L @ V - V)
        V = V - 0.53 * (L @ V - V)
    # Outward orientation: positive signed volume.
    vol = np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6
    if vol < 0:
        F = F[:, ::-1].copy()
    J = np.array([_J[nm] for nm in SMPL22_JOINT_NAMES])
    W = _skinning_weights(V)
    DV = _shape_fields(V, is_joint=False)
    DJ = _shape_fields(J, is_joint=True)
    return V, F, J, W, DV, DJ


class ProceduralBody(LBSBodyModel):
    """Tiny procedural body (see module docstring).

    Parameters
    ----------
    resolution : marching-cubes voxel size in metres (default 0.02: about 5k vertices).
    """

    name = "procedural"

    def __init__(self, resolution: float = 0.02) -> None:
        if not (0.005 <= float(resolution) <= 0.05):
            raise ValueError(f"resolution: expected 0.005..0.05 m, got {resolution}")
        V, F, J, W, DV, DJ = _build(float(resolution))
        self.template_vertices = V
        self.faces = F
        self.template_joints = J
        self.skinning_weights = W
        self.shape_dirs = DV  # (6, n, 3)
        self.joint_shape_dirs = DJ  # (6, j, 3)
        self.joint_names = SMPL22_JOINT_NAMES
        self.joint_parents = SMPL22_PARENTS.copy()
        self.shape_names = PHENOTYPE_NAMES
        self.shape_dim = 6
        self.default_shape = np.full(6, 0.5)

    def rest(self, shape):
        """Shaped rest vertices (b, n, 3) and joints (b, j, 3): template + (shape - 0.5) @ dirs."""
        # heavy: torch (~1.1 s to import)
        import torch

        dt, dev = shape.dtype, shape.device
        c = shape - 0.5
        V = self._buffer("template_vertices", dt, dev)[None] + torch.einsum(
            "bs,snk->bnk", c, self._buffer("shape_dirs", dt, dev))
        J = self._buffer("template_joints", dt, dev)[None] + torch.einsum(
            "bs,sjk->bjk", c, self._buffer("joint_shape_dirs", dt, dev))
        return V, J
