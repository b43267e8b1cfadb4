"""Inputs of a fit: scans as point sets, keypoints as (joint ids, targets)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.errors import InputError


def prepare_scan(scan, n_points: int = 8000, seed: int = 0) -> np.ndarray:
    """Turn a scan into points (p, 3) float64.

    Parameters
    ----------
    scan : ``(V, F)`` tuple, an object with ``vertices``/``faces`` (trimesh), or (p, 3)
        points. Meshes are sampled uniformly by area (``n_points`` samples, seeded).
    n_points : samples drawn from a mesh, or the cap on a point set (random subset).
    seed : sampling seed.
    """
    if hasattr(scan, "vertices") and hasattr(scan, "faces"):
        scan = (np.asarray(scan.vertices), np.asarray(scan.faces))
    if isinstance(scan, (tuple, list)) and len(scan) == 2:
        V = np.asarray(scan[0], dtype=np.float64)
        F = np.asarray(scan[1], dtype=np.int64)
        if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] == 0:
            raise InputError(f"scan vertices: expected shape (n, 3), got {V.shape}")
        if F.ndim != 2 or F.shape[1] != 3 or F.size == 0 or F.min() < 0 or F.max() >= len(V):
            raise InputError(f"scan faces: expected (m, 3) indices into the vertices, got {F.shape}")
        tri = V[F]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        if area.sum() <= 0:
            raise InputError("scan: all faces are degenerate")
        rng = np.random.default_rng(seed)
        fid = rng.choice(len(F), size=n_points, p=area / area.sum())
        u, v = rng.uniform(size=(2, n_points))
        flip = u + v > 1
        u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
        t = tri[fid]
        return _check_metres(
            t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0]))
    P = np.asarray(scan, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] < 10:
        raise InputError(f"scan: expected a mesh (V, F) or points (p, 3) with p >= 10, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise InputError("scan: contains NaN or infinite coordinates")
    if P.shape[0] > n_points:
        P = P[np.random.default_rng(seed).choice(P.shape[0], n_points, replace=False)]
    return _check_metres(P)


def normal_lines(P: np.ndarray, k: int = 16) -> np.ndarray:
    """(p, 3) float64 unit normal *lines* of a point set (sign arbitrary): per point, the
    direction of least variance of its ``k`` nearest neighbours (local plane fit). Works
    for meshes sampled by :func:`prepare_scan` and raw point clouds alike, whatever the
    winding or orientation of the source."""
    P = np.asarray(P, dtype=np.float64)
    k = int(min(max(k, 3), len(P)))
    _, nn = cKDTree(P).query(P, k=k, workers=1)
    X = P[nn] - P[nn].mean(1, keepdims=True)
    _, vecs = np.linalg.eigh(np.einsum("pki,pkj->pij", X, X))
    return vecs[:, :, 0]


#: Plausible extent of a scanned person in metres (the largest side of the bounding box).
SCAN_EXTENT_M = (0.3, 3.0)


def _check_metres(P: np.ndarray) -> np.ndarray:
    """Refuse a scan whose size is implausible in metres (millimetres, centimetres, ...)."""
    if not np.all(np.isfinite(P)):
        raise InputError("scan: contains NaN or infinite coordinates")
    extent = float(np.ptp(P, axis=0).max())
    lo, hi = SCAN_EXTENT_M
    if not lo <= extent <= hi:
        hint = (f" (in millimetres? scale by {1 / 1000:g}; centimetres? by {1 / 100:g})"
                if extent > hi else " (a partial scan, or not in metres?)")
        raise InputError(f"scan: spans {extent:.4g} units, but registration expects a person "
                         f"in metres ({lo}-{hi} m){hint}")
    return P


def keypoint_arrays(keypoints, model) -> tuple[np.ndarray, np.ndarray] | None:
    """Normalise keypoints to ``(joint ids (k,) int64, targets (k, 3) float64)``.

    Parameters
    ----------
    keypoints : None, a ``(j, 3)`` array in the model's joint order with NaN rows for
        missing joints, or ``{joint_name: xyz}``.
    model : the body model (its ``joint_names``).
    """
    if keypoints is None:
        return None
    names = list(model.joint_names)
    if isinstance(keypoints, dict):
        ids, pts = [], []
        for name, xyz in keypoints.items():
            if name not in names:
                raise InputError(f"keypoints: unknown joint {name!r}; expected one of {names}")
            ids.append(names.index(name))
            pts.append(np.asarray(xyz, dtype=np.float64).reshape(3))
        return np.array(ids, dtype=np.int64), np.array(pts).reshape(-1, 3)
    K = np.asarray(keypoints, dtype=np.float64)
    if K.shape != (len(names), 3):
        raise InputError(f"keypoints: expected shape ({len(names)}, 3) (NaN rows for missing) or a "
                         f"dict of joint name -> xyz, got {K.shape}")
    ok = np.all(np.isfinite(K), axis=1)
    return np.flatnonzero(ok), K[ok]


#: The scan's up axis -> a proper rotation taking it to +y (the frame fits work in:
#: y up; which way the body faces is found by the fit).
UP_ROTATIONS: dict[str, np.ndarray] = {
    "y": np.eye(3),
    "-y": np.diag([1.0, -1.0, -1.0]),  # 180 degrees about x
    "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),  # -90 about x
    "-z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),  # +90 about x
    "x": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),  # +90 about z
    "-x": np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),  # -90 about z
}

#: A scan whose extent along y is below this share of its largest extent does not look
#: upright with y up. Measured: the 24 scans of the edition
#: synth-registration-v3 and the 136 of the perf suites span at least 0.88 of their largest
#: extent along y (picking up; 0.79 with a floor kept). Along y a z-up scan shows a
#: horizontal extent: the edition's z-up copies (bodies facing z) 0.29-0.60, so all are
#: refused; the perf suites' (turned by random yaws, no supports) 0.27-1.0, 99 of 108
#: refused: a z-up T-pose or stance whose arms or legs lie along y passes the check.
UPRIGHT_MIN_RATIO = 0.7


def up_rotation(up: str) -> np.ndarray:
    """(3, 3) rotation taking the scan's up axis ``up`` (``x``, ``-x``, ``y``, ``-y``,
    ``z``, ``-z``) to +y."""
    if up not in UP_ROTATIONS:
        raise InputError(f"up: expected one of {', '.join(UP_ROTATIONS)}, got {up!r}")
    return UP_ROTATIONS[up].copy()


def rotate_scan(scan, R: np.ndarray):
    """The scan (``(V, F)``, a trimesh or points ``(p, 3)``) rotated by ``R`` (3, 3):
    ``(V @ R.T, F)`` or ``points @ R.T``."""
    if hasattr(scan, "vertices") and hasattr(scan, "faces"):
        scan = (np.asarray(scan.vertices), np.asarray(scan.faces))
    if isinstance(scan, (tuple, list)) and len(scan) == 2:
        return np.asarray(scan[0], dtype=np.float64) @ R.T, np.asarray(scan[1])
    return np.asarray(scan, dtype=np.float64) @ R.T


def rotate_keypoints(keypoints, R: np.ndarray):
    """Keypoints (``(j, 3)`` with NaN rows, or ``{joint_name: (3,)}``) rotated by ``R``."""
    if keypoints is None:
        return None
    if isinstance(keypoints, dict):
        return {k: np.asarray(v, dtype=np.float64) @ R.T for k, v in keypoints.items()}
    return np.asarray(keypoints, dtype=np.float64) @ R.T


def check_upright(P: np.ndarray, what: str = "scan") -> None:
    """Refuse points (p, 3) that do not look like an upright person with y up (the
    scan's y extent below :data:`UPRIGHT_MIN_RATIO` of its largest), naming the option
    that fixes it. A guard, not a detector: it catches a person standing, walking or
    sitting scanned z-up, not one whose arms or legs spread along y."""
    ext = np.ptp(np.asarray(P, dtype=np.float64), axis=0)
    if ext[1] >= UPRIGHT_MIN_RATIO * ext.max():
        return
    longest = "xz"[int(np.argmax(ext[[0, 2]]))]
    raise InputError(
        f"{what}: spans {ext[1]:.2f} m along y but {ext.max():.2f} m along {longest}: it does "
        f"not look upright with y up, which registration expects. If the scan's up axis is "
        f"{longest}, pass --up {longest} (in Python up='{longest}'; --up=-{longest} if it "
        f"points down); if the person really lies down, --up y fits anyway (the starting "
        f"poses are upright: expect a poor fit)")
