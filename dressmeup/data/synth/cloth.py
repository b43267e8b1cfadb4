"""Quasi-static cloth with body contact and self-contact, solved to a tolerance (generator 3.x).

One solve finds a local minimum, near the start, of

    E(x) = stretch + bending + gravity + body contact + anchors + self-contact,

- stretch: edge springs ``0.5 Y A_e ((|e| - L_e) / L_e)^2`` (membrane stiffness ``Y`` in N/m,
  ``A_e`` the area share of edge ``e``, ``L_e`` its rest length);
- bending: the same on the hinge edges joining the opposite corners of adjacent triangles,
  stiffness ``bending_ratio * Y``;
- gravity: ``sum_i m_i g h_i`` (areal density times vertex area, ``h`` the height);
- body contact: a one-sided quadratic penalty keeping every vertex ``body_margin`` outside
  the body, one plane per body feature (face, edge or vertex) locally closest to the vertex
  (both sides where the body folds onto itself), re-linearised at every iteration and kept
  for the rest of the solve while the vertex stays near
  (:class:`dressmeup.data.synth.contact.BodySurface`);
- anchors: where the garment rests on the body (waistband, shoulders), a spring to a point
  fixed on the body surface (face and barycentric coordinates, plus the offset along its
  normal) that the body carries along when it changes: an elastic band's grip, not a target
  taken from the garment;
- self-contact: a one-sided quadratic penalty keeping each vertex ``self_thickness`` away
  from the cloth's triangles and each edge that far from the other edges, for every pair
  closer than ``self_detect`` whose primitives share no vertex (vertex-triangle and
  edge-edge pairs found by k-d trees and measured exactly, re-linearised at every
  iteration: :func:`dressmeup.data.synth.contact.self_contacts`).

The minimum is found by a projected Newton method (each spring's Hessian made positive
semi-definite by dropping its compressive transverse part; the direction by three conjugate
gradient iterations preconditioned by a sparse LU factorisation, refreshed at the start, after
a cut-back step and every ``refactor_every`` iterations; backtracking line search). Every
iteration moves no vertex further than 0.45 times its distance to the nearest self-contact
pair it is in (``self_detect`` when none is tracked), so two layers of cloth cannot pass
through each other between two detections (the bound of Vertex Block Descent's
divide-and-truncate, Chen et al. 2024), and none further than ``max_move``. The solve stops
when the residual force (RMS over vertices, relative to the mean vertex weight) is below
``tolerance``; or when the energy has changed by less than ``energy_tolerance`` per iteration
over the last ``plateau_window`` iterations with a residual below ``plateau_grad`` (the
contacts' re-linearisation leaves a residual floor); or after ``max_iterations``.

All arithmetic is float64 numpy/scipy without BLAS-3 calls of torch or MKL: elementwise
operations, sums, sparse products and SuperLU, so the numbers do not depend on MKL's code
branch (docs/synthetic-data.md, "Reproducibility").
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from dressmeup.data.synth.contact import (
    BodyContact,
    BodySurface,
    SelfContact,
    self_contacts,
)
from dressmeup.geometry.mesh import edges, face_areas


@dataclass(frozen=True)
class ClothSettings:
    """Material, contact and solver settings of :func:`solve` (SI units)."""

    youngs: float = 200.0  # membrane stretch stiffness, N/m
    bending_ratio: float = 0.02  # hinge stiffness relative to stretch
    density: float = 0.15  # kg/m^2
    gravity: float = 9.81  # m/s^2
    body_stiffness: float = 5.0e5  # N/m^3 (per unit area)
    body_margin: float = 0.005  # m, body contact starts this far outside the body
    body_track: float = 0.005  # m, body features this much further away are tracked too
    anchor_stiffness: float = 2.0e4  # N/m^3 (per unit area)
    self_stiffness: float = 2.0e5  # N/m^3 (per unit area)
    self_thickness: float = 0.004  # m, cloth layers are kept this far apart
    self_detect: float = 0.016  # m, vertex-triangle pairs closer than this are tracked
    max_move: float = 0.02  # m, largest vertex move of one iteration
    tolerance: float = 1e-3  # residual force (RMS / mean vertex weight) that ends a solve
    # ... or an energy that changes by less than this per iteration (units of total weight x
    # 1 cm; range over the last plateau_window + 1 iterations): the contacts'
    # re-linearisation leaves a residual of about 0.1 mean vertex weights in places, which no
    # iteration removes
    energy_tolerance: float = 1e-5
    plateau_window: int = 5
    plateau_grad: float = 0.1  # ... as long as the residual is below this
    max_iterations: int = 300
    refactor_every: int = 10  # iterations between two factorisations of the Hessian

    def to_dict(self) -> dict:
        """The settings as a JSON-able dict."""
        return asdict(self)


def hinge_pairs(F: np.ndarray) -> np.ndarray:
    """Opposite-corner vertex pairs ``(h, 2) int64`` of every interior edge of ``F``."""
    F = np.asarray(F, np.int64)
    he = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    opp = np.concatenate([F[:, 2], F[:, 0], F[:, 1]])
    key = np.sort(he, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    k = key[order]
    i = np.flatnonzero(np.all(k[1:] == k[:-1], axis=1))
    return np.stack([opp[order[i]], opp[order[i + 1]]], axis=1)


def vertex_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Area share ``(n,) float64`` of every vertex (a third of each incident face's area)."""
    a = face_areas(V, F) / 3.0
    return np.bincount(np.asarray(F, np.int64).ravel(), weights=np.repeat(a, 3),
                       minlength=len(V))


class ClothModel:
    """A garment's cloth: rest geometry, springs, masses and the Hessian's block pattern.

    Parameters
    ----------
    rest_V : (n, 3) float64 rest shape (defines rest lengths and areas).
    faces : (m, 3) int64.
    settings : material and solver settings.
    """

    def __init__(self, rest_V: np.ndarray, faces: np.ndarray,
                 settings: ClothSettings | None = None) -> None:
        s = self.settings = settings or ClothSettings()
        self.rest_V = np.asarray(rest_V, np.float64)
        self.faces = np.asarray(faces, np.int64)
        self.n = n = len(self.rest_V)
        E, H = edges(self.faces), hinge_pairs(self.faces)
        self.area = vertex_areas(self.rest_V, self.faces)
        self.mass = s.density * self.area
        self.springs = np.concatenate([E, H])
        L = np.linalg.norm(self.rest_V[self.springs[:, 1]] - self.rest_V[self.springs[:, 0]],
                           axis=1)
        # a hinge whose opposite corners coincide (a remeshing artefact) has no rest length
        ok = L > 1e-9
        if not ok.all():
            n_e = len(E)
            E, H = E[ok[:n_e]], H[ok[n_e:]]
            self.springs, L = self.springs[ok], L[ok]
        A = 0.5 * (self.area[self.springs[:, 0]] + self.area[self.springs[:, 1]])
        ratio = np.concatenate([np.ones(len(E)), np.full(len(H), s.bending_ratio)])
        self.rest_len = L
        self.spring_k = s.youngs * ratio * A / (L * L)  # E = 0.5 k (l - L)^2
        self.n_stretch = len(E)
        # energies in units of (total weight x 1 cm): O(1) numbers for the line search
        self.scale = 1.0 / max(self.mass.sum() * s.gravity * 0.01, 1e-12)
        self.weight_mean = float(self.mass.mean() * s.gravity)
        # self-contact leaves out pairs of vertices closer than one mean edge at rest
        self.rest_gap = float(L[: len(E)].mean())
        # block pattern: diagonal + both directions of every spring
        i = np.concatenate([np.arange(n), self.springs[:, 0], self.springs[:, 1]])
        j = np.concatenate([np.arange(n), self.springs[:, 1], self.springs[:, 0]])
        pat = sp.csr_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
        pat.sum_duplicates()
        pat.sort_indices()
        self._indptr, self._indices = pat.indptr, pat.indices
        self._diag_pos = self._pos(np.arange(n), np.arange(n))
        self._ab = self._pos(self.springs[:, 0], self.springs[:, 1])
        self._ba = self._pos(self.springs[:, 1], self.springs[:, 0])

    def _pos(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Index of block ``(i, j)`` in the pattern's CSR order."""
        rows = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(self._indptr))
        keys = rows * self.n + self._indices
        return np.searchsorted(keys, np.asarray(i, np.int64) * self.n + j)


@dataclass
class Loads:
    """What the body does to the cloth in one solve.

    Attributes
    ----------
    body_V : (b, 3) float64 body surface; body_F : (c, 3) int64.
    anchor_points : (n, 3) float64 anchor positions on the body (rows of unanchored vertices
        are ignored); anchor_weight : (n,) float64 in [0, 1].
    up : (3,) unit vector opposite to gravity.
    """

    body_V: np.ndarray
    body_F: np.ndarray
    anchor_points: np.ndarray
    anchor_weight: np.ndarray
    up: np.ndarray


@dataclass
class SolveResult:
    """Vertices ``(n, 3) float64`` of the solve and its statistics (``iterations``,
    ``energy``, ``grad_norm``, ``grad_max``, ``converged``)."""

    vertices: np.ndarray
    stats: dict


def spring_terms(model: ClothModel, x: np.ndarray):
    """Energy, gradient ``(n, 3)`` and Hessian blocks ``(s, 3, 3)`` of the springs."""
    P = model.springs
    d = x[P[:, 1]] - x[P[:, 0]]
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    u = d / np.maximum(length, 1e-12)[:, None]
    stretch = length - model.rest_len
    k = model.spring_k
    energy = 0.5 * np.sum(k * stretch * stretch)
    f = (k * stretch)[:, None] * u
    grad = np.zeros_like(x)
    for c in range(3):
        grad[:, c] = (np.bincount(P[:, 1], weights=f[:, c], minlength=model.n)
                      - np.bincount(P[:, 0], weights=f[:, c], minlength=model.n))
    uu = u[:, :, None] * u[:, None, :]
    t = np.clip(1.0 - model.rest_len / np.maximum(length, 1e-12), 0.0, None)
    K = k[:, None, None] * (uu + t[:, None, None] * (np.eye(3) - uu))
    return energy, grad, K


class _Linearized:
    """The energy with the contacts of one iteration frozen (exact for the springs)."""

    def __init__(self, model: ClothModel, loads: Loads, body: BodyContact,
                 pairs: SelfContact) -> None:
        self.m, self.loads, self.body, self.pairs = model, loads, body, pairs
        s = model.settings
        self.g_up = (model.mass * s.gravity)[:, None] * loads.up[None, :]
        self.wb = s.body_stiffness * model.area
        self.wa = s.anchor_stiffness * model.area * loads.anchor_weight
        self.ws = (s.self_stiffness * model.area[pairs.ids].mean(1) if len(pairs.ids)
                   else None)

    def energy(self, x: np.ndarray) -> float:
        s = self.m.settings
        e = self._spring_energy(x)
        e += np.sum(self.g_up * x)
        pen = self._body_pen(x)
        e += 0.5 * np.sum(self.wb[self.body.vertex] * self.body.weight * pen * pen)
        da = x - self.loads.anchor_points
        e += 0.5 * np.sum(self.wa * np.einsum("ij,ij->i", da, da))
        if self.ws is not None:
            pen = np.clip(s.self_thickness - self._self_gap(x), 0.0, None)
            e += 0.5 * np.sum(self.ws * pen * pen)
        return float(e * self.m.scale)

    def _body_pen(self, x):
        """Penetration ``(q,)`` of the margin of each contact plane."""
        b = self.body
        gap = np.einsum("ij,ij->i", x[b.vertex] - b.points, b.normals)
        return np.clip(self.m.settings.body_margin - gap, 0.0, None)

    def _spring_energy(self, x):
        P = self.m.springs
        d = x[P[:, 1]] - x[P[:, 0]]
        stretch = np.sqrt(np.einsum("ij,ij->i", d, d)) - self.m.rest_len
        return 0.5 * np.sum(self.m.spring_k * stretch * stretch)

    def _self_gap(self, x):
        p = self.pairs
        return np.einsum("ij,ij->i", np.einsum("pk,pkd->pd", p.coef, x[p.ids]), p.normals)

    def gradient_hessian(self, x: np.ndarray):
        """(energy, gradient (n, 3), sparse Hessian (3n, 3n) csc), all scaled."""
        m, s = self.m, self.m.settings
        n = m.n
        e, grad, K = spring_terms(m, x)
        blocks = np.zeros((len(m._indices), 3, 3))
        for pos, sign in ((m._ab, -1.0), (m._ba, -1.0)):
            for a in range(3):
                for b in range(3):
                    blocks[:, a, b] += np.bincount(pos, weights=sign * K[:, a, b],
                                                   minlength=len(blocks))
        diag = np.zeros((n, 3, 3))
        P = m.springs
        for a in range(3):
            for b in range(3):
                diag[:, a, b] = (np.bincount(P[:, 0], weights=K[:, a, b], minlength=n)
                                 + np.bincount(P[:, 1], weights=K[:, a, b], minlength=n))
        e += np.sum(self.g_up * x)
        grad = grad + self.g_up
        # body contact
        bv, nb = self.body.vertex, self.body.normals
        pen = self._body_pen(x)
        w = self.wb[bv] * self.body.weight
        e += 0.5 * np.sum(w * pen * pen)
        f = (w * pen)[:, None] * nb
        nn = (w * (pen > 0))[:, None, None] * nb[:, :, None] * nb[:, None, :]
        for a in range(3):
            grad[:, a] -= np.bincount(bv, weights=f[:, a], minlength=n)
            for b in range(3):
                diag[:, a, b] += np.bincount(bv, weights=nn[:, a, b], minlength=n)
        # anchors
        da = x - self.loads.anchor_points
        e += 0.5 * np.sum(self.wa * np.einsum("ij,ij->i", da, da))
        grad += self.wa[:, None] * da
        diag += self.wa[:, None, None] * np.eye(3)
        blocks[m._diag_pos] += diag
        H = sp.bsr_matrix((blocks, m._indices, m._indptr), shape=(3 * n, 3 * n))
        if self.ws is not None:
            p = self.pairs
            pen = np.clip(s.self_thickness - self._self_gap(x), 0.0, None)
            on = pen > 0
            e += 0.5 * np.sum(self.ws * pen * pen)
            coef, ids = p.coef, p.ids
            f = -(self.ws * pen)[:, None, None] * coef[:, :, None] * p.normals[:, None, :]
            for c in range(3):
                grad[:, c] += np.bincount(ids.ravel(), weights=f[:, :, c].ravel(), minlength=n)
            w = (self.ws * on)
            sel = np.flatnonzero(on)
            if len(sel):
                nn = p.normals[sel, :, None] * p.normals[sel, None, :]
                cc = coef[sel, :, None] * coef[sel, None, :]  # (q, 4, 4)
                vals = w[sel, None, None, None, None] * cc[:, :, :, None, None] * nn[:, None, None]
                rows = np.broadcast_to(ids[sel, :, None], cc.shape)
                cols = np.broadcast_to(ids[sel, None, :], cc.shape)
                r3 = (3 * rows[..., None, None] + np.arange(3)[:, None]).astype(np.int64)
                c3 = (3 * cols[..., None, None] + np.arange(3)[None, :]).astype(np.int64)
                r3, c3 = np.broadcast_arrays(r3, c3)
                H = H + sp.csr_matrix((vals.ravel(), (r3.ravel(), c3.ravel())),
                                      shape=(3 * n, 3 * n))
        return e * m.scale, grad * m.scale, (H * m.scale).tocsc()


def solve(model: ClothModel, start: np.ndarray, loads: Loads, tolerance: float | None = None,
          max_iterations: int | None = None, trace: list | None = None) -> SolveResult:
    """Minimise the cloth energy from ``start`` (see the module docstring).

    Parameters
    ----------
    model : the garment's :class:`ClothModel`.
    start : (n, 3) float64 start vertices (the previous state of the path).
    loads : the body, the anchors and the up direction of this solve.
    tolerance, max_iterations : override the settings' values.

    Returns
    -------
    SolveResult with ``iterations``, ``energy`` (scaled: units of total weight x 1 cm),
    ``grad_norm`` (RMS residual force / mean vertex weight), ``grad_max`` (largest vertex
    residual / mean vertex weight), ``converged`` and ``self_pairs`` (tracked at the end).
    """
    s = model.settings
    tol = s.tolerance if tolerance is None else float(tolerance)
    cap = s.max_iterations if max_iterations is None else int(max_iterations)
    x = np.array(start, np.float64)
    force_unit = model.weight_mean * model.scale
    it, e, gnorm, gmax, npairs = 0, float("nan"), float("inf"), float("inf"), 0
    energies: list[float] = []
    lu, factored, alpha = None, 0, 1.0
    surface = BodySurface(loads.body_V, loads.body_F)
    body = None
    while True:
        body = surface.contact(x, s.body_margin + s.body_track, previous=body)
        pairs = self_contacts(x, model.faces, model.rest_V, model.rest_gap, s.self_detect,
                              model.springs[:model.n_stretch])
        npairs = len(pairs.ids)
        lin = _Linearized(model, loads, body, pairs)
        e, g, H = lin.gradient_hessian(x)
        per_vertex = np.sqrt(np.einsum("ij,ij->i", g, g)) / force_unit
        gnorm, gmax = float(np.sqrt(np.mean(per_vertex ** 2))), float(per_vertex.max())
        energies.append(e)
        window = energies[-1 - s.plateau_window:]
        plateau = (len(energies) > s.plateau_window and gnorm < s.plateau_grad
                   and max(window) - min(window) < s.energy_tolerance * s.plateau_window)
        if gnorm < tol or plateau or it >= cap:
            break
        bound = np.minimum(0.45 * pairs.nearest(model.n, s.self_detect), s.max_move)
        # a fresh factorisation at the start, after a cut-back step, and every few iterations
        fresh = lu is None or alpha < 1.0 or it - factored >= s.refactor_every
        while True:
            if fresh:
                lu, factored = factor(H), it
            d, alpha, cut = _step(lin, x, e, g, H, lu, bound)
            if alpha > 0 or fresh:
                break
            fresh = True  # the old factorisation's direction failed: a fresh one
        x = x + alpha * d
        it += 1
        if trace is not None:
            trace.append((e, gnorm, gmax, alpha, float(cut.min()), len(body.vertex), npairs))
    return SolveResult(x, {"iterations": it, "energy": float(e), "grad_norm": gnorm,
                           "grad_max": gmax, "converged": bool(gnorm < tol or plateau),
                           "energy_change": (float(max(window) - min(window)) / s.plateau_window
                                             if len(energies) > s.plateau_window else None),
                           "self_pairs": npairs})


def _line_search(lin: _Linearized, x: np.ndarray, e: float, g: np.ndarray,
                 d: np.ndarray) -> float | None:
    """Backtracking (Armijo) step length along ``d``; None when ``d`` does not descend."""
    slope = float(np.sum(g * d))
    if not slope < 0:
        return None
    alpha = 1.0
    while alpha > 1e-4:
        if lin.energy(x + alpha * d) <= e + 1e-4 * alpha * slope:
            return alpha
        alpha *= 0.5
    return None


def factor(H: sp.csc_matrix):
    """Sparse LU of ``H`` plus a tiny diagonal shift (free directions stay solvable)."""
    shift = 1e-8 * float(np.abs(H.diagonal()).max())
    return splu((H + sp.identity(H.shape[0], format="csc") * shift).tocsc(),
                permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True})


def _step(lin: _Linearized, x: np.ndarray, e: float, g: np.ndarray, H, lu,
          bound: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """One iteration's move ``(d (n, 3), alpha, cut (n,))``: a Newton direction (three
    conjugate-gradient iterations on ``H`` preconditioned by the factorisation ``lu``, which
    may be of an earlier Hessian), each vertex's move cut to its ``bound``, then a
    backtracking line search; when the cut makes it climb, the whole move is scaled to the
    tightest bound instead. ``alpha`` 0: no descent found."""
    d = pcg(H, -g.ravel(), lu.solve, 3).reshape(-1, 3)
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    cut = np.minimum(1.0, bound / np.maximum(length, 1e-15))
    alpha = _line_search(lin, x, e, g, d * cut[:, None])
    if alpha is not None:  # each vertex's step cut to its own bound
        return d * cut[:, None], alpha, cut
    d = d * float(cut.min())
    return d, _line_search(lin, x, e, g, d) or 0.0, cut


def pcg(A, b: np.ndarray, precondition, iterations: int) -> np.ndarray:
    """``iterations`` of preconditioned conjugate gradients on ``A x = b`` from the
    preconditioned right-hand side (dot products: elementwise products summed by numpy, no
    BLAS call)."""
    x = precondition(b)
    r = b - A @ x
    z = precondition(r)
    p = z
    rz = float(np.sum(r * z))
    for _ in range(iterations):
        Ap = A @ p
        pAp = float(np.sum(p * Ap))
        if not pAp > 0 or not rz > 0:
            break
        alpha = rz / pAp
        x = x + alpha * p
        r = r - alpha * Ap
        z = precondition(r)
        rz_new = float(np.sum(r * z))
        p = z + (rz_new / rz) * p
        rz = rz_new
    return x
