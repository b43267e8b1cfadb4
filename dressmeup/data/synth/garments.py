"""Parametric garments built around the rest body, with their own topology.

A garment is an offset surface of the body (the level set ``signed_distance = offset`` of the
rest body, meshed by marching cubes), optionally united with a flared elliptic cone below the
hips (skirts, dresses), cut by planes (neckline, hem, waist, sleeve and leg ends) or by the
arm/torso boundary (sleeveless), then remeshed isotropically (pymeshlab) so that its vertices
and faces owe nothing to the body's. UVs come from xatlas. The type table is data:
``garment_types.json``.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from dressmeup.geometry.mesh import face_areas, face_normals, weld_coincident
from dressmeup.geometry.proximity import closest_points
from dressmeup.geometry.sampling import sample_surface
from dressmeup.geometry.topology import largest_component_faces
from dressmeup.geometry.uv_packing import xatlas_atlas
from dressmeup.geometry.winding import winding_number

log = logging.getLogger(__name__)

ARM_JOINTS = ("left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist",
              "right_wrist")


@lru_cache(maxsize=1)
def garment_types() -> dict[str, dict[str, Any]]:
    """The garment type table (``garment_types.json``): type -> parameter ranges."""
    text = resources.files("dressmeup.data.synth").joinpath("garment_types.json").read_text()
    return json.loads(text)["types"]


@dataclass
class BodyFrame:
    """Anatomical frame of a rest body: unit ``up``, ``left``, ``forward`` and named joints."""

    up: np.ndarray
    left: np.ndarray
    forward: np.ndarray
    joints: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def from_joints(cls, joints: np.ndarray, names: tuple[str, ...]) -> BodyFrame:
        """Frame from rest joints (j, 3): up = pelvis->head, left = right->left shoulder."""
        J = {n: np.asarray(joints[i], dtype=np.float64) for i, n in enumerate(names)}
        up = J["head"] - J["pelvis"]
        up /= np.linalg.norm(up)
        left = J["left_shoulder"] - J["right_shoulder"]
        left -= up * (left @ up)
        left /= np.linalg.norm(left)
        return cls(up, left, np.cross(left, up), J)

    def h(self, p: np.ndarray) -> np.ndarray:
        """Height of points along ``up``."""
        return np.asarray(p) @ self.up


@dataclass
class Plane:
    """Keep the side where ``(x - point) . normal > 0``; optional radial limit around ``axis``."""

    point: np.ndarray
    normal: np.ndarray
    radius: float | None = None  # only points within this distance of the axis are cut
    axis_point: np.ndarray | None = None
    axis_dir: np.ndarray | None = None
    region: Any = None  # optional callable x -> bool mask of the points the cut applies to

    def value(self, x: np.ndarray) -> np.ndarray:
        s = (x - self.point) @ self.normal
        if self.region is not None:
            s = np.where(self.region(x), s, np.inf)
        if self.radius is not None:
            d = x - self.axis_point
            d = d - np.outer(d @ self.axis_dir, self.axis_dir)
            s = np.where(np.linalg.norm(d, axis=1) < self.radius, s, np.inf)
        return s


@dataclass
class RestGarment:
    """A garment on the rest body.

    Attributes
    ----------
    garment_type, category : names from the type table.
    params : the sampled parameters (JSON-able).
    vertices : (n, 3) float64 rest-pose vertices; faces : (m, 3) int64.
    uv : (k, 2) float64 and uv_faces : (m, 3) int64 (xatlas charts).
    support : (n,) float64 in [0, 1], where the garment rests on the body (shoulders or
        waistband): these vertices are held near their skinned position while draping.
    """

    garment_type: str
    category: str
    params: dict[str, Any]
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    uv_faces: np.ndarray
    support: np.ndarray


def welded(garment: RestGarment, vertices: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """The garment ready to simulate: coincident ``vertices (n, 3)`` (the garment's, on the
    storage grid) welded and the faces that collapse dropped (two coincident vertices would
    make springs of zero rest length).

    Returns
    -------
    ``(V (k, 3), F (f, 3) int64, uv_faces (f, 3) or None, support (k,))``; a welded
    vertex keeps the largest support of the vertices merged into it.
    """
    V, F, vmap, kept = weld_coincident(vertices, garment.faces)
    uv_faces = None if garment.uv_faces is None else np.asarray(garment.uv_faces)[kept]
    support = np.zeros(len(V))
    np.maximum.at(support, vmap, np.asarray(garment.support, np.float64))
    return V, F, uv_faces, support


def sample_params(garment_type: str, rng: np.random.Generator) -> dict[str, Any]:
    """Draw one garment's parameters from the type table's ranges."""
    spec = garment_types()[garment_type]
    out: dict[str, Any] = {}
    for k, v in sorted(spec.items()):
        if isinstance(v, list) and len(v) == 2:
            out[k] = float(rng.uniform(v[0], v[1]))
        elif k != "category":
            out[k] = v
    return out


def _grid_sdf(body_V, body_F, lo, hi, h, level):
    """Signed distance to the body on a grid of step ``h``, exact near ``S = level``.

    A Euclidean distance transform of the voxelised surface (dense surface samples) gives
    the distance everywhere to about ``h``; the sign comes from connectivity to the grid
    border. Grid points within ``2 h`` of the level set are then recomputed exactly: the
    distance by a k-d tree over the surface samples, the sign by the winding number.
    """
    area = face_areas(body_V, body_F).sum()
    n_samples = int(min(max(area / (h / 3) ** 2, 20000), 400000))
    pts, _, _ = sample_surface(body_V, body_F, n_samples, seed=0)
    pts = np.vstack([pts, body_V])
    n = np.maximum(np.ceil((hi - lo) / h).astype(int) + 1, 2)
    ijk = np.round((pts - lo) / h).astype(int)
    inside_box = np.all((ijk >= 0) & (ijk < n), axis=1)
    occ = np.zeros(n, bool)
    occ[tuple(ijk[inside_box].T)] = True
    edt = ndimage.distance_transform_edt(~occ) * h
    lab, _ = ndimage.label(~occ)
    border = np.unique(np.concatenate([lab[[0, -1]].ravel(), lab[:, [0, -1]].ravel(),
                                       lab[:, :, [0, -1]].ravel()]))
    outside = np.isin(lab, border[border > 0])
    S = np.where(outside, edt, -edt).ravel(order="F")
    axes = [lo[i] + h * np.arange(n[i]) for i in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    GV = np.stack([X.ravel(order="F"), Y.ravel(order="F"), Z.ravel(order="F")], 1)
    near = np.abs(S - level) < 2.0 * h
    d, _ = cKDTree(pts).query(GV[near])
    w = winding_number(body_V, body_F, GV[near])
    S[near] = np.where(w > 0.5, -d, d)
    return GV, S, n


def _largest_component(F: np.ndarray, n: int) -> np.ndarray:
    return F[largest_component_faces(F, n)]


def _compact(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    used = np.unique(F)
    remap = -np.ones(len(V), np.int64)
    remap[used] = np.arange(len(used))
    return V[used], remap[F]


def boundary_loops(F: np.ndarray) -> list[np.ndarray]:
    """Boundary vertex loops of a triangle mesh (each an ordered vertex array)."""
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = {}
    for a, b in E:
        key[(a, b)] = True
    nxt = {}
    for a, b in E:
        if (b, a) not in key:
            nxt[a] = b
    loops, seen = [], set()
    for start in list(nxt):
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen and v in nxt:
            seen.add(v)
            loop.append(v)
            v = nxt[v]
        if len(loop) > 2:
            loops.append(np.array(loop))
    return loops


def _smooth_boundary(V, F, planes, h, iterations=6):
    """Snap boundary vertices onto their cutting plane, then smooth each loop along itself."""
    V = V.copy()
    for loop in boundary_loops(F):
        P = V[loop]
        for pl in planes:
            s = pl.value(P)
            near = np.abs(s) < 1.5 * h
            P[near] -= np.outer(s[near], pl.normal)
        for _ in range(iterations):
            P = 0.5 * P + 0.25 * (np.roll(P, 1, 0) + np.roll(P, -1, 0))
        V[loop] = P
    return V


def _remesh(V, F, edge_length, iterations=6):
    # heavy: pymeshlab (~0.3 s to import)
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(V, F))
    ms.meshing_remove_duplicate_vertices()
    ms.meshing_repair_non_manifold_edges()
    ms.meshing_isotropic_explicit_remeshing(iterations=iterations,
                                            targetlen=pymeshlab.PureValue(edge_length),
                                            adaptive=False, checksurfdist=True,
                                            maxsurfdist=pymeshlab.PureValue(edge_length * 0.3))
    ms.meshing_remove_unreferenced_vertices()
    # a garment must not cross itself: drop the rare faces that do (where two cuts meet, e.g.
    # neckline and armhole, the snapped boundary can fold) and their loose fragments
    for _ in range(3):
        ms.compute_selection_by_self_intersections_per_face()
        if ms.current_mesh().selected_face_number() == 0:
            break
        ms.compute_selection_transfer_face_to_vertex(inclusive=False)
        ms.compute_selection_transfer_vertex_to_face(inclusive=True)
        ms.meshing_remove_selected_faces()
        ms.meshing_remove_unreferenced_vertices()
        ms.meshing_repair_non_manifold_edges()
        ms.meshing_repair_non_manifold_vertices()
        ms.meshing_remove_connected_component_by_face_number(mincomponentsize=10)
        ms.meshing_remove_unreferenced_vertices()
    m = ms.current_mesh()
    return m.vertex_matrix().astype(np.float64), m.face_matrix().astype(np.int64)


def _uv(V, F):
    # xatlas' defaults and raw (not square-texel) UVs: the released synthetic datasets were
    # made this way, so the garments' UVs and the dataset hashes stay as they are.
    atlas = xatlas_atlas(V, F, square_texels=False)
    idx = atlas.uv_faces
    if idx.shape != F.shape or not np.array_equal(atlas.vertex_map[idx], F):
        raise RuntimeError("xatlas reordered faces; cannot map UVs back")  # pragma: no cover
    return atlas.uv, idx


def build_garment(garment_type: str, params: dict[str, Any], body_V: np.ndarray,
                  body_F: np.ndarray, labels: np.ndarray, frame: BodyFrame,
                  edge_length: float = 0.015, voxel: float | None = None) -> RestGarment:
    """Build one garment around a rest body.

    Parameters
    ----------
    garment_type : a key of :func:`garment_types`.
    params : from :func:`sample_params`.
    body_V : (n, 3) float64 rest body skin; body_F : (m, 3) int64 (closed or nearly closed).
    labels : (n,) names of the dominant joint of each body vertex (for sleeveless armholes).
    frame : :class:`BodyFrame` of the rest body.
    edge_length : target edge length of the garment mesh (metres).
    voxel : marching-cubes grid step (default ``edge_length / 2``).

    Returns
    -------
    RestGarment
    """
    if garment_type not in garment_types():
        raise ValueError(f"garment_type: expected one of {sorted(garment_types())}, got "
                         f"{garment_type!r}")
    spec = garment_types()[garment_type]
    J = frame.joints
    body_tree = cKDTree(body_V)

    def near_label(x):
        return labels[body_tree.query(x)[1]]

    c = _Cut(params=params, frame=frame, labels=labels, near_label=near_label,
             is_top="neck_drop" in spec, has_skirt=bool(spec.get("skirt")),
             hip_h=0.5 * (frame.h(J["left_hip"]) + frame.h(J["right_hip"])),
             ankle_h=0.5 * (frame.h(J["left_ankle"]) + frame.h(J["right_ankle"])),
             h=float(voxel or edge_length / 2))
    planes = _cut_planes(c)
    GV, S, n = _garment_sdf(c, planes, body_V, body_F)
    V, F = _cut_surface(c, planes, GV, S, n, edge_length)
    # orient outward (away from the body)
    cen = V[F].mean(1)
    _, p, _ = closest_points(body_V, body_F, cen)
    if np.sum(face_normals(V, F) * (cen - p)) < 0:
        F = F[:, [0, 2, 1]]
    uv, uvf = _uv(V, F)
    return RestGarment(garment_type, spec["category"], dict(params), V, F, uv, uvf,
                       _support(c, V))


@dataclass
class _Cut:
    """What the steps of :func:`build_garment` share: the garment's parameters, the body's
    frame and joint labels, the kind of garment and the grid step."""

    params: dict[str, Any]
    frame: BodyFrame
    labels: np.ndarray  # dominant joint of each body vertex
    near_label: Any  # x (k, 3) -> label of the closest body vertex of each point
    is_top: bool
    has_skirt: bool
    hip_h: float  # heights along the frame's up
    ankle_h: float
    h: float  # marching-cubes grid step


def _cut_planes(c: _Cut) -> list[Plane]:
    """The planes that cut the garment: neckline, waist, hem, leg and sleeve ends."""
    frame, params = c.frame, c.params
    J, up = frame.joints, frame.up
    planes: list[Plane] = []
    if c.is_top:
        neck_cut = frame.h(J["neck"]) - params["neck_drop"]
        r_neck = np.linalg.norm(J["left_collar"] - J["right_collar"]) * 0.5 + 0.06

        def neck_region(x, r=r_neck):
            d = x - J["neck"]
            radial = np.linalg.norm(d - np.outer(d @ up, up), axis=1)
            return (radial < r) | np.isin(c.near_label(x), ("neck", "head"))

        planes.append(Plane(up * neck_cut, -up, region=neck_region))
    if "waist_above_pelvis" in params:
        planes.append(Plane(up * (frame.h(J["pelvis"]) + params["waist_above_pelvis"]), -up))
    if "hem_below_hip" in params and not c.has_skirt:
        planes.append(Plane(up * (c.hip_h - params["hem_below_hip"]), up))
    if c.has_skirt:
        planes.append(Plane(up * (c.hip_h - params["skirt_hem_frac"] * (c.hip_h - c.ankle_h)),
                            up))
    if "leg_frac" in params:
        planes.append(Plane(up * (c.hip_h - params["leg_frac"] * (c.hip_h - c.ankle_h)), up))

    def on_side(side):
        names = [f"{side}_{j}" for j in ("shoulder", "elbow", "wrist")]
        return lambda x: np.isin(c.near_label(x), names)

    if params.get("sleeve_frac") is not None:
        for side in ("left", "right"):
            sh, wr = J[f"{side}_shoulder"], J[f"{side}_wrist"]
            a = (wr - sh) / np.linalg.norm(wr - sh)
            planes.append(Plane(sh + a * params["sleeve_frac"] * np.linalg.norm(wr - sh), -a,
                                region=on_side(side)))
    return planes


def _garment_sdf(c: _Cut, planes: list[Plane], body_V: np.ndarray, body_F: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The garment's implicit surface on a grid around the body's region of interest: grid
    points ``GV``, values ``S`` (zero on the garment, the body's offset surface united with
    the skirt's cone) and the grid's shape ``n``."""
    frame, params, h = c.frame, c.params, c.h
    J, off = frame.joints, params["offset"]
    # region of interest: body vertices on the kept side of every plane (+ margin)
    keep_body = ~np.isin(c.labels, ARM_JOINTS) if params.get("sleeve_frac") is None else \
        np.ones(len(body_V), bool)
    for pl in planes:
        keep_body &= pl.value(body_V) > -0.03
    if not c.is_top and not c.has_skirt:
        keep_body &= frame.h(body_V) < frame.h(J["spine2"])
    if c.is_top:
        keep_body &= frame.h(body_V) > c.hip_h - 0.25
    pad = off + 4 * h + 0.03
    lo, hi = body_V[keep_body].min(0) - pad, body_V[keep_body].max(0) + pad
    if c.has_skirt:
        drop = c.hip_h - c.ankle_h
        lo = np.minimum(lo, body_V[keep_body].min(0) - pad - params["flare"] * drop)
        hi = np.maximum(hi, body_V[keep_body].max(0) + pad + params["flare"] * drop)
    GV, S, n = _grid_sdf(body_V, body_F, lo, hi, h, level=off)
    S = S - off
    if c.has_skirt:
        S = np.minimum(S, _skirt_cone(c, GV, body_V))
    return GV, S, n


def _skirt_cone(c: _Cut, GV: np.ndarray, body_V: np.ndarray) -> np.ndarray:
    """The flared elliptic cone around both legs, from the hips down, at the grid points
    ``GV`` (a signed distance, scaled; infinite above the hips)."""
    frame, hip_h, off = c.frame, c.hip_h, c.params["offset"]
    centre = frame.joints["pelvis"]
    near_hip = (np.abs(frame.h(body_V) - hip_h) < 0.04) & ~np.isin(c.labels, ARM_JOINTS)
    rel = body_V[near_hip] - centre
    a_lat = np.abs(rel @ frame.left).max() + off
    a_fwd = np.abs(rel @ frame.forward).max() + off
    d = GV - centre
    below = np.maximum(hip_h - frame.h(GV), 0.0)
    grow = c.params["flare"] * below
    ex, ez = d @ frame.left / (a_lat + grow), d @ frame.forward / (a_fwd + grow)
    rr = np.sqrt(ex**2 + ez**2)
    cone = (rr - 1.0) * np.minimum(a_lat, a_fwd)
    return np.where(frame.h(GV) > hip_h + 0.02, np.inf, cone)


def _cut_surface(c: _Cut, planes: list[Plane], GV: np.ndarray, S: np.ndarray, n: np.ndarray,
                 edge_length: float) -> tuple[np.ndarray, np.ndarray]:
    """The zero level of ``S`` meshed, cut by the planes (no arms for sleeveless garments,
    never the feet), its largest piece with smoothed boundary, remeshed: ``(V, F)``."""
    # heavy: igl (~0.4 s to import)
    import igl

    MV, MF, _ = igl.marching_cubes(S, GV, int(n[0]), int(n[1]), int(n[2]), 0.0)
    MF = MF.astype(np.int64)
    # cut
    keep_v = np.ones(len(MV), bool)
    for pl in planes:
        keep_v &= pl.value(MV) > 0
    if c.params.get("sleeve_frac") is None:  # sleeveless tops and all bottoms: no arms
        keep_v &= ~np.isin(c.near_label(MV), ARM_JOINTS)
    if not c.has_skirt:
        keep_v &= c.frame.h(MV) > c.ankle_h  # never the feet
    F = MF[keep_v[MF].all(1)]
    F = _largest_component(F, len(MV))
    V, F = _compact(MV, F)
    V = _smooth_boundary(V, F, planes, c.h)
    V, F = _remesh(V, F, edge_length)
    F = _largest_component(F, len(V))
    return _compact(V, F)


def _support(c: _Cut, V: np.ndarray) -> np.ndarray:
    """Where the garment ``V (n, 3)`` hangs from the body: 1 at the shoulders of a top, at
    the waistband of a bottom, else 0."""
    frame, J = c.frame, c.frame.joints
    if c.is_top:
        top = frame.h(J["left_collar"]) - 0.03
        lateral = np.abs((V - J["neck"]) @ frame.left)
        reach = 0.5 * np.linalg.norm(J["left_shoulder"] - J["right_shoulder"])
        return ((frame.h(V) > top) & (lateral < reach)).astype(np.float64)
    waist = frame.h(J["pelvis"]) + c.params["waist_above_pelvis"]
    return (frame.h(V) > waist - 0.04).astype(np.float64)
