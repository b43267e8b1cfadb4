"""Limb-wise search: a way out of local minima for arms and legs the starting poses miss.

The canonical hypotheses (:mod:`.hypotheses`) cover a few whole-body poses; an arm crossed
over the chest or one knee pulled up lies far from all of them, and the local optimiser
keeps the limb where the start left it. After the start, :func:`limb_search` tries, for
each arm and leg in turn, a grid of upper-limb directions (the 26 directions of a cube's
faces, edges and corners) x twists about it x hinge bends of the lower limb (elbow,
knee), and keeps a configuration when it lowers the same symmetric capped distance that
ranks the hypotheses (:func:`~dressmeup.body.registration.init.symmetric_score`). The
candidates are scored without the body model: the limb's points move rigidly with their
dominant bone (upper limb; lower limb with the hand or foot), which is exact away from the
blended joints, so a candidate costs two small k-d tree queries. The best candidates are
polished by a small pattern search; a short pose stage then settles the body, and the
whole change is kept only if the symmetric score of the settled body beats the start's.

The score's basin around the right configuration of an outstretched arm is narrow (about
10 degrees at the shoulder on a sitting scan whose hand the fit had lost: the nearest grid
candidates score worse than the lost arm). With ``aim`` the search also aims the limb at
the scan the body leaves unexplained: scan points farther than a gap from the body are
grouped (:func:`unexplained_groups`), the limb is reduced to its two bones, and the
configurations of a finer grid whose bones run nearest through a group within reach
(:func:`aimed_candidates`) compete with the cube grid under the same score.

Hinge conventions are those of :mod:`.hypotheses` (SMPL frame: y up, facing +z, left on
+x): elbows bend about -y (left) / +y (right), knees about +x.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from dressmeup.body.registration.hypotheses import align_directions
from dressmeup.body.registration.init import capped_distances, symmetric_score
from dressmeup.body.registration.stages import run_adam
from dressmeup.body.registration.terms import JOINT_LIMITS
from dressmeup.geometry.neighbors import NearestTree

logger = logging.getLogger(__name__)

#: (upper joint, lower joint, hinge axis of the lower joint in its local frame).
LIMBS: tuple[tuple[str, str, tuple[float, float, float]], ...] = (
    ("left_shoulder", "left_elbow", (0.0, -1.0, 0.0)),
    ("right_shoulder", "right_elbow", (0.0, 1.0, 0.0)),
    ("left_hip", "left_knee", (1.0, 0.0, 0.0)),
    ("right_hip", "right_knee", (1.0, 0.0, 0.0)),
)

#: Knee bends (degrees) of the legs' grid in the first limb search (the one right after the
#: hypotheses; ``OptimizationRegistrar.limb_first_knee_bends``). No 140: from the
#: hypotheses' rough body a shin folded up into a skirt or dress explains cloth and
#: outscores the hanging one; the second search, from a settled body, still tries 140.
FIRST_KNEE_BENDS: tuple[float, ...] = (0.0, 50.0, 100.0)


def cube_directions() -> np.ndarray:
    """(26, 3) unit vectors: the directions of a cube's 6 faces, 12 edges and 8 corners."""
    g = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)
                  if (x, y, z) != (0, 0, 0)], dtype=np.float64)
    return g / np.linalg.norm(g, axis=1, keepdims=True)


def _descendants(parents: np.ndarray, root: int) -> list[int]:
    """``root`` and every joint below it in the kinematic tree."""
    out = [root]
    for j in range(len(parents)):
        k = j
        while k >= 0 and k != root:
            k = int(parents[k])
        if k == root and j != root:
            out.append(j)
    return out


class LimbScorer:
    """The symmetric score of the body with one limb moved rigidly (see module docstring).

    Parameters
    ----------
    P : (p, 3) scan points; tree : their nearest-point index (``NearestTree`` or ``cKDTree``).
    Vb : (b, 3) the body points scored (the problem's ``body_ids`` subset), current pose.
    limb_up, limb_lo : (b,) bool, points moving with the upper / lower limb bone.
    J_up, J_lo : (3,) current positions of the upper and lower joint.
    cap, scan_cap : distance caps (m) of the score's body -> scan and scan -> body terms
        (``scan_cap`` None: ``cap``).
    """

    def __init__(self, P, tree, Vb, limb_up, limb_lo, J_up, J_lo, cap: float = 0.1,
                 scan_cap: float | None = None):
        scan_cap = cap if scan_cap is None else scan_cap
        self.tree, self.cap, self.scan_cap = tree, cap, scan_cap
        rest = ~(limb_up | limb_lo)
        self.n_b, self.n_p = len(Vb), len(P)
        self.const_body = float(capped_distances(tree, Vb[rest], cap).sum())
        d_rest = capped_distances(NearestTree(Vb[rest]), P, scan_cap)
        self.J_up, self.J_lo = np.asarray(J_up, np.float64), np.asarray(J_lo, np.float64)
        self.X_up = Vb[limb_up] - self.J_up
        self.X_lo = Vb[limb_lo] - self.J_lo
        reach = float(np.linalg.norm(np.r_[self.X_up, self.X_lo + self.J_lo - self.J_up],
                                     axis=1).max()) + scan_cap
        near = np.linalg.norm(P - self.J_up, axis=1) < reach  # others cannot change
        self.P_near, self.d_near = P[near], d_rest[near]
        self.const_scan = float(d_rest[~near].sum())

    def points(self, M_up: np.ndarray, M_lo: np.ndarray) -> np.ndarray:
        """(k, 3) limb points after rotating the upper bone by ``M_up`` about the upper joint
        and the lower bone by ``M_lo`` about the (moved) lower joint (world rotations)."""
        j_lo = self.J_up + M_up @ (self.J_lo - self.J_up)
        return np.r_[self.J_up + self.X_up @ M_up.T, j_lo + self.X_lo @ M_lo.T]

    def score(self, M_up: np.ndarray, M_lo: np.ndarray) -> float:
        """Symmetric capped distance (m) with the limb moved (same value as
        ``symmetric_score`` for the identity, up to the skinning blend near the joints)."""
        X = self.points(M_up, M_lo)
        b = float(capped_distances(self.tree, X, self.cap).sum())
        # Only a scan point nearer the limb's bounding box than to the rest of the body can
        # get closer (the margin keeps float rounding of the box distance on the safe side),
        # so only those are queried: the same sum, term for term (benchmarks/perf/limb_scorer.py).
        gap = np.linalg.norm(np.maximum(np.maximum(X.min(0) - self.P_near,
                                                   self.P_near - X.max(0)), 0.0), axis=1)
        near = gap < self.d_near + 1e-9
        d = self.d_near.copy()
        if near.any():
            d_limb, _ = NearestTree(X).query(self.P_near[near],
                                             distance_upper_bound=self.scan_cap)
            d[near] = np.minimum(d[near], d_limb)
        return (self.const_body + b) / self.n_b + (self.const_scan + float(d.sum())) / self.n_p


def fibonacci_directions(n: int) -> np.ndarray:
    """(n, 3) unit vectors spread evenly over the sphere (Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    polar = np.arccos(1.0 - 2.0 * i / n)
    turn = math.pi * (1.0 + 5.0 ** 0.5) * i
    return np.c_[np.cos(turn) * np.sin(polar), np.cos(polar), np.sin(turn) * np.sin(polar)]


def unexplained_groups(P: np.ndarray, V: np.ndarray, gap: float = 0.05, link: float = 0.03,
                       min_points: int = 15, most: int = 3) -> list[np.ndarray]:
    """The groups of scan points the body leaves unexplained, largest first.

    Parameters
    ----------
    P : (p, 3) scan points (m); V : (b, 3) body points (m), current pose.
    gap : a scan point farther than this from every body point is unexplained (m); above
        a clothed scan's shell (1-3 cm) and the noise.
    link : unexplained points closer than this are in one group (m).
    min_points, most : smaller groups are ignored; at most ``most`` groups are returned.

    Returns
    -------
    groups : list of (m_k, 3) arrays of scan points.
    """
    # heavy: scipy (~0.5 s to import)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    d = capped_distances(NearestTree(V), P, gap)
    far = P[d >= gap]
    if len(far) < min_points:
        return []
    pairs = cKDTree(far).query_pairs(link, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(far), len(far)))
    _, label = connected_components(graph, directed=False)
    sizes = np.bincount(label)
    order = [k for k in np.argsort(-sizes, kind="stable") if sizes[k] >= min_points][:most]
    return [far[label == k] for k in order]


def _segment_distances(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n, m) distances of points ``q`` (m, 3) to the segments ``a`` -> ``b`` ((n, 3) or
    (3,) each); through (n, 3) x (3, m) products, no (n, m, 3) array."""
    a = np.broadcast_to(a, b.shape) if a.ndim == 1 else a
    ab = b - a
    ab2 = np.maximum(np.einsum("nk,nk->n", ab, ab), 1e-12)
    # einsum, not @: these products are too small for BLAS threads to pay
    proj = np.einsum("nk,mk->nm", ab, q) - np.einsum("nk,nk->n", a, ab)[:, None]  # (q-a).ab
    w2 = ((q * q).sum(1)[None] - 2.0 * np.einsum("nk,mk->nm", a, q)
          + np.einsum("nk,nk->n", a, a)[:, None])
    t = np.clip(proj / ab2[:, None], 0.0, 1.0)
    return np.sqrt(np.maximum(w2 - 2.0 * t * proj + t * t * ab2[:, None], 0.0))


def aimed_candidates(W_up: np.ndarray, W_lo: np.ndarray,
                     J_up: np.ndarray, J_lo: np.ndarray, end: np.ndarray, hinge,
                     groups, most: int = 60, samples: int = 32, n_directions: int = 300,
                     twists: int = 24, bends_deg=tuple(range(0, 141, 10)),
                     seed: int = 0) -> list[tuple]:
    """(direction, twist rad, bend rad) candidates (parametrised as in
    :func:`_limb_candidates`) whose bones run through a group of unexplained scan points.

    The limb is reduced to its two bones, upper joint -> lower joint -> ``end``; on a finer
    grid (upper-bone directions x twists x bends) a configuration's distance to a group is
    the mean distance of the group's points (``samples`` of them) to the nearer bone. Per
    group within reach, the ``most`` nearest configurations are returned.

    Parameters
    ----------
    W_up, W_lo : (3, 3) current world rotations of the upper and lower joint; J_up, J_lo :
        (3,) their positions (m); the upper bone runs from J_up to J_lo.
    end : (3,) end of the lower bone (e.g. the centre of the hand's or foot's points),
        current pose (m); it moves with the lower bone.
    groups : list of (m_k, 3) scan points (m), e.g. :func:`unexplained_groups`.
    """
    # heavy: scipy (~0.5 s to import)
    from scipy.spatial.transform import Rotation

    length = float(np.linalg.norm(J_lo - J_up))
    c_up = (J_lo - J_up) / max(length, 1e-12)
    reach = length + float(np.linalg.norm(end - J_lo))
    rng = np.random.default_rng(seed)
    groups = [g[rng.choice(len(g), min(samples, len(g)), replace=False)] for g in groups]
    groups = [g for g in groups if np.linalg.norm(g - J_up, axis=1).min() <= reach]
    if not groups:
        return []

    D = fibonacci_directions(n_directions)
    d_all = np.repeat(D, twists, axis=0)
    t_all = np.tile(2 * math.pi * np.arange(twists) / twists, n_directions)
    align = np.repeat([align_directions(c_up, d) for d in D], twists, axis=0)
    # :func:`_world`'s upper rotation for every candidate at once
    R_up = (Rotation.from_rotvec(d_all * t_all[:, None]) * Rotation.from_rotvec(align)
            * Rotation.from_matrix(W_up))
    j_lo = J_up + length * d_all
    local_end = W_lo.T @ (end - J_lo)  # in the lower joint's current frame
    upper = [_segment_distances(g, J_up, j_lo) for g in groups]
    scores: list[list[np.ndarray]] = [[] for _ in groups]
    bends = np.radians(np.asarray(bends_deg, dtype=np.float64))
    for bend in bends:
        M = (R_up * Rotation.from_rotvec(np.asarray(hinge) * bend)).as_matrix()
        tip = j_lo + M @ local_end
        for k, g in enumerate(groups):
            scores[k].append(np.minimum(upper[k], _segment_distances(g, j_lo, tip)).mean(1))
    out = []
    for per_bend in scores:
        flat = np.concatenate(per_bend)  # bend-major: index = bend * n + candidate
        for i in np.argsort(flat, kind="stable")[:most]:
            b, c = divmod(int(i), len(d_all))
            out.append((d_all[c], float(t_all[c]), float(bends[b])))
    return out


def _limb_candidates(c_up: np.ndarray, twists: int, bends_deg) -> list[tuple]:
    """(direction, twist rad, bend rad) triples of the grid for a limb now pointing ``c_up``."""
    out = [(d, 0.0, 0.0) for d in cube_directions()]
    for d in cube_directions():
        for k in range(twists):
            for b in bends_deg:
                if b > 0:
                    out.append((d, 2 * math.pi * k / twists, math.radians(b)))
    return out


def _world(c_up, W_up, d, twist, bend, hinge, turns: dict | None = None):
    """World rotations (upper, lower) of a candidate: the upper bone turned from ``c_up``
    onto ``d`` then twisted about it, the lower bone bent about its hinge. ``W_up``: the
    upper joint's world rotation (a matrix or a ``Rotation``); ``turns``: a dict kept across
    the calls of one limb (same ``c_up``), caching the turn of each (direction, twist), the
    same product in the same order, so the same floats."""
    # heavy: scipy (~0.5 s to import)
    from scipy.spatial.transform import Rotation

    key = (np.asarray(d, np.float64).tobytes(), float(twist))
    turn = None if turns is None else turns.get(key)
    if turn is None:
        turn = Rotation.from_rotvec(d * twist) * Rotation.from_rotvec(align_directions(c_up, d))
        if turns is not None:
            turns[key] = turn
    R_up = turn * (W_up if isinstance(W_up, Rotation) else Rotation.from_matrix(W_up))
    R_lo = R_up * Rotation.from_rotvec(np.asarray(hinge) * bend)
    return R_up, R_lo


def _tilt(d: np.ndarray, a: float, b: float) -> np.ndarray:
    """``d`` tilted by angles ``a`` and ``b`` (rad) about two axes perpendicular to it."""
    # heavy: scipy (~0.5 s to import)
    from scipy.spatial.transform import Rotation

    e1 = np.cross(d, (0.0, 1.0, 0.0) if abs(d[1]) < 0.9 else (1.0, 0.0, 0.0))
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    return (Rotation.from_rotvec(e2 * b) * Rotation.from_rotvec(e1 * a)).apply(d)


def _within_limits(name: str, rotvec: np.ndarray, margin: float = 0.3) -> bool:
    if name not in JOINT_LIMITS:
        return True
    lo, hi = np.array(JOINT_LIMITS[name]).T
    return bool(np.all(rotvec >= lo - margin) and np.all(rotvec <= hi + margin))


def search_limb(problem, scorer: LimbScorer, upper: int, lower: int, hinge, W, twists: int,
                bends_deg, top: int = 3, rounds: int = 2, extra=()) -> tuple[
                    float, float, np.ndarray, np.ndarray]:
    """Best configuration of one limb by the grid (and the ``extra`` candidates, e.g.
    :func:`aimed_candidates`) then a pattern search around the ``top`` best. Returns (start
    score, best score, local rotvec upper, local rotvec lower); ``W`` (j, 3, 3) are the
    current world rotations of the joints."""
    # heavy: scipy (~0.5 s to import)
    from scipy.spatial.transform import Rotation

    names = list(problem.model.joint_names)
    parent = int(problem.model.joint_parents[upper])
    W_par = Rotation.from_matrix(W[parent]) if parent >= 0 else Rotation.identity()
    c_up = scorer.J_lo - scorer.J_up
    c_up = c_up / max(np.linalg.norm(c_up), 1e-12)
    base = scorer.score(np.eye(3), np.eye(3))
    W_up_inv, W_lo_inv = W[upper].T, W[lower].T
    up_name, lo_name = names[upper], names[lower]
    R_W_up, W_par_inv, turns = Rotation.from_matrix(W[upper]), W_par.inv(), {}

    def evaluate(d, twist, bend):
        R_up, R_lo = _world(c_up, R_W_up, d, twist, bend, hinge, turns)
        local = (W_par_inv * R_up).as_rotvec()
        if not (_within_limits(up_name, local) and _within_limits(lo_name, np.asarray(hinge)
                                                                  * bend)):
            return math.inf
        return scorer.score(R_up.as_matrix() @ W_up_inv, R_lo.as_matrix() @ W_lo_inv)

    scored = [(evaluate(*c), c) for c in [*_limb_candidates(c_up, twists, bends_deg), *extra]]
    scored.sort(key=lambda t: t[0])
    best = scored[0]
    step = math.radians(15.0)
    for s0, (d0, t0, b0) in scored[:top]:
        cur = (s0, (d0, t0, b0))
        for r in range(rounds):
            h = step / (2 ** r)
            d, t, b = cur[1]
            moves = [(_tilt(d, h, 0), t, b), (_tilt(d, -h, 0), t, b), (_tilt(d, 0, h), t, b),
                     (_tilt(d, 0, -h), t, b), (d, t + 2 * h, b), (d, t - 2 * h, b)]
            if b > 0:
                moves += [(d, t, b + 2 * h), (d, t, max(b - 2 * h, 0.0))]
            for m in moves:
                s = evaluate(*m)
                if s < cur[0]:
                    cur = (s, m)
        if cur[0] < best[0]:
            best = cur
    d, t, b = best[1]
    R_up, _ = _world(c_up, R_W_up, d, t, b, hinge, turns)
    return base, best[0], (W_par_inv * R_up).as_rotvec(), np.asarray(hinge) * b


def limb_search(problem, n_pose: int, lr_pose: float, lr_transl: float, size_init: bool,
                twists: int = 6, bends_deg=(0, 50, 100, 140), min_gain: float = 2e-4,
                aim: str = "none", scan_cap: float = 0.1, leg_bends_deg=None,
                verbose: bool = False) -> dict:
    """Try other directions for each arm and leg of the current fit (see module docstring);
    leaves the better of (start, start with moved limbs + ``n_pose`` pose steps) in
    ``problem``.

    Parameters
    ----------
    n_pose : pose steps after a limb moved (0: keep the moved limbs unsettled).
    twists, bends_deg : twists about each upper-limb direction (evenly spaced) and bends of
        the lower limb (degrees) of the grid; 26 x (1 + twists x bends > 0) candidates a limb.
    leg_bends_deg : the knee bends (degrees) of the legs' grid; None: ``bends_deg``.
    min_gain : a limb moves only if the symmetric score drops by more than this (m).
    aim : which limbs (``"none"``, ``"arms"``, ``"all"``) also score the configurations
        that run their bones through the scan the body leaves unexplained
        (:func:`unexplained_groups`, :func:`aimed_candidates`); the groups are found again
        before each limb, so a group one limb took is not chased again.
    scan_cap : cap (m) of the score's scan -> body distances (its body -> scan cap is 0.1;
        :func:`~dressmeup.body.registration.init.symmetric_score`).

    Returns
    -------
    info : ``{"limbs_moved": [joint names], "limb_score": (before, after) m, "limb_kept":
    bool}``.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    model = problem.model
    names = list(model.joint_names)
    parents = np.asarray(model.joint_parents)
    dom = problem.W_sub.cpu().numpy().argmax(1)
    start_score, start = symmetric_score(problem, scan_cap=scan_cap), problem.snapshot()
    moved: list[str] = []
    posed = None
    for up_name, lo_name, hinge in LIMBS:
        if up_name not in names or lo_name not in names:
            continue
        upper, lower = names.index(up_name), names.index(lo_name)
        if posed is None:  # the body as it is now (again only after a limb moved)
            with torch.no_grad():
                out = model.forward(problem.shape_value()[None], problem.pose[None],
                                    problem.transl[None], torch.exp(problem.log_scale)[None])
            posed = (out.vertices[0].cpu().numpy().astype(np.float64)[problem.body_ids],
                     out.joints[0].cpu().numpy().astype(np.float64),
                     out.transforms[0, :, :3, :3].cpu().numpy().astype(np.float64))
        V, J, W = posed
        up_mask = dom == upper
        lo_mask = np.isin(dom, _descendants(parents, lower))
        if up_mask.sum() + lo_mask.sum() < 10:
            continue
        scorer = LimbScorer(problem.P, problem.tree, V, up_mask, lo_mask, J[upper], J[lower],
                            scan_cap=scan_cap)
        extra = []
        if aim == "all" or (aim == "arms" and up_name.endswith("shoulder")):
            groups = unexplained_groups(problem.P, V)
            below = [j for j in range(len(parents)) if parents[j] == lower]
            end_mask = np.isin(dom, _descendants(parents, below[0])) if below else lo_mask
            if groups and end_mask.any():
                extra = aimed_candidates(W[upper], W[lower], J[upper], J[lower],
                                         V[end_mask].mean(0), hinge, groups)
        leg = leg_bends_deg is not None and up_name.endswith("hip")
        base, best, rv_up, rv_lo = search_limb(problem, scorer, upper, lower, hinge, W, twists,
                                               leg_bends_deg if leg else bends_deg,
                                               extra=extra)
        logger.info("limb %s: %.4f -> %.4f", up_name, base, best)
        if best < base - min_gain:
            with torch.no_grad():
                problem.pose[upper] = torch.as_tensor(rv_up, dtype=problem.dt)
                problem.pose[lower] = torch.as_tensor(rv_lo, dtype=problem.dt)
            moved.append(up_name)
            posed = None
    info = {"limbs_moved": moved, "limb_score": (round(start_score, 5), round(start_score, 5)),
            "limb_kept": False}
    if not moved:
        return info
    if n_pose > 0:
        params, lrs = [problem.pose, problem.transl], [lr_pose, lr_transl]
        if size_init:
            params.append(problem.log_scale)
            lrs.append(0.003)
        run_adam(problem, "pose", n_pose, params, lrs, label="limb search pose", verbose=verbose)
    after = symmetric_score(problem, scan_cap=scan_cap)
    info["limb_score"] = (round(start_score, 5), round(after, 5))
    if after < start_score:
        info["limb_kept"] = True
    else:
        problem.restore(start)
    logger.info("limb search: moved %s, score %.4f -> %.4f (%s)", moved, start_score, after,
                "kept" if info["limb_kept"] else "dropped")
    return info
