"""Ray-cast rendering of a synthetic subject: exact depth with open3d's ``RaycastingScene``
(lens distortion included), shaded colour and label images, then the noise model."""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from dressmeup.capture.camera import Camera
from dressmeup.capture.frame import RGBDFrame
from dressmeup.capture.rig import Rig
from dressmeup.capture.synthetic.noise import NoiseModel
from dressmeup.capture.synthetic.subject import SyntheticSubject, _perp
from dressmeup.capture.visibility import raycasting_scene

__all__ = ["camera_rays", "render_depth", "render_frames"]


def camera_rays(camera: Camera) -> np.ndarray:
    """World-space rays of every pixel, lens distortion included.

    Parameters
    ----------
    camera : Camera

    Returns
    -------
    (h, w, 6) float32 rays (origin, direction) whose direction has camera-frame z = 1, so a
    ray-cast ``t_hit`` is the depth along the optical axis.
    """
    u, v = np.meshgrid(np.arange(camera.width, dtype=np.float64), np.arange(camera.height, dtype=np.float64))
    pix = np.stack([u.ravel(), v.ravel()], axis=1)
    if camera.has_distortion:
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 1e-10)
        norm = cv2.undistortPoints(pix.reshape(-1, 1, 2), camera.K, camera.distortion, None, None, None,
                                   crit).reshape(-1, 2)
    else:
        norm = np.stack([(pix[:, 0] - camera.cx) / camera.fx, (pix[:, 1] - camera.cy) / camera.fy], axis=1)
    d_cam = np.concatenate([norm, np.ones((len(norm), 1))], axis=1)
    R = camera.camera_to_world[:3, :3]
    d = d_cam @ R.T
    o = np.broadcast_to(camera.center, d.shape)
    return np.concatenate([o, d], axis=1).reshape(camera.height, camera.width, 6).astype(np.float32)


def render_depth(vertices: np.ndarray, faces: np.ndarray, camera: Camera, scene: Any = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Exact depth of a mesh seen by one camera.

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int.
    camera : Camera
    scene : optional prebuilt open3d RaycastingScene of the same mesh.

    Returns
    -------
    depth : (h, w) float64 metres (0 = background),
    face_ids : (h, w) int64 (-1 = background),
    bary : (h, w, 3) float64 barycentric coordinates of the hit,
    rays : (h, w, 6) float32 the rays used.
    """
    if scene is None:
        scene = raycasting_scene(vertices, faces)
    rays = camera_rays(camera)
    ans = scene.cast_rays(rays)
    t = ans["t_hit"].numpy().astype(np.float64)
    fid = ans["primitive_ids"].numpy().astype(np.int64)
    hit = np.isfinite(t)
    fid[~hit] = -1
    uv = ans["primitive_uvs"].numpy().astype(np.float64)
    bary = np.stack([1 - uv[..., 0] - uv[..., 1], uv[..., 0], uv[..., 1]], axis=-1)
    return np.where(hit, t, 0.0), fid, bary, rays


def render_frames(subject: SyntheticSubject, rig: Rig, noise: NoiseModel | None = None,
                  seed: int = 0, index: int = 0, light: Any = None) -> list[RGBDFrame]:
    """Render colour, depth and label images of a subject from every camera of a rig.

    Parameters
    ----------
    subject : SyntheticSubject (in rig world coordinates; see :func:`place_subject`).
    rig : Rig
    noise : NoiseModel or None (None: exact depth, quantised to 1 mm).
    seed : int, noise seed (each camera gets its own stream).
    index : int, frame number written into the frames.
    light : (3,) float or None, direction towards a distant light (default: up + front).

    Returns
    -------
    list of RGBDFrame, one per camera in rig order.
    """
    noise = noise if noise is not None else NoiseModel(enabled=False)
    scene = raycasting_scene(subject.vertices, subject.faces)
    fnorm = np.cross(*(subject.vertices[subject.faces[:, k]] - subject.vertices[subject.faces[:, 0]] for k in (1, 2)))
    fnorm /= np.maximum(np.linalg.norm(fnorm, axis=1, keepdims=True), 1e-20)
    lvec = np.asarray(light if light is not None else rig.up + 0.5 * _perp(rig.up), dtype=np.float64)
    lvec /= np.linalg.norm(lvec)
    frames = []
    seeds = np.random.SeedSequence([seed, index]).spawn(len(rig.cameras))
    for cam, ss in zip(rig.cameras, seeds, strict=True):
        rng = np.random.default_rng(ss)
        depth, fid, bary, rays = render_depth(subject.vertices, subject.faces, cam, scene)
        h, w = depth.shape
        hit = fid >= 0
        pts = rays[..., :3].astype(np.float64) + rays[..., 3:].astype(np.float64) * depth[..., None]
        color = np.zeros((h, w, 3))
        labels = np.zeros((h, w), dtype=np.uint8)
        cos_view = np.zeros((h, w))
        if hit.any():
            f = fid[hit]
            n = fnorm[f]
            alb = subject.albedo(pts[hit], f, bary[hit])
            shade = 0.65 + 0.35 * np.clip(n @ lvec, 0, 1)
            color[hit] = alb * shade[:, None]
            labels[hit] = subject.face_labels[f]
            dirs = rays[..., 3:][hit].astype(np.float64)
            dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
            cos_view[hit] = np.abs(np.einsum("ij,ij->i", n, dirs))
        lum = color @ np.array([0.299, 0.587, 0.114])
        noisy = noise.apply(depth, cos_view, lum, rng)
        if noise.enabled and (noise.mask_boundary_px > 0 or noise.mask_blobs > 0):
            labels = noise.corrupt_labels(labels, rng)
        c8 = color * 255.0
        if noise.enabled and noise.color_sigma > 0:
            c8 = c8 + rng.normal(scale=noise.color_sigma, size=c8.shape) * hit[..., None]
        frames.append(RGBDFrame(cam.serial, index, np.clip(np.round(c8), 0, 255).astype(np.uint8),
                                noisy, labels, cam))
    return frames
