"""Synthetic RGBD captures with exact ground truth: ray-cast rendering and a depth-noise model.

A :class:`SyntheticSubject` is a labelled, coloured triangle mesh (the clothed person: face
labels 1 = skin, 2.. = garments). :func:`render_frames` ray-casts it from every camera of a
rig with open3d's ``RaycastingScene`` (lens distortion included) and produces colour, depth
and label images; :class:`NoiseModel` turns the exact depth into Kinect-like measurements;
:func:`synth_capture` writes a whole session with its ``ground_truth/`` folder.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.capture.rig import Camera, Rig, perturb_rig, save_rig
from dressmeup.capture.session import (
    LABEL_SKIN,
    GarmentInfo,
    RGBDFrame,
    SessionInfo,
    write_frame,
    write_session,
)
from dressmeup.capture.visibility import raycasting_scene
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_path, atomic_write_text

__all__ = [
    "SyntheticSubject",
    "NoiseModel",
    "make_mannequin",
    "subject_from_sample",
    "label_faces_by_garments",
    "place_subject",
    "camera_rays",
    "render_frames",
    "render_depth",
    "synth_capture",
    "load_ground_truth",
    "GroundTruth",
]

log = logging.getLogger(__name__)

ColorFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass
class SyntheticSubject:
    """A clothed person to render.

    Attributes
    ----------
    vertices : (n, 3) float64, metres.
    faces : (m, 3) int64.
    face_labels : (m,) uint8, 1 = skin, 2.. = garment labels.
    garments : list of GarmentInfo (their ``label`` values appear in ``face_labels``).
    vertex_colors : (n, 3) uint8 or None, albedo per vertex (used when ``color_fn`` is None).
    color_fn : callable or None, ``color_fn(points (k,3), face_ids (k,)) -> (k,3) float in [0,1]``
        procedural albedo (stripes, prints) evaluated at ray hits.
    subject_id, pose_id : str
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_labels: np.ndarray
    garments: list[GarmentInfo]
    vertex_colors: np.ndarray | None = None
    color_fn: ColorFn | None = None
    subject_id: str = "S00"
    pose_id: str = "P0"

    def albedo(self, points: np.ndarray, face_ids: np.ndarray, bary: np.ndarray) -> np.ndarray:
        """Albedo at surface points: (k, 3) float64 in [0, 1]."""
        if self.color_fn is not None:
            return np.clip(self.color_fn(points, face_ids), 0.0, 1.0)
        if self.vertex_colors is not None:
            vc = np.asarray(self.vertex_colors, dtype=np.float64)[:, :3] / 255.0
            tri = self.faces[face_ids]
            return np.einsum("kj,kjc->kc", bary, vc[tri])
        palette = np.array([[0.5, 0.5, 0.5], [0.87, 0.68, 0.55], [0.2, 0.35, 0.75], [0.45, 0.3, 0.25],
                            [0.6, 0.2, 0.2], [0.2, 0.55, 0.3]])
        return palette[np.minimum(self.face_labels[face_ids], len(palette) - 1)]


@dataclass
class NoiseModel:
    """Kinect-like depth noise.

    Attributes
    ----------
    enabled : bool, False gives exact depth (still quantised to the depth unit).
    sigma_base : float, metres, constant part of the axial noise standard deviation.
    sigma_quadratic : float, metres per metre^2: sigma(z) = sigma_base + sigma_quadratic * z^2.
    grazing_cos_full, grazing_cos_none : float, dropout probability rises linearly from 0 where
        cos(view angle) >= ``grazing_cos_none`` to 1 at ``grazing_cos_full``.
    dark_luminance : float, albedo luminance below which pixels start to drop out (IR absorption).
    dark_max_dropout : float, dropout probability at luminance 0.
    flying_threshold : float, metres; a depth jump larger than this between 4-neighbours is an edge.
    flying_probability : float, chance that an edge pixel becomes a flying pixel (a depth
        between foreground and background, or up to ``flying_max_tail`` behind the foreground).
    flying_max_tail : float, metres.
    color_sigma : float, colour noise standard deviation on 0..255.
    depth_unit : float, metres per stored unit (quantisation).
    mask_boundary_px : int, label-mask boundary errors (see :meth:`corrupt_labels`; 0: exact).
    mask_blobs : int, wrongly labelled blobs per view (0: none).
    """

    enabled: bool = True
    sigma_base: float = 0.0005
    sigma_quadratic: float = 0.0003
    grazing_cos_full: float = 0.08
    grazing_cos_none: float = 0.25
    dark_luminance: float = 0.08
    dark_max_dropout: float = 0.8
    flying_threshold: float = 0.05
    flying_probability: float = 0.5
    flying_max_tail: float = 0.3
    color_sigma: float = 2.0
    depth_unit: float = 0.001
    mask_boundary_px: int = 0
    mask_blobs: int = 0

    def corrupt_labels(self, labels: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Imitate a 2D human-parsing model's errors on an exact label mask.

        Each label region (>= 1) grows or shrinks by up to ``mask_boundary_px`` pixels (its own
        random amount per view) and ``mask_blobs`` discs of 4-12 px radius inside the
        silhouette take a wrong label. Background (0) is left alone. Off by default.

        Parameters
        ----------
        labels : (h, w) uint8, rng : numpy Generator.

        Returns
        -------
        (h, w) uint8
        """
        import cv2

        out = labels.copy()
        fg = labels > 0
        present = [int(v) for v in np.unique(labels) if v > 0]
        if self.mask_boundary_px > 0:
            for lab in present:
                k = int(rng.integers(-self.mask_boundary_px, self.mask_boundary_px + 1))
                if k == 0:
                    continue
                mask = (out == lab).astype(np.uint8)
                ker = np.ones((2 * abs(k) + 1,) * 2, np.uint8)
                if k > 0:
                    grown = cv2.dilate(mask, ker) > 0
                    out[grown & fg] = lab
                else:
                    shrunk = cv2.erode(mask, ker) > 0
                    lost = (mask > 0) & ~shrunk
                    # lost pixels take the most common other label around them
                    others = np.where(out == lab, 0, out).astype(np.uint8)
                    spread = cv2.dilate(others, np.ones((2 * abs(k) + 3,) * 2, np.uint8))
                    out[lost & (spread > 0)] = spread[lost & (spread > 0)]
        if self.mask_blobs > 0 and len(present) > 1:
            ys, xs = np.nonzero(fg)
            for _ in range(self.mask_blobs):
                if len(ys) == 0:
                    break
                i = int(rng.integers(len(ys)))
                r = int(rng.integers(4, 13))
                disc = np.zeros(labels.shape, np.uint8)
                cv2.circle(disc, (int(xs[i]), int(ys[i])), r, 1, -1)
                wrong = [v for v in present if v != labels[ys[i], xs[i]]]
                out[(disc > 0) & fg] = wrong[int(rng.integers(len(wrong)))]
        return out

    def sigma(self, z: np.ndarray) -> np.ndarray:
        """Axial noise standard deviation (metres) at depth ``z`` (metres)."""
        return self.sigma_base + self.sigma_quadratic * np.asarray(z) ** 2

    def apply(self, depth: np.ndarray, cos_view: np.ndarray, luminance: np.ndarray,
              rng: np.random.Generator) -> np.ndarray:
        """Corrupt an exact depth image.

        Parameters
        ----------
        depth : (h, w) float, exact depth in metres (0 = no surface).
        cos_view : (h, w) float, cosine between the surface normal and the ray towards the camera.
        luminance : (h, w) float in [0, 1], albedo luminance.
        rng : numpy Generator.

        Returns
        -------
        (h, w) float32 noisy depth in metres, quantised to ``depth_unit``, 0 = dropout.
        """
        d = np.asarray(depth, dtype=np.float64).copy()
        valid = d > 0
        if self.enabled:
            d[valid] += rng.normal(size=int(valid.sum())) * self.sigma(d[valid])
            span = max(self.grazing_cos_none - self.grazing_cos_full, 1e-9)
            p_graze = np.clip((self.grazing_cos_none - cos_view) / span, 0.0, 1.0)
            p_dark = self.dark_max_dropout * np.clip((self.dark_luminance - luminance) / max(self.dark_luminance, 1e-9), 0, 1)
            p = 1.0 - (1.0 - p_graze) * (1.0 - p_dark)
            drop = valid & (rng.random(d.shape) < p)
            # flying pixels at depth edges: mix foreground and background
            exact = np.asarray(depth, dtype=np.float64)
            big = np.where(exact > 0, exact, np.inf)
            fly = np.zeros(d.shape, dtype=bool)
            far = np.zeros(d.shape)
            padded = np.pad(big, 1, mode="edge")
            h, w = big.shape
            for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0)):
                nb = padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
                edge = valid & (nb - exact > self.flying_threshold)
                fly |= edge
                far = np.where(edge, np.maximum(far, np.where(np.isfinite(nb), nb, exact + self.flying_max_tail)), far)
            fly &= rng.random(d.shape) < self.flying_probability
            u = rng.random(d.shape)
            d = np.where(fly, exact + u * (far - exact), d)
            d[drop & ~fly] = 0.0
        d[~valid] = 0.0
        if self.depth_unit > 0:
            d = np.round(d / self.depth_unit) * self.depth_unit
        d[d < 0] = 0
        return d.astype(np.float32)


# ----------------------------------------------------------------------------------------
# subjects

def _profile() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Half-widths (x) and half-depths (z) of the mannequin along its height (y, metres)."""
    y = np.array([0.0, 0.05, 0.3, 0.5, 0.7, 0.88, 0.95, 1.05, 1.12, 1.25, 1.35, 1.42, 1.47,
                  1.51, 1.55, 1.6, 1.66, 1.72, 1.77, 1.8])
    a = np.array([0.17, 0.19, 0.17, 0.16, 0.18, 0.2, 0.2, 0.17, 0.15, 0.17, 0.19, 0.22, 0.2,
                  0.12, 0.06, 0.075, 0.09, 0.085, 0.06, 0.0])
    b = np.array([0.12, 0.13, 0.1, 0.09, 0.11, 0.13, 0.13, 0.11, 0.1, 0.12, 0.13, 0.12, 0.1,
                  0.07, 0.06, 0.085, 0.1, 0.095, 0.07, 0.0])
    return y, a, b


def make_mannequin(n_around: int = 160, n_up: int = 240, seed: int = 0) -> SyntheticSubject:
    """A procedural clothed mannequin (y-up, feet at y = 0, 1.8 m tall) with two garments.

    A closed torso-and-head surface of elliptic cross-sections with an asymmetric chest pocket
    bump and a nose, and two capsule arms hanging beside it (so that multi-view registration
    is well posed); faces between 0.97 m and 1.5 m (sleeves: arm faces above 1.22 m) are a
    striped top (label 2, ``G-top``, topwear), between 0.32 m and 0.97 m trousers (label 3,
    ``G-pants``, bottomwear), the rest skin (label 1).

    Parameters
    ----------
    n_around, n_up : int, grid resolution (faces = 2 * n_around * n_up approximately).
    seed : int, seed of the small random surface texture.

    Returns
    -------
    SyntheticSubject
    """
    from scipy.interpolate import PchipInterpolator

    py, pa, pb = _profile()
    fa, fb = PchipInterpolator(py, pa), PchipInterpolator(py, pb)
    ys = 0.8 - 0.8 * np.cos(np.linspace(0, math.pi, n_up + 1))  # denser near the ends
    ys = ys / ys.max() * py[-1]
    ys = ys[:-1]  # the top is closed by a pole vertex
    th = np.linspace(0, 2 * math.pi, n_around, endpoint=False)
    Y, T = np.meshgrid(ys, th, indexing="ij")
    A, B = fa(Y), fb(Y)
    # pocket bump on the left chest, nose on the face (front = +z)
    bump = 0.025 * np.exp(-(((Y - 1.3) / 0.05) ** 2 + ((T - 1.1) / 0.25) ** 2))
    nose = 0.03 * np.exp(-(((Y - 1.66) / 0.025) ** 2 + ((T - math.pi / 2) / 0.12) ** 2))
    X = (A + bump) * np.cos(T)
    Z = (B + bump + nose) * np.sin(T)
    verts = np.stack([X, Y, Z], axis=-1).reshape(-1, 3)
    n_ring = len(ys)
    idx = np.arange(n_ring * n_around).reshape(n_ring, n_around)
    nxt = np.roll(idx, -1, axis=1)
    a0, a1, b0, b1 = idx[:-1], nxt[:-1], idx[1:], nxt[1:]
    quads = np.concatenate([np.stack([a0, b0, a1], -1).reshape(-1, 3), np.stack([a1, b0, b1], -1).reshape(-1, 3)])
    bottom = len(verts)
    top = bottom + 1
    verts = np.vstack([verts, [[0, ys[0], 0], [0, py[-1], 0]]])
    cap_b = np.stack([np.full(n_around, bottom), idx[0], nxt[0]], -1)
    cap_t = np.stack([np.full(n_around, top), nxt[-1], idx[-1]], -1)
    faces = np.vstack([quads, cap_b, cap_t]).astype(np.int64)
    # orientation: outward normals
    import trimesh

    tm = trimesh.Trimesh(verts, faces, process=False)
    if tm.volume < 0:
        faces = faces[:, ::-1].copy()
    # arms: separate closed capsules hanging beside the torso (slight A-pose)
    for side in (-1.0, 1.0):
        top_pt, bottom_pt = np.array([0.255 * side, 1.40, 0.0]), np.array([0.33 * side, 0.84, 0.03])
        axis = bottom_pt - top_pt
        length = float(np.linalg.norm(axis))
        arm = trimesh.creation.capsule(height=length, radius=0.042, count=[16, 16])
        # the capsule is centred on the origin along z: rotate z onto the arm axis
        arm.apply_transform(trimesh.geometry.align_vectors([0, 0, 1], axis / length))
        arm.apply_translation(top_pt + axis / 2)
        av, af = trimesh.remesh.subdivide_to_size(arm.vertices, arm.faces, max_edge=0.02)
        arm = trimesh.Trimesh(av, af, process=True)
        faces = np.vstack([faces, np.asarray(arm.faces) + len(verts)])
        verts = np.vstack([verts, np.asarray(arm.vertices)])
    cy = verts[faces].mean(axis=1)[:, 1]
    labels = np.full(len(faces), LABEL_SKIN, dtype=np.uint8)
    n_torso = len(quads) + 2 * n_around
    is_arm = np.arange(len(faces)) >= n_torso
    labels[(cy >= 0.97) & (cy < 1.5) & ~is_arm] = 2
    labels[(cy >= 1.22) & is_arm] = 2
    labels[(cy >= 0.32) & (cy < 0.97) & ~is_arm] = 3
    garments = [GarmentInfo("G-top", "topwear", 2, "tshirt"), GarmentInfo("G-pants", "bottomwear", 3, "trousers")]
    phase = np.random.default_rng(seed).uniform(0, 2 * math.pi)

    def color_fn(points: np.ndarray, face_ids: np.ndarray) -> np.ndarray:
        lab = labels[face_ids]
        out = np.empty((len(points), 3))
        skin = np.array([0.87, 0.66, 0.53])
        out[:] = skin
        stripes = 0.5 + 0.5 * np.sign(np.sin(points[:, 1] * 2 * math.pi / 0.06 + phase))
        top = np.array([0.15, 0.3, 0.75])[None] * (1 - stripes[:, None]) + np.array([0.92, 0.9, 0.85])[None] * stripes[:, None]
        ang = np.arctan2(points[:, 2], points[:, 0])
        check = 0.5 + 0.5 * np.sign(np.sin(ang * 12) * np.sin(points[:, 1] * 2 * math.pi / 0.1))
        pants = np.array([0.25, 0.22, 0.2])[None] + 0.15 * check[:, None]
        out[lab == 2] = top[lab == 2]
        out[lab == 3] = pants[lab == 3]
        return out

    return SyntheticSubject(verts.astype(np.float64), faces, labels, garments,
                            color_fn=color_fn, subject_id="S00", pose_id="P0")


def label_faces_by_garments(vertices: np.ndarray, faces: np.ndarray,
                            garment_meshes: list[tuple[np.ndarray, np.ndarray]],
                            labels: list[int], tolerance: float = 0.004) -> np.ndarray:
    """Label scan faces by the garment surface they lie on.

    A face whose centroid is within ``tolerance`` of a garment surface takes that garment's
    label (the nearest garment when several are close); other faces are skin (1).

    Parameters
    ----------
    vertices : (n, 3) float, faces : (m, 3) int, the scan.
    garment_meshes : list of (V (k,3), F (l,3)) garment meshes in the scan's frame.
    labels : list of int, one label value per garment.
    tolerance : float, metres.

    Returns
    -------
    (m,) uint8 face labels.
    """
    import open3d as o3d

    cent = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)].mean(axis=1)
    best = np.full(len(cent), np.inf)
    out = np.full(len(cent), LABEL_SKIN, dtype=np.uint8)
    for (gv, gf), lab in zip(garment_meshes, labels, strict=True):
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(np.asarray(gv, dtype=np.float32), np.asarray(gf, dtype=np.uint32))
        d = scene.compute_distance(cent.astype(np.float32)).numpy().astype(np.float64)
        take = (d < tolerance) & (d < best)
        out[take] = lab
        best = np.where(take, d, best)
    return out


def _read_mesh(path: Path) -> Any:
    import trimesh

    try:
        m = trimesh.load(str(path), process=False, force="mesh")
    except Exception as exc:  # trimesh raises many types on bad files
        raise InputError(f"{path}: cannot read mesh ({exc})") from exc
    if len(m.faces) == 0:
        raise InputError(f"{path}: mesh has no faces")
    return m


def subject_from_sample(sample_dir: str | os.PathLike, tolerance: float = 0.004,
                        with_siblings: bool = False) -> SyntheticSubject:
    """A subject from a dataset sample folder ``samples/<subject>/<garment>/<pose>/``.

    Reads ``scan.ply`` and the sample's garment mesh (a DressMeUp-style sample holds one
    garment, and the generator's scans show that garment only); with ``with_siblings`` also
    the garments of the same subject and pose (``samples/<subject>/*/<pose>/garment.*``) that
    the scan surface runs along (median distance below ``tolerance``), for datasets whose
    scans dress several garments at once. Then it labels the scan's
    faces by the garment surface they lie on (:func:`label_faces_by_garments`). The categories
    come from ``manifest.parquet`` when it can be read, else ``unknown``.

    Raises
    ------
    InputError naming the missing or unreadable file.
    """
    sample_dir = Path(sample_dir)
    scan_path = sample_dir / "scan.ply"
    if not scan_path.is_file():
        raise InputError(f"{scan_path}: file is missing (synth-capture needs the clothed scan of the sample)")
    scan = _read_mesh(scan_path)
    pose_id, subject_dir = sample_dir.name, sample_dir.parent.parent
    subject_id = subject_dir.name
    categories: dict[str, str] = {}
    types: dict[str, str] = {}
    manifest = subject_dir.parent.parent / "manifest.parquet"
    if manifest.is_file():
        try:
            import pandas as pd

            df = pd.read_parquet(manifest)
            if {"garment_id", "category"} <= set(df.columns):
                categories = dict(zip(df["garment_id"].astype(str), df["category"].astype(str), strict=False))
            if {"garment_id", "garment_type"} <= set(df.columns):
                types = dict(zip(df["garment_id"].astype(str), df["garment_type"].astype(str), strict=False))
        except Exception as exc:  # a damaged manifest only loses the category names
            log.warning("could not read categories from %s: %s", manifest, exc)

    V, F = np.asarray(scan.vertices, dtype=np.float64), np.asarray(scan.faces, dtype=np.int64)
    scan_scene = raycasting_scene(V, F)
    meshes, infos = [], []
    siblings = sorted(p for p in subject_dir.iterdir() if p.is_dir()) if with_siblings else [sample_dir.parent]
    for gdir in siblings:
        cand = [gdir / pose_id / f"garment.{ext}" for ext in ("ply", "obj")]
        path = next((c for c in cand if c.is_file()), None)
        if path is None:
            continue
        m = _read_mesh(path)
        gv = np.asarray(m.vertices, dtype=np.float64)
        # a sibling garment belongs to this scan only if the scan surface runs along it
        # (generated datasets write one scan per garment; real ones may dress several)
        dist = scan_scene.compute_distance(gv.astype(np.float32)).numpy()
        if gdir.name != sample_dir.parent.name and np.median(dist) > tolerance:
            continue
        meshes.append((gv, np.asarray(m.faces)))
        infos.append(GarmentInfo(gdir.name, categories.get(gdir.name, "unknown"), 2 + len(infos),
                                 types.get(gdir.name, "")))
    if not infos:
        raise InputError(f"{subject_dir}: no garment.ply/obj found for pose {pose_id!r}")
    labels = label_faces_by_garments(V, F, meshes, [g.label for g in infos], tolerance)
    vc = None
    vcol = getattr(scan.visual, "vertex_colors", None)
    if vcol is not None and len(vcol) == len(V) and np.ptp(np.asarray(vcol)[:, :3]) > 0:
        vc = np.asarray(vcol)[:, :3].astype(np.uint8)
    return SyntheticSubject(V, F, labels, infos, vertex_colors=vc, subject_id=subject_id, pose_id=pose_id)


def place_subject(subject: SyntheticSubject, rig: Rig, subject_up: str | np.ndarray = "auto"
                  ) -> tuple[SyntheticSubject, np.ndarray]:
    """Stand a subject in the rig: its up axis on the rig's, feet on the floor, centred.

    Parameters
    ----------
    subject : SyntheticSubject
    rig : Rig (its ``up`` and ``target``).
    subject_up : ``"auto"`` (the longest bounding-box axis, sign kept positive), ``"x"``,
        ``"y"``, ``"z"`` or a 3-vector.

    Returns
    -------
    (placed subject, (4, 4) float64 subject-to-world transform)
    """
    V = subject.vertices
    if isinstance(subject_up, str):
        if subject_up == "auto":
            axis = int(np.argmax(np.ptp(V, axis=0)))
        elif subject_up in ("x", "y", "z"):
            axis = "xyz".index(subject_up)
        else:
            raise ValueError(f"subject_up: expected auto, x, y, z or a vector, got {subject_up!r}")
        up = np.eye(3)[axis]
    else:
        up = np.asarray(subject_up, dtype=np.float64)
        up = up / np.linalg.norm(up)
    target_up = rig.up / np.linalg.norm(rig.up)
    v = np.cross(up, target_up)
    c = float(up @ target_up)
    if np.linalg.norm(v) < 1e-9:
        R = np.eye(3) if c > 0 else -np.eye(3) + 2 * np.outer(_perp(up), _perp(up))
    else:
        k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        R = np.eye(3) + k + k @ k * (1 / (1 + c))
    P = V @ R.T
    h = P @ target_up
    horiz = P - np.outer(h, target_up)
    center = 0.5 * (horiz.min(axis=0) + horiz.max(axis=0))
    tgt_h = rig.target - target_up * (rig.target @ target_up)
    t = -center + tgt_h - target_up * (center @ target_up) - target_up * h.min()
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    placed = SyntheticSubject(P + t, subject.faces, subject.face_labels, subject.garments,
                              subject.vertex_colors, None, subject.subject_id, subject.pose_id)
    if subject.color_fn is not None:
        fn = subject.color_fn
        inv_r, inv_t = R.T, -R.T @ t
        placed.color_fn = lambda p, f: fn(p @ inv_r.T + inv_t, f)
    return placed, T


def _perp(v: np.ndarray) -> np.ndarray:
    a = np.array([1.0, 0, 0]) if abs(v[0]) < 0.9 else np.array([0, 1.0, 0])
    p = np.cross(v, a)
    return p / np.linalg.norm(p)


# ----------------------------------------------------------------------------------------
# rendering

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
    import cv2

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
                                noisy, labels))
    return frames


@dataclass
class GroundTruth:
    """The exact answer of a synthetic session (``SESSION/ground_truth``).

    Attributes
    ----------
    vertices : (n, 3) float64, faces : (m, 3) int64, the clothed scan in world coordinates.
    face_labels : (m,) uint8
    rig : Rig, the true (unperturbed) calibration.
    subject_to_world : (4, 4) float64
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_labels: np.ndarray
    rig: Rig
    subject_to_world: np.ndarray = field(default_factory=lambda: np.eye(4))

    def garment(self, label: int) -> tuple[np.ndarray, np.ndarray]:
        """The ground-truth garment with this label: (V (k,3) float64, F (l,3) int64)."""
        sel = self.faces[self.face_labels == label]
        used, inv = np.unique(sel, return_inverse=True)
        return self.vertices[used], inv.reshape(-1, 3).astype(np.int64)


def load_ground_truth(session_root: str | os.PathLike) -> GroundTruth:
    """Read ``SESSION/ground_truth`` written by :func:`synth_capture`.

    Raises
    ------
    FileNotFoundError when the session has no ground truth (a real capture).
    """
    from dressmeup.capture.rig import load_rig

    gt = Path(session_root) / "ground_truth"
    if not (gt / "scan.npz").is_file():
        raise FileNotFoundError(f"{gt / 'scan.npz'}: no ground truth (only synthetic sessions have one)")
    with np.load(gt / "scan.npz", allow_pickle=False) as z:
        V, F, L, T = z["vertices"], z["faces"], z["face_labels"], z["subject_to_world"]
    return GroundTruth(V.astype(np.float64), F.astype(np.int64), L.astype(np.uint8),
                       load_rig(gt / "rig_true.json"), T.astype(np.float64))


def synth_capture(subject: SyntheticSubject, rig: Rig, out: str | os.PathLike,
                  noise: NoiseModel | None = None, seed: int = 0, n_frames: int = 1,
                  perturb_deg: float = 0.0, perturb_m: float = 0.0, subject_up: str = "auto",
                  place: bool = True) -> Path:
    """Render a subject with a rig and write a capture session with its ground truth.

    Parameters
    ----------
    subject : SyntheticSubject
    rig : Rig, the true calibration used for rendering.
    out : session folder to write.
    noise : NoiseModel or None (exact depth).
    seed : int, seed of the noise and of the extrinsic perturbation.
    n_frames : int, number of frames (same pose, fresh noise).
    perturb_deg, perturb_m : float, size of the calibration drift written into rig.json
        (every camera but the reference), see :func:`perturb_rig`.
    subject_up : how to find the subject's up axis when placing it (:func:`place_subject`).
    place : stand the subject in the rig (False: use its coordinates as world coordinates).

    Returns
    -------
    Path of the session folder.
    """
    out = Path(out)
    if n_frames < 1:
        raise ValueError(f"n_frames: expected >= 1, got {n_frames}")
    T = np.eye(4)
    if place:
        subject, T = place_subject(subject, rig, subject_up)
    written_rig = perturb_rig(rig, perturb_deg, perturb_m, seed) if (perturb_deg or perturb_m) else rig
    info = SessionInfo(subject_id=subject.subject_id, pose_id=subject.pose_id, garments=subject.garments,
                       n_frames=n_frames,
                       extra={"synthetic": True, "seed": seed, "noise": asdict(noise) if noise else None,
                              "perturbation": {"rotation_deg": perturb_deg, "translation_m": perturb_m}})
    write_session(out, written_rig, info)
    for i in range(n_frames):
        for fr in render_frames(subject, rig, noise, seed=seed, index=i):
            write_frame(out, fr, depth_scale=rig.camera(fr.serial).depth_scale)
    gt = out / "ground_truth"
    gt.mkdir(exist_ok=True)
    save_rig(rig, gt / "rig_true.json")
    with atomic_path(gt / "scan.npz") as tmp:
        np.savez_compressed(tmp, vertices=subject.vertices, faces=subject.faces,
                            face_labels=subject.face_labels, subject_to_world=T)
    atomic_write_text(gt / "README.txt", "Exact ground truth of this synthetic capture: scan.npz "
                      "(vertices, faces, face_labels, subject_to_world) and rig_true.json (the "
                      "calibration used for rendering; rig.json may hold a perturbed one).\n")
    atomic_write_text(gt / "labels.json", json.dumps(info.label_names(), indent=2) + "\n")
    return out
