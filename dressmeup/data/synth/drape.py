"""Draping a rest garment onto a posed body: skinning, then quasi-static cloth relaxation.

The skinned garment (linear blend skinning with weights transferred from the body) is the
starting point; the draped garment is a local minimum of

    E(x) = stretch + bending + gravity + body collision + support,

- stretch: edge springs, ``0.5 Y sum_e A_e ((|e| - L_e) / L_e)^2`` (membrane stiffness ``Y``
  in N/m, ``A_e`` the area share of edge ``e``, ``L_e`` its rest length);
- bending: the same on the "hinge" edges joining the opposite corners of adjacent triangles,
  with stiffness ``bending_ratio * Y``;
- gravity: ``sum_i m_i g h_i`` (areal density times vertex area, ``h`` the height);
- collision: a one-sided quadratic penalty keeping every vertex ``margin`` outside the posed
  body along the direction to its closest body point (re-linearised each outer iteration;
  inside/outside by the generalised winding number);
- support: where the garment rests on the body (shoulders, waistband), a soft spring to the
  skinned position stands in for friction and elastic bands;
- self-collision (generator 2.x, ``self_stiffness > 0``): a one-sided quadratic penalty
  keeping vertices that are far apart on the cloth (rest distance over three thicknesses)
  ``self_thickness`` apart in space (pairs found by a k-d tree each outer iteration).

Minimised with L-BFGS (torch, float64). A final projection puts any vertex still closer than
``clearance`` to the body (or inside it) at ``clearance`` outside.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.geometry.mesh import edges, face_areas, face_normals
from dressmeup.geometry.proximity import closest_points
from dressmeup.geometry.winding import winding_number


@dataclass
class DrapeSettings:
    """Material and solver settings (SI units)."""

    youngs: float = 200.0  # membrane stretch stiffness, N/m
    bending_ratio: float = 0.02  # hinge stiffness relative to stretch
    density: float = 0.15  # kg/m^2
    gravity: float = 9.81  # m/s^2
    collision_stiffness: float = 2.0e5  # N/m^3 (per unit area)
    margin: float = 0.004  # m, collision penalty starts this far outside the body
    support_stiffness: float = 2.0e4  # N/m^3 (per unit area)
    outer_iterations: int = 5
    inner_iterations: int = 60
    clearance: float = 0.001  # m, hard minimum distance outside the body at the end
    # generator 2.x (0 / off reproduces 1.x exactly):
    self_stiffness: float = 0.0  # N/m^3 (per unit area), cloth-cloth repulsion; 0: none
    self_thickness: float = 0.006  # m, cloth layers are kept this far apart

    def to_dict(self) -> dict:
        """The settings as a JSON-able dict."""
        return asdict(self)


@dataclass
class DrapeResult:
    """Draped vertices ``(n, 3) float64``, the skinned start ``(n, 3)`` and statistics."""

    vertices: np.ndarray
    skinned: np.ndarray
    stats: dict


def hinge_pairs(F: np.ndarray) -> np.ndarray:
    """Opposite-corner vertex pairs ``(h, 2) int64`` of every interior edge of ``F``."""
    F = np.asarray(F, np.int64)
    m = len(F)
    he = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    opp = np.concatenate([F[:, 2], F[:, 0], F[:, 1]])
    key = np.sort(he, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    k = key[order]
    same = np.all(k[1:] == k[:-1], axis=1)
    i = np.flatnonzero(same)
    del m
    return np.stack([opp[order[i]], opp[order[i + 1]]], axis=1)


def _vertex_areas(V, F):
    a = face_areas(V, F) / 3.0
    out = np.zeros(len(V))
    for k in range(3):
        np.add.at(out, F[:, k], a)
    return out


def _body_query(body_V, body_F, x, exact_faces=False):
    """Signed distance (positive outside), closest points and outward unit directions
    (``exact_faces``: see :func:`dressmeup.geometry.proximity.closest_points`)."""

    d, p, fid = closest_points(body_V, body_F, x, exact_faces=exact_faces)
    inside = winding_number(body_V, body_F, x) > 0.5
    sd = np.where(inside, -d, d)
    diff = x - p
    nrm = np.linalg.norm(diff, axis=1, keepdims=True)
    fn = face_normals(body_V, body_F)[fid]
    n = np.where(nrm > 1e-7, diff / np.maximum(nrm, 1e-12), fn)
    n = np.where(inside[:, None] & (nrm > 1e-7), -n, n)
    return sd, p, n


def drape(rest_V: np.ndarray, faces: np.ndarray, skinned: np.ndarray, support: np.ndarray,
          body_V: np.ndarray, body_F: np.ndarray, up: np.ndarray,
          settings: DrapeSettings | None = None, start: np.ndarray | None = None,
          exact_faces: bool = False) -> DrapeResult:
    """Relax a skinned garment on a posed body (see module docstring).

    Parameters
    ----------
    rest_V : (n, 3) float64 garment in its rest shape (defines rest lengths).
    faces : (m, 3) int64 garment faces.
    skinned : (n, 3) float64 garment posed by skinning (start point, support targets).
    support : (n,) float64 in [0, 1], weight of the support spring per vertex.
    body_V : (b, 3) float64 posed body surface; body_F : (c, 3) int64.
    up : (3,) unit vector opposite to gravity.
    settings : material and solver settings.
    start : (n, 3) float64 start point (default ``skinned``); the pose-continuation path of
        generator 2.x starts each step from the previous step's drape.
    exact_faces : the body's closest faces chosen in float64 among the faces around the
        BVH's pick (:func:`dressmeup.geometry.proximity.closest_points`), so the drape does
        not depend on the CPU's float32 rounding (generator 2.1.0; off reproduces 1.x).

    Returns
    -------
    DrapeResult with statistics: ``skinning_mean_m`` / ``skinning_max_m`` (distance between
    skinned and draped vertices), ``min_signed_distance_m`` (to the body, after draping),
    ``stretch_mean`` (mean |l/L - 1| over edges), ``energy_start`` / ``energy_end``.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # small problems: one thread is faster and deterministic
    try:
        return _drape(rest_V, faces, skinned, support, body_V, body_F, up, settings, start,
                      exact_faces)
    finally:
        torch.set_num_threads(threads)


def _self_pairs(x: np.ndarray, rest_V: np.ndarray, thickness: float) -> np.ndarray:
    """Vertex pairs ``(k, 2)`` closer than ``2 thickness`` in ``x`` but far apart on the cloth."""
    P = cKDTree(x).query_pairs(2.0 * thickness, output_type="ndarray")
    if len(P) == 0:
        return np.zeros((0, 2), np.int64)
    far = np.linalg.norm(rest_V[P[:, 0]] - rest_V[P[:, 1]], axis=1) > 3.0 * thickness
    P = P[far].astype(np.int64)
    return P[np.lexsort((P[:, 1], P[:, 0]))]


def _drape(rest_V, faces, skinned, support, body_V, body_F, up, settings, start=None,
           exact_faces=False):
    s = settings or DrapeSettings()
    F = np.asarray(faces, np.int64)
    rest_V = np.asarray(rest_V, np.float64)
    x0 = np.asarray(skinned, np.float64)
    up = np.asarray(up, np.float64) / np.linalg.norm(up)
    E = edges(F)
    L = np.linalg.norm(rest_V[E[:, 1]] - rest_V[E[:, 0]], axis=1)
    energy = _energy(s, rest_V, F, E, L, x0, up, support)
    x0_start = x0 if start is None else np.asarray(start, np.float64)
    xf, e_start, e_end = _relax(energy, s, rest_V, body_V, body_F, x0_start, exact_faces)
    sd, p, n = _body_query(body_V, body_F, xf, exact_faces)
    fix = sd < s.clearance
    xf[fix] = p[fix] + n[fix] * s.clearance
    sd_final = _body_query(body_V, body_F, xf, exact_faces)[0]
    le = np.linalg.norm(xf[E[:, 1]] - xf[E[:, 0]], axis=1)
    dist = np.linalg.norm(xf - x0, axis=1)
    stats = {"skinning_mean_m": float(dist.mean()), "skinning_max_m": float(dist.max()),
             "min_signed_distance_m": float(sd_final.min()),
             "projected_vertices": int(fix.sum()),
             "stretch_mean": float(np.mean(np.abs(le / L - 1.0))),
             "skinned_stretch_mean": float(np.mean(np.abs(
                 np.linalg.norm(x0[E[:, 1]] - x0[E[:, 0]], axis=1) / L - 1.0))),
             "skinned_min_signed_distance_m": float(
                 _body_query(body_V, body_F, x0, exact_faces)[0].min()),
             "energy_start": e_start, "energy_end": e_end}
    return DrapeResult(xf, x0, stats)


def _energy(s: DrapeSettings, rest_V: np.ndarray, F: np.ndarray, E: np.ndarray,
            L: np.ndarray, x0: np.ndarray, up: np.ndarray, support: np.ndarray):
    """The energy of the module docstring as a torch function ``energy(x, p, n, active,
    pairs=None)`` of the vertices ``x`` (tensor), the closest body points ``p`` and outward
    directions ``n``, the collision mask ``active`` and the self-collision pairs, divided by
    the garment's weight x 1 cm (O(1) for the solver); ``E``, ``L``: edges and rest lengths."""
    # heavy: torch (~1.1 s to import)
    import torch

    H = hinge_pairs(F)
    A_v = _vertex_areas(rest_V, F)
    LH = np.linalg.norm(rest_V[H[:, 1]] - rest_V[H[:, 0]], axis=1)
    A_e = (A_v[E[:, 0]] + A_v[E[:, 1]]) * 0.5
    A_h = (A_v[H[:, 0]] + A_v[H[:, 1]]) * 0.5
    mass = s.density * A_v
    norm = 1.0 / max(mass.sum() * s.gravity * 0.01, 1e-12)  # energies O(1) for the solver

    t = lambda a, dt=torch.float64: torch.as_tensor(a, dtype=dt)  # noqa: E731
    tE, tH = t(E, torch.int64), t(H, torch.int64)
    tL, tLH, tAe, tAh, tAv = t(L), t(LH), t(A_e), t(A_h), t(A_v)
    tm, tup, tsup, tx0 = t(mass), t(up), t(np.asarray(support, np.float64)), t(x0)

    def energy(x, p, n, active, pairs=None):
        e = x[tE[:, 1]] - x[tE[:, 0]]
        le = torch.sqrt((e * e).sum(1) + 1e-20)
        es = 0.5 * s.youngs * (tAe * ((le - tL) / tL) ** 2).sum()
        h = x[tH[:, 1]] - x[tH[:, 0]]
        lh = torch.sqrt((h * h).sum(1) + 1e-20)
        eb = 0.5 * s.youngs * s.bending_ratio * (tAh * ((lh - tLH) / tLH) ** 2).sum()
        eg = s.gravity * (tm * (x @ tup)).sum()
        pen = torch.relu(s.margin - ((x - p) * n).sum(1)) * active
        ec = 0.5 * s.collision_stiffness * (tAv * pen ** 2).sum()
        da = x - tx0
        ea = 0.5 * s.support_stiffness * (tAv * tsup * (da * da).sum(1)).sum()
        total = es + eb + eg + ec + ea
        if pairs is not None and len(pairs):
            d = x[pairs[:, 1]] - x[pairs[:, 0]]
            gap = torch.relu(s.self_thickness - torch.sqrt((d * d).sum(1) + 1e-20))
            w = 0.5 * (tAv[pairs[:, 0]] + tAv[pairs[:, 1]])
            total = total + 0.5 * s.self_stiffness * (w * gap ** 2).sum()
        return norm * total

    return energy


def _relax(energy, s: DrapeSettings, rest_V: np.ndarray, body_V: np.ndarray,
           body_F: np.ndarray, x_start: np.ndarray, exact_faces: bool
           ) -> tuple[np.ndarray, float, float]:
    """Minimise ``energy`` from ``x_start``: ``outer_iterations`` L-BFGS runs, the body's
    closest points (and the self-collision pairs) found again before each; returns the
    vertices and the energy at the start and at the end."""
    # heavy: torch (~1.1 s to import)
    import torch

    t = lambda a, dt=torch.float64: torch.as_tensor(a, dtype=dt)  # noqa: E731
    tpairs = t(np.zeros((0, 2), np.int64), torch.int64)
    x = t(x_start).clone().requires_grad_(True)
    e_start = e_end = float("nan")
    for it in range(max(1, s.outer_iterations)):
        xn = x.detach().numpy()
        sd, p, n = _body_query(body_V, body_F, xn, exact_faces)
        active = t((sd < s.margin + 0.03).astype(np.float64))
        tp, tn = t(p), t(n)
        if s.self_stiffness > 0:
            tpairs = t(_self_pairs(xn, rest_V, s.self_thickness), torch.int64)
        opt = torch.optim.LBFGS([x], lr=1.0, max_iter=s.inner_iterations, history_size=20,
                                line_search_fn="strong_wolfe", tolerance_grad=1e-9,
                                tolerance_change=1e-12)

        def closure(opt=opt, tp=tp, tn=tn, active=active, pairs=tpairs):
            opt.zero_grad()
            val = energy(x, tp, tn, active, pairs)
            val.backward()
            return val

        if it == 0:
            with torch.no_grad():
                e_start = float(energy(x, tp, tn, active, tpairs))
        opt.step(closure)
        with torch.no_grad():
            e_end = float(energy(x, tp, tn, active, tpairs))
    return x.detach().numpy().copy(), e_start, e_end
