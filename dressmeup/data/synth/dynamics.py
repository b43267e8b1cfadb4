"""Cloth dynamics with barrier contact (generator 4): implicit time steps of a garment
following a moving body, with no penetration of the body or of itself.

Each time step ``h`` from state ``(x, v)`` minimises the incremental potential of backward
Euler with mass-proportional damping ``gamma``,

    Phi(y) = sum_i m_i / 2 (1 / h^2 + gamma / h) |y_i - z_i|^2 + E(y) + kappa B(y),
    z_i = (x_i + h v_i + gamma h x_i) / (1 + gamma h),

so that ``v' = (y - x) / h`` (the inertia term with its target ``x + h v``, and the damping
term pulling towards ``x``, combined into one quadratic). ``E`` is the cloth energy of
generator 3.x (:mod:`dressmeup.data.synth.cloth`: edge and hinge springs, gravity) plus the
anchors that hold the waistband and shoulders to the body (an elastic band's grip,
:class:`dressmeup.data.synth.common.BodyAnchors`); ``B`` is the IPC log barrier
(Li et al. 2020, ``ipctk``) over every pair of cloth-body and cloth-cloth primitives closer
than ``dhat`` (the body does not collide with itself), with ``kappa`` set so that the barrier
pushes with ``barrier_force`` mean vertex weights at ``dhat / 2``.

The minimisation is Newton's method (the springs' Hessian made positive semi-definite, the
barrier's projected by ``ipctk``, a sparse LU factorisation), each step cut to the largest
fraction that is free of collisions by continuous collision detection (ipctk's Tight
Inclusion CCD) and then by a backtracking line search. A step's solve stops when the largest
vertex move of a Newton step, divided by ``h``, is below ``velocity_tolerance`` (IPC's
criterion), or after ``max_iterations`` (recorded as unconverged).

Between two frames the body moves linearly. Before a step's solve, cloth within ``carry`` of
the body is moved with the body's local displacement (weighted by its distance, full at the
surface), and the joint move of body and cloth is checked by CCD; when it collides, the
step is split into shorter sub-steps of the same linear body motion until each is free. So no
state of the simulation has a vertex inside the body or a cloth triangle crossing another:
the absence of penetration holds by construction, up to CCD's tolerance, and is checked at
the end of every motion (:func:`intersection_free`).

All the numerical work of this module is float64 numpy, scipy's SuperLU and ipctk on one
thread; nothing calls BLAS-3 or numpy's transcendental functions, so the numbers do not
depend on the CPU's SIMD code branch.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import ipctk
import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from dressmeup.data.synth.cloth import ClothModel, ClothSettings, factor, pcg, spring_terms
from dressmeup.geometry.proximity import barycentric, closest_points


@dataclass(frozen=True)
class DynamicsSettings:
    """Material, contact and solver settings of :class:`ClothDynamics` (SI units)."""

    youngs: float = 200.0  # membrane stretch stiffness, N/m
    bending_ratio: float = 0.02  # hinge stiffness relative to stretch
    density: float = 0.15  # kg/m^2
    gravity: float = 9.81  # m/s^2
    damping: float = 2.0  # 1/s, mass-proportional
    anchor_stiffness: float = 2.0e4  # N/m^3 (per unit area)
    dhat: float = 0.003  # m, barrier activation distance
    barrier_force: float = 10.0  # barrier force at dhat / 2, in mean vertex weights
    tolerance: float = 1e-6  # m, a step's solve ends when Newton's predicted decrease is
    # below lifting every vertex by this much
    max_iterations: int = 40  # Newton iterations of one step's solve
    refactor_every: int = 8  # iterations between two factorisations of the Hessian
    carry_full: float = 0.02  # m, cloth this close to the body moves with it before a solve
    carry: float = 0.06  # m, ... and from carry_full to here less and less
    carry_blend: float = 0.06  # m, the carry averaged over cloth this close (0: not)
    crop: float = 0.05  # m, body faces this far from the cloth take part in a frame
    pinch: float = 0.01  # m, body faces where two body parts came this close leave the
    # contact (0: none) ...
    pinch_rest: float = 0.05  # m, ... parts whose vertices are this far apart at rest
    min_substep: float = 1.0 / 256.0  # smallest sub-step, as a fraction of a frame
    substep_budget: float = 6.0  # sub-steps a frame on average over a motion, at most
    # (simulate; a motion over it fails)

    def to_dict(self) -> dict:
        """The settings as a JSON-able dict."""
        return asdict(self)

    def cloth(self) -> ClothSettings:
        """The springs' and gravity's settings as :class:`ClothSettings`."""
        return ClothSettings(youngs=self.youngs, bending_ratio=self.bending_ratio,
                             density=self.density, gravity=self.gravity)


#: the narrow phase of every CCD query: Tight Inclusion with ipctk's tolerance and rescaling,
#: its iterations bounded (a bounded query returns a smaller, still collision-free step;
#: the default 10^7 took tens of seconds on a sheet landing parallel to a box's face)
_CCD = ipctk.TightInclusionCCD(tolerance=1e-6, max_iterations=100_000)


class Scene:
    """The collision mesh of one frame: the cloth (vertices ``0 .. n-1``) and the body faces
    with a point within ``crop`` of a cloth vertex in any of the frame's bodies (the body does
    not collide with itself).

    Parameters
    ----------
    model : the garment's :class:`ClothModel`.
    body_F : (c, 3) int64 all body faces.
    body_Vs : body surfaces ``(b, 3)`` the frame moves between.
    x : (n, 3) float64 the cloth at the frame's start.
    crop : m.
    pinch : optional ``(rest_V (b, 3), pinch, pinch_rest)``: body faces with a vertex within
        ``pinch`` of a vertex ``pinch_rest`` or more away from it on the rest body ``rest_V``
        (two body parts pressed together by the pose: an arm against the chest, the thighs
        of a sitting body) are left out, in any of the frame's bodies. Cloth caught there
        cannot be held off both parts by any contact force (the body is kinematic): it may
        enter the body there, and the plausibility figures count it.
    """

    def __init__(self, model: ClothModel, body_F: np.ndarray, body_Vs: list[np.ndarray],
                 x: np.ndarray, crop: float, pinch: tuple | None = None) -> None:
        n = model.n
        tree = cKDTree(x)
        keep = np.zeros(len(body_F), bool)
        for V in body_Vs:
            # a face with a point within crop of a cloth vertex has its centroid within
            # crop + (its largest corner distance from the centroid) of that vertex
            tri = V[body_F]
            centre = tri.mean(axis=1)
            radius = np.sqrt(np.max(np.sum((tri - centre[:, None]) ** 2, axis=2), axis=1))
            keep |= tree.query(centre)[0] <= crop + radius
        if pinch is not None:
            keep &= ~pinched(body_F, keep, body_Vs, *pinch)[body_F].any(axis=1)
        faces = body_F[keep]
        self.body_vertices = np.unique(faces)
        remap = np.full(len(body_Vs[0]), -1, np.int64)
        remap[self.body_vertices] = np.arange(len(self.body_vertices))
        faces_all = np.vstack([model.faces, remap[faces] + n]).astype(np.int32)
        rest = np.vstack([model.rest_V, body_Vs[0][self.body_vertices]])
        self.mesh = ipctk.CollisionMesh(rest, ipctk.edges(faces_all), faces_all)
        self.mesh.can_collide = ipctk.make_static_obstacle_filter(n)
        self.n = n

    def stack(self, y: np.ndarray, body_V: np.ndarray) -> np.ndarray:
        """Vertices ``(n + k, 3)`` of the collision mesh: cloth ``y``, then the body's."""
        return np.vstack([y, body_V[self.body_vertices]])

    def collisions(self, y: np.ndarray, body_V: np.ndarray, dhat: float):
        """ipctk's set of primitive pairs closer than ``dhat``."""
        col = ipctk.NormalCollisions()
        col.build(self.mesh, self.stack(y, body_V), dhat)
        return col

    def free_fraction(self, y0, body0, y1, body1) -> float:
        """Largest fraction in [0, 1] of the linear move from ``(y0, body0)`` to ``(y1,
        body1)`` that is free of collisions (ipctk's CCD)."""
        return float(ipctk.compute_collision_free_stepsize(
            self.mesh, self.stack(y0, body0), self.stack(y1, body1),
            narrow_phase_ccd=_CCD))


def pinched(body_F: np.ndarray, keep: np.ndarray, body_Vs: list[np.ndarray],
            rest_V: np.ndarray, pinch: float, pinch_rest: float) -> np.ndarray:
    """(b,) bool: body vertices of the faces ``keep`` that are within ``pinch`` (m) of another
    such vertex in one of ``body_Vs`` while ``pinch_rest`` (m) or more from it in ``rest_V``
    (see :class:`Scene`)."""
    out = np.zeros(len(rest_V), bool)
    cand = np.unique(body_F[keep])
    if len(cand) < 2 or pinch <= 0:
        return out
    for V in body_Vs:
        pairs = cKDTree(V[cand]).query_pairs(pinch, output_type="ndarray")
        if len(pairs):
            a, b = cand[pairs[:, 0]], cand[pairs[:, 1]]
            far = np.sum((rest_V[a] - rest_V[b]) ** 2, axis=1) >= pinch_rest * pinch_rest
            out[a[far]] = True
            out[b[far]] = True
    return out


class SubstepsExceeded(RuntimeError):
    """A frame that needs more sub-steps than it was allowed (``substeps``: the count at the
    sub-step over the limit)."""

    def __init__(self, substeps: int) -> None:
        super().__init__(f"{substeps} sub-steps")
        self.substeps = substeps


class ClothDynamics:
    """One garment simulated in time against a moving body of fixed topology.

    Parameters
    ----------
    rest_V : (n, 3) float64 the garment as designed (rest lengths and areas).
    faces : (m, 3) int64 garment faces.
    body_F : (c, 3) int64 faces of the body (the same for every frame).
    up : (3,) unit vector opposite to gravity.
    settings : :class:`DynamicsSettings`.
    anchor_weight : (n,) float64 in [0, 1] per-vertex anchor strength (None: no anchors).
    body_rest : (b, 3) float64 the body at rest, for the pinch rule of :class:`Scene`
        (None: no face is left out for a pinch).
    """

    def __init__(self, rest_V: np.ndarray, faces: np.ndarray, body_F: np.ndarray,
                 up: np.ndarray, settings: DynamicsSettings | None = None,
                 anchor_weight: np.ndarray | None = None,
                 body_rest: np.ndarray | None = None) -> None:
        s = self.settings = settings or DynamicsSettings()
        self.body_rest = None if body_rest is None else np.asarray(body_rest, np.float64)
        self.model = ClothModel(rest_V, faces, s.cloth())
        m = self.model
        self.n = n = m.n
        self.body_F = np.asarray(body_F, np.int64)
        up = np.asarray(up, np.float64)
        self.up = up / np.sqrt(np.sum(up * up))
        self.gravity = (m.mass * s.gravity)[:, None] * self.up[None, :]
        w = np.zeros(n) if anchor_weight is None else np.asarray(anchor_weight, np.float64)
        self.anchor_k = s.anchor_stiffness * m.area * w
        # kappa: the barrier's force at dhat / 2 equals barrier_force mean vertex weights
        # (ipctk's barrier is a function of squared distances: d/dd b(d^2) = 2 d b'(d^2))
        half = 0.5 * s.dhat
        slope = abs(ipctk.barrier_first_derivative(half * half, s.dhat * s.dhat)) * 2 * half
        self.kappa = s.barrier_force * m.weight_mean / slope
        self.barrier = ipctk.BarrierPotential(s.dhat, self.kappa)
        # Hessian pattern of the springs: (a, a), (b, b), (a, b), (b, a) blocks of each
        P = m.springs
        blk_r = np.concatenate([P[:, 0], P[:, 1], P[:, 0], P[:, 1]])
        blk_c = np.concatenate([P[:, 0], P[:, 1], P[:, 1], P[:, 0]])
        r = 3 * blk_r[:, None, None] + np.arange(3)[None, :, None]
        c = 3 * blk_c[:, None, None] + np.arange(3)[None, None, :]
        r, c = np.broadcast_arrays(r, c)
        diag = np.arange(3 * n)
        self._rows = np.concatenate([r.ravel(), diag])
        self._cols = np.concatenate([c.ravel(), diag])
        self._sign = np.concatenate([np.ones(2 * len(P)), -np.ones(2 * len(P))])
        # body vertices this close to a cloth vertex can bulge into its triangles
        self.reach = 1.5 * float(np.max(m.rest_len[: m.n_stretch]))
        self._tree, self._tree_of = None, None

    def scene(self, x: np.ndarray, body_Vs: list[np.ndarray]) -> Scene:
        """The collision mesh of a frame moving between the bodies ``body_Vs``."""
        s = self.settings
        pinch = (None if self.body_rest is None or s.pinch <= 0
                 else (self.body_rest, s.pinch, s.pinch_rest))
        return Scene(self.model, self.body_F, body_Vs, x, s.crop, pinch)

    # ------------------------------------------------------------------ energy
    def _smooth_energy(self, y, c, z, anchors):
        """Inertia, springs, gravity and anchors at ``y`` (J)."""
        d = y - z
        e = 0.5 * np.sum(c[:, None] * d * d)
        P = self.model.springs
        dd = y[P[:, 1]] - y[P[:, 0]]
        stretch = np.sqrt(np.einsum("ij,ij->i", dd, dd)) - self.model.rest_len
        e += 0.5 * np.sum(self.model.spring_k * stretch * stretch)
        e += np.sum(self.gravity * y)
        if anchors is not None:
            da = y - anchors
            e += 0.5 * np.sum(self.anchor_k[:, None] * da * da)
        return float(e)

    def energy(self, scene: Scene, y, body_V, c, z, anchors):
        """``(Phi(y) (J), the collision set at y)`` of a collision-free ``y``."""
        col = scene.collisions(y, body_V, self.settings.dhat)
        return self._smooth_energy(y, c, z, anchors) + float(
            self.barrier(col, scene.mesh, scene.stack(y, body_V))), col

    def smooth_system(self, y, c, z, anchors):
        """``(energy (J), gradient (n, 3), Hessian (3n, 3n) csc)`` of inertia, springs,
        gravity and anchors at ``y (n, 3)`` (``c (n,)`` inertia weights, ``z (n, 3)`` their
        target; ``anchors (n, 3)`` or None): :meth:`solve_step`'s potential without the
        barrier."""
        n = self.n
        e_s, g_s, K = spring_terms(self.model, y)
        d = y - z
        e = 0.5 * np.sum(c[:, None] * d * d) + e_s + np.sum(self.gravity * y)
        g = c[:, None] * d + g_s + self.gravity
        dvals = np.repeat(c, 3)
        if anchors is not None:
            da = y - anchors
            e += 0.5 * np.sum(self.anchor_k[:, None] * da * da)
            g = g + self.anchor_k[:, None] * da
            dvals = dvals + np.repeat(self.anchor_k, 3)
        Kv = np.concatenate([K, K, K, K]) * self._sign[:, None, None]
        H = sp.csc_matrix((np.concatenate([Kv.ravel(), dvals]), (self._rows, self._cols)),
                          shape=(3 * n, 3 * n))
        return e, g, H

    def _system(self, scene: Scene, y, body_V, c, z, anchors, col=None):
        """``(Phi, gradient (3n,), Hessian (3n, 3n) csc, contacts)`` at ``y`` (``col``: the
        collision set at ``y`` when already built)."""
        n = self.n
        e, g, H = self.smooth_system(y, c, z, anchors)
        if col is None:
            col = scene.collisions(y, body_V, self.settings.dhat)
        if col.empty():
            return float(e), g.ravel(), H, 0
        V_all = scene.stack(y, body_V)
        e += float(self.barrier(col, scene.mesh, V_all))
        gb = np.asarray(self.barrier.gradient(col, scene.mesh, V_all))[: 3 * n]
        Hb = self.barrier.hessian(col, scene.mesh, V_all, ipctk.PSDProjectionMethod.CLAMP)
        Hb = sp.csc_matrix(Hb)[: 3 * n, : 3 * n]
        return float(e), g.ravel() + gb, (H + Hb).tocsc(), len(col)

    # ------------------------------------------------------------------ stepping
    def solve_step(self, scene: Scene, x: np.ndarray, v: np.ndarray, h: float,
                   body_V: np.ndarray, start: np.ndarray, anchors: np.ndarray | None
                   ) -> tuple[np.ndarray, dict]:
        """One backward-Euler step of length ``h`` (s) from ``(x, v)`` with the body at
        ``body_V``, Newton iterations from ``start`` (collision-free with ``body_V``).

        Returns ``(y (n, 3), stats)``; stats: ``iterations``, ``converged``, ``residual``
        (RMS of the potential's gradient per vertex / mean vertex weight), ``contacts``.
        """
        s = self.settings
        m = self.model.mass
        c = m * (1.0 / (h * h) + s.damping / h)
        z = (x + h * v + s.damping * h * x) / (1.0 + s.damping * h)
        y = np.array(start, np.float64)
        enough = self.n * self.model.weight_mean * s.tolerance  # J
        converged, it, n_col = False, 0, 0
        lu, factored, alpha, col = None, 0, 1.0, None
        while True:
            e, g, H, n_col = self._system(scene, y, body_V, c, z, anchors, col)
            if it >= s.max_iterations:
                break
            # a fresh factorisation at the start, after a cut-back step and every few
            # iterations; in between the old one preconditions conjugate gradients
            fresh = lu is None or alpha < 1.0 or it - factored >= s.refactor_every
            while True:
                if fresh:
                    lu, factored = factor(H), it
                d = pcg(H, -g, lu.solve, 3)
                slope = float(np.sum(g * d))
                if slope < 0 or fresh:
                    break
                fresh = True
            if not slope < 0:
                break
            if -0.5 * slope < enough:
                converged = True
                break
            d = d.reshape(-1, 3)
            alpha = scene.free_fraction(y, body_V, y + d, body_V)
            while alpha > 1e-8:
                trial, col = self.energy(scene, y + alpha * d, body_V, c, z, anchors)
                if trial <= e + 1e-4 * alpha * slope:
                    break
                alpha *= 0.5
            if alpha <= 1e-8:
                break
            y = y + alpha * d
            it += 1
        per_vertex = np.sqrt(np.einsum("ij,ij->i", g.reshape(-1, 3), g.reshape(-1, 3)))
        residual = float(np.sqrt(np.mean(per_vertex ** 2)) / self.model.weight_mean)
        return y, {"iterations": it, "converged": converged, "residual": residual,
                   "contacts": n_col}

    def carried(self, x: np.ndarray, body_from: np.ndarray, body_to: np.ndarray) -> np.ndarray:
        """Displacement ``(n, 3)`` of the cloth ``x`` carried by the body's move from
        ``body_from`` to ``body_to``: the body's displacement at each vertex's closest body
        point, plus, along that face's normal, the largest further outward move of the body
        vertices within ``reach`` of the vertex (so the body does not bulge into a cloth
        triangle between its corners); in full within ``carry_full`` of the body, fading
        linearly to nothing at ``carry``."""
        s = self.settings
        dist, p, face = closest_points(body_from, self.body_F, x, exact_faces=True)
        w = np.clip((s.carry - dist) / (s.carry - s.carry_full), 0.0, 1.0)
        near = np.flatnonzero(w > 0)
        out = np.zeros_like(x)
        if not len(near):
            return out
        tri = self.body_F[face[near]]
        bc = barycentric(p[near], body_from[tri])
        move = body_to - body_from
        u = np.einsum("pk,pkd->pd", bc, move[tri])
        a, b, c = (body_from[tri[:, k]] for k in range(3))
        nrm = np.cross(b - a, c - a)
        nrm /= np.maximum(np.sqrt(np.sum(nrm * nrm, axis=1)), 1e-300)[:, None]
        idx = self._body_tree(body_from).query_ball_point(x[near], self.reach)
        counts = np.fromiter((len(js) for js in idx), np.int64, len(idx))
        flat = np.fromiter((j for js in idx for j in js), np.int64, int(counts.sum()))
        row = np.repeat(np.arange(len(near)), counts)
        lift = np.zeros(len(near))
        np.maximum.at(lift, row, np.einsum("ij,ij->i", move[flat] - u[row], nrm[row]))
        out[near] = w[near, None] * (u + lift[:, None] * nrm)
        if s.carry_blend > 0:
            out = self._blended(x, out, s.carry_blend)
        return out

    @staticmethod
    def _blended(x: np.ndarray, u: np.ndarray, radius: float) -> np.ndarray:
        """The carry ``u (n, 3)`` averaged over the cloth vertices within ``radius`` of each
        vertex of ``x`` (weights ``1 - d / radius``): layers of cloth close to each other
        (a sleeve on the side of a shirt) are carried alike instead of into each other."""
        moving = np.flatnonzero(np.any(u != 0.0, axis=1))
        if not len(moving):
            return u
        tree = cKDTree(x)
        pairs = tree.query_ball_point(x[moving], radius)
        counts = np.fromiter((len(js) for js in pairs), np.int64, len(pairs))
        flat = np.fromiter((j for js in pairs for j in js), np.int64, int(counts.sum()))
        row = np.repeat(moving, counts)
        d = np.sqrt(np.sum((x[row] - x[flat]) ** 2, axis=1))
        w = 1.0 - d / radius
        out = np.zeros_like(u)
        total = np.zeros(len(u))
        np.add.at(out, flat, w[:, None] * u[row])
        np.add.at(total, flat, w)
        touched = total > 0
        out[touched] /= total[touched, None]
        return out

    def _body_tree(self, body_V: np.ndarray) -> cKDTree:
        """k-d tree of ``body_V`` (kept for the last body asked)."""
        if self._tree_of is not body_V:
            self._tree, self._tree_of = cKDTree(body_V), body_V
        return self._tree

    def advance(self, x: np.ndarray, v: np.ndarray, h: float, body_from: np.ndarray,
                body_to: np.ndarray, anchors_at=None, substep_limit: int | None = None
                ) -> tuple[np.ndarray, np.ndarray, dict]:
        """One frame of length ``h``: the body moves linearly from ``body_from`` to
        ``body_to`` (both ``(b, 3)``), in as many sub-steps as collision-free moves need.

        ``anchors_at(body_V) -> (n, 3)`` gives the anchor points on a body (None: none).
        Returns ``(x', v', stats)``; stats: ``substeps``, ``iterations`` (all sub-steps),
        ``converged`` (every sub-step), ``residual`` (largest), ``contacts`` (last).

        Raises
        ------
        SubstepsExceeded
            The frame needs more than ``substep_limit`` sub-steps (raised before the
            sub-step over it is solved).
        RuntimeError
            When the body's move cannot be followed: the collision-free part of the
            shortest sub-step stays negligible (cloth caught between two body parts).
        """
        s = self.settings
        scene = self.scene(x, [body_from, body_to])
        stats = {"substeps": 0, "iterations": 0, "converged": True, "residual": 0.0,
                 "contacts": 0}
        done, frac, body_now, stalled = 0.0, 1.0, body_from, 0
        while done < 1.0:
            if substep_limit is not None and stats["substeps"] >= substep_limit:
                raise SubstepsExceeded(stats["substeps"] + 1)
            frac = min(frac, 1.0 - done)
            # the carry is linear in the body's move: computed once to the frame's end and
            # scaled to each trial sub-step
            u_rest = self.carried(x, body_now, body_to)
            while True:
                reach = 1.0 if done + frac >= 1.0 else done + frac
                target = body_to if reach >= 1.0 else body_from + reach * (body_to - body_from)
                u = u_rest if reach >= 1.0 else u_rest * ((reach - done) / (1.0 - done))
                free = scene.free_fraction(x, body_now, x + u, target)
                # a collision-free part of 4 shortest sub-steps or more is taken as it is;
                # a smaller one is tried again on a shorter sub-step
                if free >= 1.0 or frac <= s.min_substep or free * frac >= s.min_substep * 4:
                    break
                frac = max(frac * max(0.5 * free, 0.25), s.min_substep)
            if free < 1.0:
                # the sub-step collides at its end: go 90 % of the way the CCD allows (the
                # barrier then pushes the cloth ahead of the body)
                part = 0.9 * free
                stalled = stalled + 1 if part * frac < 1e-3 * s.min_substep else 0
                if stalled > 8:
                    raise RuntimeError(
                        f"cloth dynamics: the body's move cannot be followed without a "
                        f"collision (cloth caught between body parts?) at {done:.4f} of "
                        f"the frame")
                reach = done + part * frac
                target = body_from + reach * (body_to - body_from)
                u = part * u
                frac = part * frac
            anchors = None if anchors_at is None else anchors_at(target)
            y, st = self.solve_step(scene, x, v, h * frac, target, x + u, anchors)
            v = (y - x) / (h * frac)
            x, body_now, done = y, target, reach
            stats["substeps"] += 1
            if stats["substeps"] > 4.0 / s.min_substep:
                raise RuntimeError(f"cloth dynamics: more than {4.0 / s.min_substep:.0f} "
                                   "sub-steps in one frame")
            stats["iterations"] += st["iterations"]
            stats["converged"] &= st["converged"]
            stats["residual"] = max(stats["residual"], st["residual"])
            stats["contacts"] = st["contacts"]
            frac = min(1.0, 2.0 * frac)
        return x, v, stats

    def intersection_free(self, x: np.ndarray, body_V: np.ndarray) -> bool:
        """Whether no cloth triangle crosses a body or cloth edge (ipctk's exact check; every
        body face near the cloth, pinched ones included)."""
        scene = Scene(self.model, self.body_F, [body_V], x, self.settings.crop)
        return not ipctk.has_intersections(scene.mesh, scene.stack(x, body_V))

    def min_distance(self, x: np.ndarray, body_V: np.ndarray) -> float:
        """Smallest distance (m) between non-adjacent cloth-body or cloth-cloth primitives
        within ``dhat`` (``dhat`` when none is closer)."""
        scene = self.scene(x, [body_V])
        col = scene.collisions(x, body_V, self.settings.dhat)
        if col.empty():
            return float(self.settings.dhat)
        return float(col.compute_minimum_distance(scene.mesh, scene.stack(x, body_V)))


def simulate(dyn: ClothDynamics, x0: np.ndarray, bodies: list[np.ndarray], dt: float,
             anchors_at=None, on_frame=None) -> tuple[np.ndarray, dict]:
    """Run ``dyn`` through the frames ``bodies`` (frame 0 is the start) from rest at ``x0``.

    Returns ``(vertices (n, 3), stats)``; stats: ``frames``, ``substeps``, ``iterations``,
    ``unconverged_frames``, ``worst_residual``, ``max_iterations`` (of one frame), ``cpu_s``.

    Raises
    ------
    RuntimeError
        The motion needs more than ``dyn.settings.substep_budget`` sub-steps a frame on
        average (raised at the sub-step that goes over, before it is solved), or the
        dynamics cannot follow the body (:meth:`ClothDynamics.advance`).
    """
    t0 = time.process_time()
    ipctk.set_num_threads(1)  # one thread: the same sums in the same order on every machine
    x = np.array(x0, np.float64)
    v = np.zeros_like(x)
    tot = {"frames": len(bodies) - 1, "substeps": 0, "iterations": 0,
           "unconverged_frames": 0, "worst_residual": 0.0, "max_iterations": 0}
    budget = int(np.floor(dyn.settings.substep_budget * tot["frames"]))
    for k in range(1, len(bodies)):
        try:
            # the frame stops at the sub-step that goes over the motion's budget
            x, v, st = dyn.advance(x, v, dt, bodies[k - 1], bodies[k], anchors_at,
                                   substep_limit=budget - tot["substeps"])
        except SubstepsExceeded as over:
            raise RuntimeError(f"frame {k} of {tot['frames']}: "
                               f"{tot['substeps'] + over.substeps} sub-steps, over the budget "
                               f"of {budget} ({dyn.settings.substep_budget} a frame)") from None
        tot["substeps"] += st["substeps"]
        tot["iterations"] += st["iterations"]
        tot["unconverged_frames"] += not st["converged"]
        tot["worst_residual"] = max(tot["worst_residual"], st["residual"])
        tot["max_iterations"] = max(tot["max_iterations"], st["iterations"])
        if on_frame is not None:
            on_frame(k, x, st)
    tot["cpu_s"] = time.process_time() - t0
    return x, tot
