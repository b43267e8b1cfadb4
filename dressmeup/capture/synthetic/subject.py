"""What a synthetic capture renders: a labelled, coloured mesh of a clothed person
(:class:`SyntheticSubject`), made procedurally (:func:`make_mannequin`) or from a dataset
sample (:func:`subject_from_sample`), and stood in a rig (:func:`place_subject`)."""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.capture.rig import Rig
from dressmeup.capture.session import LABEL_SKIN, GarmentInfo
from dressmeup.capture.visibility import raycasting_scene
from dressmeup.errors import InputError

__all__ = ["SyntheticSubject", "ColorFn", "make_mannequin", "label_faces_by_garments",
           "subject_from_sample", "place_subject"]

log = logging.getLogger("dressmeup.capture.synthetic")

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
    # heavy: scipy.interpolate
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
    # heavy: trimesh
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
    # heavy: open3d (~0.8 s to import)
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
    # heavy: trimesh (~0.7 s to import)
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
            # heavy: pandas
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
