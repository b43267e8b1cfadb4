"""Contact detection of the cloth solver (:mod:`dressmeup.data.synth.cloth`).

Two kinds of contact, each found once per solver iteration and linearised there:

- **body**: every cloth vertex's closest point on the body surface (float64, the closest face
  chosen exactly: :func:`dressmeup.geometry.proximity.closest_points` with
  ``exact_faces=True``), inside or outside by the angle-weighted pseudo-normal of the closest
  feature, and the outward unit direction;
- **self**: vertex-triangle pairs of the cloth closer than a detection distance whose triangle
  is not in the vertex's topological neighbourhood (two rings), found with a k-d tree over the
  triangle centroids and measured exactly; each pair keeps the barycentric coordinates of the
  closest point and the unit direction from it to the vertex.

Pairs are returned sorted, so that sums over them do not depend on the k-d tree's order.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.geometry.mesh import edges, face_normals
from dressmeup.geometry.proximity import SurfaceIndex, barycentric, closest_point_on_triangles


@dataclass
class BodyContact:
    """Contact planes between cloth vertices and the body: ``vertex (q,) int64``, the body
    feature's ``key (q,) int64`` (face, edge or body vertex; -1: the closest point of a
    vertex deep inside), the plane's ``points (q, 3)`` on the body, outward unit ``normals (q, 3)`` and ``weight (q,)`` in
    (0, 1]; ``signed (n,)`` is every cloth vertex's signed distance to the body (negative
    inside).

    A vertex has one plane per body feature (face, edge or body vertex) that is *locally*
    closest to it: the closest feature of every face around it. On a convex or flat part of
    the body that is the closest point, so the penalty is the signed distance's; in a fold
    of the body (between thigh and belly when sitting, under the arm) each side of the fold
    has its own locally closest feature, and the vertex rests against both instead of being
    pushed out of one side into the other, iteration after iteration.
    """

    vertex: np.ndarray
    key: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    weight: np.ndarray
    signed: np.ndarray


@dataclass
class SelfContact:
    """Self-contact pairs of the cloth, vertex-triangle and edge-edge alike: the four cloth
    vertices of each pair ``ids (q, 4) int64`` (vertex, triangle corners; or the two edges'
    ends), ``coef (q, 4)`` such that ``sum_k coef_k x_ids_k`` is the vector from the closest
    point of the second primitive to that of the first, unit ``normals (q, 3)`` along it at
    detection, ``distance (q,)`` at detection and the ``kind (q,)`` (0 vertex-triangle, 1
    edge-edge)."""

    ids: np.ndarray
    coef: np.ndarray
    normals: np.ndarray
    distance: np.ndarray
    kind: np.ndarray

    def nearest(self, n: int, default: float) -> np.ndarray:
        """Per cloth vertex ``(n,)``: the smallest distance of a pair it is in, ``default``
        where it is in none."""
        out = np.full(n, float(default))
        for k in range(4):
            np.minimum.at(out, self.ids[:, k], self.distance)
        return out


def _no_pairs() -> SelfContact:
    return SelfContact(np.zeros((0, 4), np.int64), np.zeros((0, 4)), np.zeros((0, 3)),
                       np.zeros(0), np.zeros(0, np.int64))


class BodySurface:
    """The body of one solve, prepared for :meth:`contact` queries (BVH, k-d tree of face
    centroids, face normals).

    Parameters
    ----------
    V : (b, 3) float64 body vertices; F : (c, 3) int64 faces (closed, outward oriented).
    """

    def __init__(self, V: np.ndarray, F: np.ndarray) -> None:
        self.V, self.F = np.asarray(V, np.float64), np.asarray(F, np.int64)
        self.index = SurfaceIndex(self.V, self.F)
        self.fn = face_normals(self.V, self.F)
        tri = self.V[self.F]
        self.cen = tri.mean(1)
        self.radius = float(np.sqrt(((tri - self.cen[:, None]) ** 2).sum(2)).max())
        self.tree = cKDTree(self.cen)
        self._vn: np.ndarray | None = None
        self.topology = _edge_topology(self.F)

    def vertex_normals(self) -> np.ndarray:
        """Angle-weighted vertex normals ``(b, 3)`` (not normalised), computed once."""
        if self._vn is None:
            self._vn = _angle_weighted_normals(self.V, self.F, self.fn)
        return self._vn

    def contact(self, x: np.ndarray, reach: float,
                previous: BodyContact | None = None) -> BodyContact:
        """Contact planes of the cloth vertices ``x (n, 3)`` within ``reach`` of the body,
        plus the closest-point plane of any vertex inside the body (see :class:`BodyContact`).

        Inside or outside is decided by the angle-weighted pseudo-normal of the feature
        (face, edge or vertex; exact for a closed surface, Baerentzen and Aanaes 2005).
        ``previous``: the planes of the last iteration on this body; those not found again
        are kept while their vertex is within ``reach`` of them, so a vertex caught where
        the body intersects itself, whose locally closest features change from one iteration
        to the next, rests against all of them instead of alternating between them.

        A plane's weight is one over the sum of its similarities to the vertex's planes
        (itself included; similarity 1 for parallel normals, falling to 0 at 60 degrees): the
        two faces of a shallow concave edge, which both hold a locally closest point, count
        once together, the two sides of a fold once each.
        """
        V, F = self.V, self.F
        # the BVH's own pick (float32): only the sign of vertices beyond reach depends on it,
        # the planes within reach come from the float64 local features below
        d, p, fid = self.index.query(x, exact_faces=False)
        pn = self._pseudo_normal(fid, barycentric(p, V[F[fid]]))
        inside = np.einsum("ij,ij->i", x - p, pn) < 0
        signed = np.where(inside, -d, d)
        v, key, c, nrm = self._local_features(x, np.flatnonzero(d < reach), reach)
        # a vertex inside the body beyond the detection reach: its closest point's plane
        deep = np.setdiff1d(np.flatnonzero(inside), v)
        v = np.concatenate([v, deep])
        key = np.concatenate([key, np.full(len(deep), -1, np.int64)])
        c = np.concatenate([c, p[deep]])
        nrm = np.concatenate([nrm, pn[deep]])
        fresh = np.ones(len(v), bool)
        if previous is not None and len(previous.vertex):
            old = np.linalg.norm(x[previous.vertex] - previous.points, axis=1) < reach
            v = np.concatenate([v, previous.vertex[old]])
            key = np.concatenate([key, previous.key[old]])
            c = np.concatenate([c, previous.points[old]])
            nrm = np.concatenate([nrm, previous.normals[old]])
            fresh = np.concatenate([fresh, np.zeros(int(old.sum()), bool)])
        if not len(v):
            z = np.zeros((0, 3))
            return BodyContact(v, key, z, z, np.zeros(0), signed)
        # one plane per (vertex, feature): the fresh one first
        order = np.lexsort((~fresh, key, v))
        v, key, c, nrm, fresh = v[order], key[order], c[order], nrm[order], fresh[order]
        first = np.concatenate([[True], (v[1:] != v[:-1]) | (key[1:] != key[:-1])])
        v, key, c, nrm, fresh = v[first], key[first], c[first], nrm[first], fresh[first]
        # weight 1 / (sum of the similarities of the vertex's planes to this one), where
        # similarity is 1 for parallel normals and 0 beyond 60 degrees: symmetric, so it
        # does not change with which plane happens to be nearest
        crowd = np.ones(len(v))
        for k in range(1, len(v)):
            same = np.flatnonzero(v[k:] == v[:-k])
            if not len(same):
                break
            sim = np.clip((np.einsum("ij,ij->i", nrm[same], nrm[same + k]) - 0.5) / 0.4, 0.0, 1.0)
            crowd[same] += sim
            crowd[same + k] += sim
        w = 1.0 / crowd
        keep = w > 0
        return BodyContact(v[keep], key[keep], c[keep], nrm[keep], w[keep], signed)

    def _local_features(self, x: np.ndarray, rows: np.ndarray, reach: float):
        """``(vertex (q,), feature key (q,), point (q, 3), outward normal (q, 3))`` of every
        locally closest body feature within ``reach`` of the cloth vertices ``rows``."""
        empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3)))
        if not len(rows):
            return empty
        dm = cKDTree(x[rows]).sparse_distance_matrix(self.tree, reach + self.radius,
                                                     output_type="ndarray")
        v, f = rows[dm["i"].astype(np.int64)], dm["j"].astype(np.int64)
        tri = self.V[self.F[f]]
        c = closest_point_on_triangles(x[v], tri[:, 0], tri[:, 1], tri[:, 2])
        diff = x[v] - c
        d = np.sqrt(np.einsum("ij,ij->i", diff, diff))
        near = d < reach
        v, f, c, d = v[near], f[near], c[near], d[near]
        if not len(v):
            return empty
        bary = barycentric(c, self.V[self.F[f]])
        on = bary > 1e-9
        count = on.sum(1)
        fe = self.topology[0]
        m, ne = len(self.F), int(fe.max()) + 1
        corner = self.F[f, np.argmax(bary, axis=1)]
        # feature key: face (interior), edge (on one edge) or body vertex (at a corner)
        edge = fe[f, (np.argmin(on, axis=1) + 1) % 3]
        key = np.where(count == 3, f, np.where(count == 2, m + edge, m + ne + corner))
        # a feature is locally closest when every face around it finds it (edge: 2 faces;
        # body vertex: its valence); the interior of a face always is
        need = np.where(count == 3, 1, np.where(count == 2, 2, self._valence()[corner]))
        pair = v * (m + ne + len(self.V)) + key
        order = np.lexsort((f, pair))
        pair, v, f, c, need = pair[order], v[order], f[order], c[order], need[order]
        first = np.concatenate([[True], pair[1:] != pair[:-1]])
        start = np.flatnonzero(first)
        found = np.diff(np.concatenate([start, [len(pair)]]))
        keep = start[found >= need[start]]
        v, f, c, key = v[keep], f[keep], c[keep], pair[keep] - v[keep] * (m + ne + len(self.V))
        return v, key, c, self._pseudo_normal(f, barycentric(c, self.V[self.F[f]]))

    def _valence(self) -> np.ndarray:
        """Number of faces around every body vertex ``(b,)``."""
        if getattr(self, "_val", None) is None:
            self._val = np.bincount(self.F.ravel(), minlength=len(self.V))
        return self._val

    def _pseudo_normal(self, fid: np.ndarray, bary: np.ndarray) -> np.ndarray:
        """Angle-weighted pseudo-normals ``(q, 3)`` of the closest features (faces ``fid``,
        barycentric ``bary`` of the closest points)."""
        fn, F = self.fn, self.F
        fe, ef = self.topology
        out = fn[fid].copy()
        on = bary > 1e-9
        count = on.sum(1)
        edge = np.flatnonzero(count == 2)
        if len(edge):
            local = (np.argmin(on[edge], axis=1) + 1) % 3  # the edge opposite the zero corner
            e = fe[fid[edge], local]
            out[edge] = fn[ef[e, 0]] + fn[ef[e, 1]]
        corner = np.flatnonzero(count <= 1)
        if len(corner):
            out[corner] = self.vertex_normals()[F[fid[corner], np.argmax(bary[corner], axis=1)]]
        return out / np.maximum(np.linalg.norm(out, axis=1), 1e-300)[:, None]


_EDGE_FACES: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def _edge_topology(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(fe (m, 3), ef (e, 2))``: edge id of each face's local edge ``k`` (corners ``k``,
    ``k + 1``) and the two faces of each edge (closed manifold surface), cached by faces."""
    key = hashlib.blake2b(np.ascontiguousarray(F).tobytes(), digest_size=16).digest()
    if key not in _EDGE_FACES:
        m = len(F)
        he = np.sort(np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
        _, fe, counts = np.unique(he, axis=0, return_inverse=True, return_counts=True)
        fe = fe.reshape(m, 3)
        order = np.argsort(fe.ravel(), kind="stable")
        faces = np.repeat(np.arange(m), 3)[order]
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        second = np.minimum(first + 1, len(order) - 1)
        if len(_EDGE_FACES) >= 4:
            _EDGE_FACES.pop(next(iter(_EDGE_FACES)))
        _EDGE_FACES[key] = (fe, np.stack([faces[first], faces[second]], axis=1))
    return _EDGE_FACES[key]


def _angle_weighted_normals(V: np.ndarray, F: np.ndarray, fn: np.ndarray) -> np.ndarray:
    """Vertex normals ``(n, 3)`` weighted by the incident corner angles (not normalised)."""
    out = np.zeros((len(V), 3))
    for k in range(3):
        a, b, c = V[F[:, k]], V[F[:, (k + 1) % 3]], V[F[:, (k + 2) % 3]]
        u, w = b - a, c - a
        cos = np.einsum("ij,ij->i", u, w) / np.maximum(
            np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1), 1e-300)
        ang = np.arccos(np.clip(cos, -1.0, 1.0))
        for c3 in range(3):
            out[:, c3] += np.bincount(F[:, k], weights=ang * fn[:, c3], minlength=len(V))
    return out


def _rest_close(rest_V: np.ndarray, a: np.ndarray, b: np.ndarray, gap: float) -> np.ndarray:
    """Whether cloth vertices ``a`` and ``b`` (rows) are closer than ``gap`` in the rest shape."""
    d = rest_V[a] - rest_V[b]
    return np.einsum("ij,ij->i", d, d) < gap * gap


def self_contacts(x: np.ndarray, faces: np.ndarray, rest_V: np.ndarray, rest_gap: float,
                  radius: float, cloth_edges: np.ndarray | None = None) -> SelfContact:
    """Vertex-triangle and edge-edge pairs of the cloth ``x (n, 3)``, ``faces (m, 3)``
    closer than ``radius`` (metres), without pairs of which two vertices are closer than
    ``rest_gap`` in the rest shape ``rest_V (n, 3)`` (neighbours on the cloth; a fold two
    rings wide is still a contact); ``cloth_edges (e, 2)``: the edges to pair (default: those
    of ``faces``). Edge-edge pairs of nearly parallel edges are left to the vertex-triangle
    pairs."""
    F = np.asarray(faces, np.int64)
    R = np.asarray(rest_V, np.float64)
    vt = _vertex_triangle(x, F, R, rest_gap, radius)
    E = edges(F) if cloth_edges is None else np.asarray(cloth_edges, np.int64)
    ee = _edge_edge(x, E, R, rest_gap, radius)
    out = SelfContact(*(np.concatenate([getattr(vt, k), getattr(ee, k)]) for k in (
        "ids", "coef", "normals", "distance", "kind")))
    return out


def _vertex_triangle(x, F, R, gap, radius) -> SelfContact:
    tri = x[F]
    cen = tri.mean(1)
    reach = radius + float(np.sqrt(((tri - cen[:, None]) ** 2).sum(2)).max())
    dm = cKDTree(x).sparse_distance_matrix(cKDTree(cen), reach, output_type="ndarray")
    v, f = dm["i"].astype(np.int64), dm["j"].astype(np.int64)
    keep = ~(_rest_close(R, v, F[f, 0], gap) | _rest_close(R, v, F[f, 1], gap)
             | _rest_close(R, v, F[f, 2], gap))
    v, f = v[keep], f[keep]
    if not len(v):
        return _no_pairs()
    c = closest_point_on_triangles(x[v], tri[f, 0], tri[f, 1], tri[f, 2])
    diff = x[v] - c
    d = np.sqrt(np.einsum("ij,ij->i", diff, diff))
    near = d < radius
    v, f, c, diff, d = v[near], f[near], c[near], diff[near], d[near]
    if not len(v):
        return _no_pairs()
    order = np.lexsort((f, v))
    v, f, c, diff, d = v[order], f[order], c[order], diff[order], d[order]
    bary = barycentric(c, tri[f])
    fn = face_normals(x, F)[f]
    side = np.sign(np.einsum("ij,ij->i", diff, fn))
    nrm = np.where((d > 1e-9)[:, None], diff / np.maximum(d, 1e-12)[:, None],
                   fn * np.where(side == 0, 1.0, side)[:, None])
    ids = np.concatenate([v[:, None], F[f]], axis=1)
    coef = np.concatenate([np.ones((len(v), 1)), -bary], axis=1)
    return SelfContact(ids, coef, nrm, d, np.zeros(len(v), np.int64))


def _edge_edge(x, E, R, gap, radius) -> SelfContact:
    a, b = x[E[:, 0]], x[E[:, 1]]
    mid = 0.5 * (a + b)
    half = float(np.linalg.norm(b - a, axis=1).max()) * 0.5
    P = cKDTree(mid).query_pairs(radius + 2.0 * half, output_type="ndarray")
    if not len(P):
        return _no_pairs()
    i, j = P[:, 0].astype(np.int64), P[:, 1].astype(np.int64)
    bad = np.zeros(len(i), bool)
    for p in range(2):
        for q in range(2):
            bad |= _rest_close(R, E[i, p], E[j, q], gap)
    i, j = i[~bad], j[~bad]
    if not len(i):
        return _no_pairs()
    s, t, ok = _segment_params(a[i], b[i], a[j], b[j])
    pa = a[i] + s[:, None] * (b[i] - a[i])
    pb = a[j] + t[:, None] * (b[j] - a[j])
    diff = pa - pb
    d = np.sqrt(np.einsum("ij,ij->i", diff, diff))
    # interior of both edges (an end's contact is a vertex-triangle pair's), not parallel
    keep = ok & (d < radius) & (d > 1e-9) & (s > 1e-6) & (s < 1 - 1e-6) & (t > 1e-6) \
        & (t < 1 - 1e-6)
    i, j, s, t, diff, d = i[keep], j[keep], s[keep], t[keep], diff[keep], d[keep]
    if not len(i):
        return _no_pairs()
    order = np.lexsort((j, i))
    i, j, s, t, diff, d = i[order], j[order], s[order], t[order], diff[order], d[order]
    ids = np.stack([E[i, 0], E[i, 1], E[j, 0], E[j, 1]], axis=1)
    coef = np.stack([1.0 - s, s, -(1.0 - t), -t], axis=1)
    return SelfContact(ids, coef, diff / d[:, None], d, np.ones(len(i), np.int64))


def _segment_params(p0, p1, q0, q1):
    """Parameters ``(s, t, ok)`` of the closest points of segments ``p0 p1`` and ``q0 q1``
    (rows); ``ok`` is False for nearly parallel segments."""
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("ij,ij->i", u, u)
    b = np.einsum("ij,ij->i", u, v)
    c = np.einsum("ij,ij->i", v, v)
    d = np.einsum("ij,ij->i", u, w)
    e = np.einsum("ij,ij->i", v, w)
    den = a * c - b * b
    ok = den > 1e-6 * a * c
    s = np.clip(np.where(ok, (b * e - c * d) / np.where(ok, den, 1.0), 0.0), 0.0, 1.0)
    t = np.clip((b * s + e) / np.maximum(c, 1e-30), 0.0, 1.0)
    s = np.clip((b * t - d) / np.maximum(a, 1e-30), 0.0, 1.0)
    return s, t, ok
