"""3D keypoints from a scan: render virtual views, detect 2D body keypoints, triangulate.

Route (needs the optional ``[keypoints]`` extra, i.e. ``mediapipe==0.10.14`` whose wheel
ships its pose models, so it runs offline):

1. :func:`render_views`: the scan is seen by ``n_views`` virtual pinhole cameras on a
   circle around the vertical axis (y up). Meshes are ray cast with open3d's
   ``RaycastingScene``; point sets are splatted into a z-buffer. Pixels are shaded by the
   surface normal against the view direction (grey body on a dark background).
2. :func:`detect_2d`: mediapipe's legacy ``solutions.pose`` gives 33 landmarks per view
   with a visibility score; those with an SMPL-like counterpart are kept
   (:data:`MEDIAPIPE_TO_SMPL`).
3. :func:`triangulate`: per joint, RANSAC over the views' observations of the joint *and*
   of its mirror twin (detectors swap left and right on back views): two-view DLT
   hypotheses, inliers by reprojection error, a visibility-weighted DLT on the inliers;
   the two clusters of a left/right pair are assigned by the majority of their labels.
   Joints seen consistently in fewer than ``min_views`` views stay NaN.

:func:`detect_keypoints` chains the three and returns :class:`ScanKeypoints` whose
``joints`` ``(j, 3)`` (NaN rows for missing joints) go straight to ``register(...,
keypoints=...)``. :func:`keypoints_available` tells whether the extra is installed.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from dressmeup.body.registration.scan import normal_lines

logger = logging.getLogger(__name__)

#: mediapipe pose landmark index -> SMPL-like joint (the person's own left/right).
MEDIAPIPE_TO_SMPL: dict[int, str] = {
    11: "left_shoulder", 12: "right_shoulder", 13: "left_elbow", 14: "right_elbow",
    15: "left_wrist", 16: "right_wrist", 23: "left_hip", 24: "right_hip",
    25: "left_knee", 26: "right_knee", 27: "left_ankle", 28: "right_ankle",
}


def keypoints_available() -> bool:
    """True when mediapipe's legacy pose solution can be imported (``[keypoints]`` extra)."""
    try:
        # optional: mediapipe (any import failure means not available)
        import mediapipe as mp

        return hasattr(mp, "solutions") and hasattr(mp.solutions, "pose")
    except Exception:  # noqa: BLE001 - any import failure means "not available"
        return False


@dataclass
class Camera:
    """Pinhole camera: ``K (3,3)``, world-to-camera ``R (3,3)``, ``t (3,)``, image size."""

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    width: int
    height: int

    @property
    def P(self) -> np.ndarray:
        """(3, 4) projection matrix ``K [R | t]``."""
        return self.K @ np.hstack([self.R, self.t[:, None]])

    def project(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (n, 2) (x right, y down) and depths (n,) of world points X (n, 3)."""
        Xc = X @ self.R.T + self.t
        uv = Xc[:, :2] / Xc[:, 2:3] * self.K[0, 0] + self.K[:2, 2]
        return uv, Xc[:, 2]


@dataclass
class ScanKeypoints:
    """Result of :func:`detect_keypoints`.

    Attributes
    ----------
    joints : (j, 3) float64 in the model's joint order, NaN rows for joints not found.
    views : number of rendered views; detections : views where a person was found.
    inliers : {joint name: number of consistent views}.
    """

    joints: np.ndarray
    views: int
    detections: int
    inliers: dict[str, int] = field(default_factory=dict)


def ring_cameras(points: np.ndarray, n_views: int = 8, width: int = 320, height: int = 480,
                 elevation_deg: float = 10.0) -> list[Camera]:
    """Cameras on a circle around the vertical (y) axis through the scan's centre, looking
    slightly down, framing the whole scan."""
    lo, hi = points.min(0), points.max(0)
    centre = 0.5 * (lo + hi)
    half_h = 0.5 * float(hi[1] - lo[1])
    r_xz = float(np.linalg.norm(points[:, [0, 2]] - centre[[0, 2]], axis=1).max())
    f = float(height)  # ~53 degrees vertical field of view
    # the nearest depth of the scan is dist - r_xz: there it must fit 90% of the frame
    dist = r_xz + max(half_h * f / (0.45 * height), r_xz * f / (0.45 * width))
    K = np.array([[f, 0, width / 2], [0, f, height / 2], [0, 0, 1.0]])
    el = np.deg2rad(elevation_deg)
    cams = []
    for k in range(n_views):
        a = 2 * np.pi * k / n_views
        c = centre + dist * np.array([np.sin(a) * np.cos(el), np.sin(el), np.cos(a) * np.cos(el)])
        z = (centre - c) / np.linalg.norm(centre - c)
        x = np.cross(z, [0.0, 1.0, 0.0])
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        R = np.stack([x, y, z])
        cams.append(Camera(K, R, -R @ c, width, height))
    return cams


def _shade(normal_dot: np.ndarray, hit: np.ndarray) -> np.ndarray:
    """(h, w, 3) uint8 image: skin-toned Lambertian shading where ``hit``, dark elsewhere."""
    shade = 0.25 + 0.75 * np.abs(normal_dot)
    img = np.full(hit.shape + (3,), 40.0)
    tint = np.array([225.0, 190.0, 165.0])
    img[hit] = shade[hit][:, None] * tint
    return img.astype(np.uint8)


def render_views(scan, cameras: list[Camera]) -> list[np.ndarray]:
    """Shaded renders (h, w, 3) uint8 of a scan (``(V, F)`` mesh or ``(p, 3)`` points)."""
    if isinstance(scan, (tuple, list)) and len(scan) == 2:
        return [_raycast(np.asarray(scan[0], float), np.asarray(scan[1], np.int64), c)
                for c in cameras]
    P = np.asarray(scan, dtype=np.float64)
    N = normal_lines(P, k=20)  # shading uses |n . d|: the sign does not matter
    return [_splat(P, N, c) for c in cameras]


def _raycast(V: np.ndarray, F: np.ndarray, cam: Camera) -> np.ndarray:
    # heavy: open3d (~0.8 s to import)
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
    ext = np.eye(4)
    ext[:3, :3], ext[:3, 3] = cam.R, cam.t
    rays = scene.create_rays_pinhole(o3d.core.Tensor(cam.K), o3d.core.Tensor(ext), cam.width,
                                     cam.height)
    ans = scene.cast_rays(rays)
    hit = np.isfinite(ans["t_hit"].numpy())
    d = rays.numpy()[..., 3:]
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    n = ans["primitive_normals"].numpy()
    return _shade((n * d).sum(-1), hit)


def _splat(P: np.ndarray, N: np.ndarray, cam: Camera, radius: int = 2) -> np.ndarray:
    """Z-buffered point splats (square, ``radius`` px) shaded by |n . view|."""
    uv, z = cam.project(P)
    view = P - (-cam.R.T @ cam.t)
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    dot = np.abs((N * view).sum(1))
    h, w = cam.height, cam.width
    depth = np.full(h * w, np.inf)
    value = np.zeros(h * w)
    order = np.argsort(-z)  # far first: nearer splats overwrite
    ui, vi = np.round(uv[order]).astype(int).T
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            x, y = ui + dx, vi + dy
            ok = (x >= 0) & (x < w) & (y >= 0) & (y < h)
            idx = y[ok] * w + x[ok]
            zz, vv = z[order][ok], dot[order][ok]
            # keep the nearest per pixel: sort by depth descending, last write wins
            s = np.argsort(-zz, kind="stable")
            closer = zz[s] < depth[idx[s]]
            depth[idx[s][closer]] = zz[s][closer]
            value[idx[s][closer]] = vv[s][closer]
    hit = np.isfinite(depth).reshape(h, w)
    return _shade(value.reshape(h, w), hit)


def detect_2d(images: list[np.ndarray], model_complexity: int = 1) -> list[dict | None]:
    """Per image: ``{joint: (u, v, visibility)}`` in pixels, or None (no person found).

    Raises
    ------
    ImportError : mediapipe (the ``[keypoints]`` extra) is not installed.
    """
    try:
        # optional: mediapipe (ImportError handled)
        import mediapipe as mp
    except ImportError as exc:
        raise ImportError("keypoints from scans need the [keypoints] extra: pip install "
                          "'dressmeup[keypoints]' && pip install --no-deps mediapipe==0.10.14 "
                          "(docs/body-models.md)") from exc
    out: list[dict | None] = []
    with mp.solutions.pose.Pose(static_image_mode=True, model_complexity=model_complexity,
                                enable_segmentation=False) as pose:
        for img in images:
            res = pose.process(img)
            if res.pose_landmarks is None:
                out.append(None)
                continue
            h, w = img.shape[:2]
            lm = res.pose_landmarks.landmark
            out.append({name: (lm[i].x * w, lm[i].y * h, lm[i].visibility)
                        for i, name in MEDIAPIPE_TO_SMPL.items()})
    return out


def _dlt(Ps: list[np.ndarray], uvs: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted linear triangulation of one point from (k, 2) pixels in k views."""
    rows = []
    for P, (u, v), w in zip(Ps, uvs, weights, strict=True):
        rows += [w * (u * P[2] - P[0]), w * (v * P[2] - P[1])]
    _, _, vt = np.linalg.svd(np.asarray(rows))
    X = vt[-1]
    return X[:3] / X[3] if abs(X[3]) > 1e-12 else np.full(3, np.nan)


def _reproj(P: np.ndarray, X: np.ndarray, uv: np.ndarray) -> float:
    x = P @ np.r_[X, 1.0]
    return float(np.linalg.norm(x[:2] / x[2] - uv)) if x[2] > 0 else np.inf


def _ransac(obs: list[tuple[int, np.ndarray, float, str]], Ps: list[np.ndarray],
            threshold: float, exclude: set[int] = frozenset()) -> tuple[np.ndarray, list[int]]:
    """Best point and its inlier observations (indices into ``obs``) by two-view RANSAC."""
    best_X, best_in, best_score = None, [], 0.0
    idx = [i for i in range(len(obs)) if i not in exclude]
    for a in idx:
        for b in idx:
            if b <= a or obs[a][0] == obs[b][0]:
                continue
            X = _dlt([Ps[obs[a][0]], Ps[obs[b][0]]], np.array([obs[a][1], obs[b][1]]),
                     np.ones(2))
            if not np.all(np.isfinite(X)):
                continue
            inl = _inliers(obs, idx, Ps, X, threshold)
            score = sum(obs[i][2] for i in inl)
            if score > best_score:
                best_X, best_in, best_score = X, inl, score
    if best_X is None:
        return np.full(3, np.nan), []
    for _ in range(2):  # re-fit on all inliers, then re-select them around the new point
        X = _dlt([Ps[obs[i][0]] for i in best_in], np.array([obs[i][1] for i in best_in]),
                 np.array([max(obs[i][2], 0.05) for i in best_in]))
        if not np.all(np.isfinite(X)):
            break
        again = _inliers(obs, idx, Ps, X, threshold)
        if len(again) < 2:
            break
        best_X, best_in = X, again
    return best_X, best_in


def _inliers(obs, idx: list[int], Ps, X: np.ndarray, threshold: float) -> list[int]:
    """Per view, the observation nearest to X's projection if within ``threshold`` px."""
    best: dict[int, tuple[float, int]] = {}
    for i in idx:
        e = _reproj(Ps[obs[i][0]], X, obs[i][1])
        if e < threshold and (obs[i][0] not in best or e < best[obs[i][0]][0]):
            best[obs[i][0]] = (e, i)
    return sorted(i for _, i in best.values())


def _votes(obs, inliers: list[int], joint: str, twin: str) -> float:
    """Visibility-weighted "joint" labels minus "twin" labels among ``inliers``."""
    return sum(obs[i][2] * (1.0 if obs[i][3] == joint else -1.0 if obs[i][3] == twin else 0.0)
               for i in inliers)


def triangulate(detections: list[dict | None], cameras: list[Camera], joint_names,
                threshold_px: float = 12.0, min_views: int = 3,
                min_visibility: float = 0.3) -> tuple[np.ndarray, dict[str, int]]:
    """Robust multi-view triangulation (see module docstring).

    Returns
    -------
    joints : (j, 3) float64 in ``joint_names`` order, NaN where not found.
    inliers : {joint: number of consistent views}.
    """
    names = list(joint_names)
    J = np.full((len(names), 3), np.nan)
    Ps = [c.P for c in cameras]
    inliers: dict[str, int] = {}
    done: set[str] = set()
    for joint in MEDIAPIPE_TO_SMPL.values():
        if joint in done or joint not in names:
            continue
        twin = joint.replace("left_", "right_") if joint.startswith("left_") else \
            joint.replace("right_", "left_")
        obs = []
        for v, det in enumerate(detections):
            if det is None:
                continue
            for label in (joint, twin):
                u, w_, vis = det[label]
                if vis >= min_visibility:
                    obs.append((v, np.array([u, w_]), float(vis), label))
        X1, in1 = _ransac(obs, Ps, threshold_px)
        X2, in2 = _ransac(obs, Ps, threshold_px, exclude=set(in1))
        clusters = [(X1, in1), (X2, in2)]
        # the cluster with more "joint" labels (weighted by visibility) is the joint
        if _votes(obs, in1, joint, twin) < _votes(obs, in2, joint, twin):
            clusters.reverse()
        for (X, inl), name in zip(clusters, (joint, twin), strict=True):
            done.add(name)
            inliers[name] = len(inl)
            if name in names and len(inl) >= min_views:
                J[names.index(name)] = X
    return J, inliers


def detect_keypoints(scan, model, n_views: int = 8, model_complexity: int = 1,
                     **triangulate_options) -> ScanKeypoints:
    """Detect 3D body keypoints of an upright scan (y up); see module docstring.

    Parameters
    ----------
    scan : ``(V, F)`` mesh, trimesh, or ``(p, 3)`` points in metres.
    model : the body model whose joint order the result follows.
    n_views : virtual cameras around the scan.
    model_complexity : mediapipe pose model (1 full: shipped in the 0.10.14 wheel; 0 lite
        and 2 heavy are downloaded at first use, so they fail offline).
    """
    if hasattr(scan, "vertices") and hasattr(scan, "faces"):
        scan = (np.asarray(scan.vertices), np.asarray(scan.faces))
    pts = np.asarray(scan[0] if isinstance(scan, (tuple, list)) else scan, dtype=np.float64)
    cams = ring_cameras(pts, n_views)
    images = render_views(scan, cams)
    dets = detect_2d(images, model_complexity)
    J, inl = triangulate(dets, cams, model.joint_names, **triangulate_options)
    found = int(np.isfinite(J[:, 0]).sum())
    logger.info("keypoints: %d of %d views with a person, %d joints triangulated",
                sum(d is not None for d in dets), n_views, found)
    return ScanKeypoints(joints=J, views=n_views, detections=sum(d is not None for d in dets),
                         inliers=inl)
