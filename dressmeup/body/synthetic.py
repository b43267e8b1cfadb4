"""Synthetic bodies and scans from known parameters (registration tests and benchmarks).

- :func:`named_pose`: a few poses of the 22-joint SMPL-like skeleton (standing, walking,
  sitting, arms raised), axis-angle in the SMPL frame (y up, facing +z, left on +x).
- :func:`synthetic_scan`: sample a posed body's surface, optionally push the torso out by a
  smooth 1-3 cm "garment shell", cut round holes (missing patches), add Gaussian noise.
"""

from __future__ import annotations

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.body.skeleton import SMPL22_JOINT_NAMES

_POSES: dict[str, dict[str, tuple[float, float, float]]] = {
    "standing": {
        "left_shoulder": (0.0, 0.0, -0.55), "right_shoulder": (0.0, 0.0, 0.55),
        "left_elbow": (0.0, -0.15, 0.0), "right_elbow": (0.0, 0.15, 0.0),
    },
    "walking": {
        "left_hip": (-0.45, 0.0, 0.0), "left_knee": (0.25, 0.0, 0.0),
        "right_hip": (0.3, 0.0, 0.0), "right_knee": (0.55, 0.0, 0.0),
        "right_ankle": (-0.15, 0.0, 0.0),
        "left_shoulder": (0.35, 0.0, -0.6), "right_shoulder": (-0.35, 0.0, 0.6),
        "left_elbow": (0.0, -0.3, 0.0), "right_elbow": (0.0, 0.2, 0.0),
        "spine2": (0.0, 0.08, 0.0),
    },
    "sitting": {
        "left_hip": (-1.45, 0.05, -0.05), "right_hip": (-1.45, -0.05, 0.05),
        "left_knee": (1.5, 0.0, 0.0), "right_knee": (1.5, 0.0, 0.0),
        "left_shoulder": (-0.3, 0.0, -0.6), "right_shoulder": (-0.3, 0.0, 0.6),
        "left_elbow": (0.0, -0.9, 0.0), "right_elbow": (0.0, 0.9, 0.0),
        "spine1": (0.15, 0.0, 0.0),
    },
    "arms_raised": {
        "left_shoulder": (0.0, 0.0, 1.3), "right_shoulder": (0.0, 0.0, -1.3),
        "left_elbow": (0.0, -0.5, 0.0), "right_elbow": (0.0, 0.5, 0.0),
        "left_collar": (0.0, 0.0, 0.2), "right_collar": (0.0, 0.0, -0.2),
        "neck": (0.15, 0.0, 0.0),
    },
}

#: Joints whose skin the synthetic garment shell covers (a top and trousers' waistband).
TORSO_JOINTS = ("pelvis", "spine1", "spine2", "spine3", "left_collar", "right_collar")


def pose_names() -> list[str]:
    """Names accepted by :func:`named_pose`."""
    return sorted(_POSES)


def named_pose(name: str, yaw: float = 0.0) -> np.ndarray:
    """Return the (22, 3) axis-angle pose ``name`` turned by ``yaw`` radians about +y."""
    if name not in _POSES:
        raise ValueError(f"name: unknown pose {name!r}; known: {pose_names()}")
    pose = np.zeros((22, 3))
    for joint, aa in _POSES[name].items():
        pose[SMPL22_JOINT_NAMES.index(joint)] = aa
    pose[0] = (0.0, yaw, 0.0)
    return pose


def synthetic_scan(model, params: BodyParams, n_points: int = 30000, noise: float = 0.002,
                   n_holes: int = 0, hole_radius: float = 0.06, shell: tuple | None = None,
                   seed: int = 0, missing_side=None, seat_box: bool = False,
                   floor: float | None = None):
    """Make a scan (points) of a posed body with noise, holes and an optional shell.

    Parameters
    ----------
    model : BodyModel; params : BodyParams of the body.
    n_points : surface samples before holes are cut.
    noise : standard deviation (m) of isotropic Gaussian noise.
    n_holes : number of missing round patches (centres on random samples).
    hole_radius : radius (m) of each missing patch.
    shell : ``(min, max)`` offset in metres of a smooth garment shell over the torso
        (:data:`TORSO_JOINTS`), e.g. ``(0.01, 0.03)``; None for a naked scan.
    seed : random seed.
    missing_side : optional horizontal direction (3,): the surface facing it (normal . dir
        > 0.2) is missing, as when a capture rig misses one side.
    seat_box : add a box under the hips (a seat that is part of the scan), from the floor
        (the body's lowest point) to the underside of the thighs.
    floor : add a floor patch at the body's lowest point (horizontal, y up) covering the
        body's horizontal extent grown by this margin (m) on every side; None: no floor.

    Returns
    -------
    points : (p, 3) float64 scan points.
    """
    # heavy: trimesh (~0.7 s to import)
    import trimesh

    rng = np.random.default_rng(seed)
    out = model.posed(params)
    V = out.vertices.copy()
    if shell is not None:
        lo, hi = shell
        W = model.skinning_weights
        ids = [list(model.joint_names).index(j) for j in TORSO_JOINTS if j in model.joint_names]
        cover = np.clip((W[:, ids].sum(1) - 0.3) / 0.4, 0, 1)  # smooth border
        # Smooth offset field: a few random low-frequency waves over the rest surface.
        R = out.rest_vertices
        phase = rng.uniform(0, 2 * np.pi, 3)
        freq = rng.uniform(4, 9, 3)
        wave = np.mean([np.sin(freq[k] * R[:, k] + phase[k]) for k in range(3)], axis=0)
        offset = lo + (hi - lo) * (0.5 + 0.5 * wave / max(np.abs(wave).max(), 1e-9))
        normals = trimesh.Trimesh(V, model.faces, process=False).vertex_normals
        V = V + (cover * offset)[:, None] * normals
    mesh = trimesh.Trimesh(V, model.faces, process=False)
    pts, fid = trimesh.sample.sample_surface(mesh, n_points, seed=int(rng.integers(2**31)))
    pts = np.asarray(pts, dtype=np.float64)
    if missing_side is not None:
        side = np.asarray(missing_side, dtype=np.float64)
        side = side / np.linalg.norm(side)
        pts = pts[mesh.face_normals[fid] @ side <= 0.2]
    if seat_box:
        pts = np.vstack([pts, _seat_box_points(model, out, n_points / mesh.area, rng)])
    if floor is not None:
        pts = np.vstack([pts, _floor_points(out.vertices, floor, n_points / mesh.area, rng)])
    if n_holes:
        centres = pts[rng.choice(len(pts), n_holes, replace=False)]
        keep = np.ones(len(pts), dtype=bool)
        for c in centres:
            keep &= np.linalg.norm(pts - c, axis=1) > hole_radius
        pts = pts[keep]
    return pts + rng.normal(0, noise, pts.shape)


def _seat_box_points(model, out, density: float, rng) -> np.ndarray:
    """Points (k, 3) on the top and sides of a box under the hips (see ``seat_box``)."""
    names = list(model.joint_names)
    W = np.asarray(model.skinning_weights)
    thigh = W[:, [names.index(j) for j in ("left_hip", "right_hip") if j in names]].sum(1) > 0.5
    V = out.vertices
    top = float(V[thigh, 1].min()) if thigh.any() else float(V[:, 1].mean())
    floor = float(V[:, 1].min())
    c = out.joints[0]
    lo = np.array([c[0] - 0.25, floor, c[2] - 0.25])
    hi = np.array([c[0] + 0.25, top, c[2] + 0.25])
    size = hi - lo
    faces = []  # (axis, value, the other two axes); the bottom face lies on the floor
    faces.append((1, hi[1], (0, 2)))
    for axis in (0, 2):
        faces += [(axis, lo[axis], (1, 2 - axis)), (axis, hi[axis], (1, 2 - axis))]
    pts = []
    for axis, value, (a, b) in faces:
        k = int(density * size[a] * size[b])
        p = np.empty((k, 3))
        p[:, axis] = value
        p[:, a] = lo[a] + rng.uniform(size=k) * size[a]
        p[:, b] = lo[b] + rng.uniform(size=k) * size[b]
        pts.append(p)
    return np.vstack(pts)


def _floor_points(V: np.ndarray, margin: float, density: float, rng) -> np.ndarray:
    """Points (k, 3) on a floor patch at the lowest vertex (see ``floor``)."""
    lo = V[:, [0, 2]].min(0) - margin
    size = np.ptp(V[:, [0, 2]], axis=0) + 2 * margin
    k = int(density * size[0] * size[1])
    p = np.empty((k, 3))
    p[:, [0, 2]] = lo + rng.uniform(size=(k, 2)) * size
    p[:, 1] = V[:, 1].min()
    return p


def vertex_joint_errors(model, fit: BodyParams, truth: BodyParams) -> tuple[float, float]:
    """Mean vertex and joint distances (metres) between two parameter sets of one model."""
    a, b = model.posed(fit), model.posed(truth)
    return (float(np.linalg.norm(a.vertices - b.vertices, axis=1).mean()),
            float(np.linalg.norm(a.joints - b.joints, axis=1).mean()))
