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
the scan the body leaves unexplained (:mod:`.aim`): those candidates compete with the cube
grid under the same score.

Hinge conventions are those of :mod:`.hypotheses` (SMPL frame: y up, facing +z, left on
+x): elbows bend about -y (left) / +y (right), knees about +x.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from scipy.spatial.transform import Rotation

from dressmeup.body.registration.aim import aimed_candidates, unexplained_groups
from dressmeup.body.registration.hypotheses import align_directions
from dressmeup.body.registration.init import capped_distances, symmetric_score
from dressmeup.body.registration.problem import Objective
from dressmeup.body.registration.search import Candidate, best_of
from dressmeup.body.registration.stages import SIZE_RATE, run_adam
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
#: hypotheses; the setting ``limb_first_knee_bends``). No 140: from the hypotheses' rough
#: body a shin folded up into a skirt or dress explains cloth and outscores the hanging
#: one; the later searches, from a settled body, still try 140.
FIRST_KNEE_BENDS: tuple[float, ...] = (0.0, 50.0, 100.0)
#: twists about each upper-limb direction of the grid (evenly spaced)
TWISTS = 6
#: a limb moves only if its best candidate lowers the symmetric score by more than this (m)
MIN_GAIN = 2e-4
#: cap (m) of both directions of the score that decides the limb searches
SCORE_CAP = 0.1


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

    def score(self, M_up: np.ndarray, M_lo: np.ndarray, above: float = math.inf) -> float:
        """Symmetric capped distance (m) with the limb moved (same value as
        ``symmetric_score`` for the identity, up to the skinning blend near the joints);
        ``math.inf`` when it is surely above ``above`` (a lower bound of the score exceeds
        it: the remaining queries are skipped; a search needs no more of a candidate that
        cannot beat its best)."""
        X = self.points(M_up, M_lo)
        cut = above * (1.0 + 1e-9) + 1e-12  # float rounding of the bounds on the safe side
        if above < math.inf:  # every distance is >= 0: a quarter of the limb bounds b below
            part = float(capped_distances(self.tree, X[::4], self.cap).sum())
            if (self.const_body + part) / self.n_b + self.const_scan / self.n_p > cut:
                return math.inf
        b = float(capped_distances(self.tree, X, self.cap).sum())
        if (self.const_body + b) / self.n_b + self.const_scan / self.n_p > cut:
            return math.inf
        # Only a scan point nearer the limb's bounding box than to the rest of the body can
        # get closer (the margin keeps float rounding of the box distance on the safe side),
        # so only those are queried: the same sum, term for term (benchmarks/perf/limb_scorer.py).
        gap = np.linalg.norm(np.maximum(np.maximum(X.min(0) - self.P_near,
                                                   self.P_near - X.max(0)), 0.0), axis=1)
        near = gap < self.d_near + 1e-9
        d = self.d_near.copy()
        if above < math.inf:  # the points that cannot come nearer keep their distance
            kept = float(d[~near].sum())
            if (self.const_body + b) / self.n_b + (self.const_scan + kept) / self.n_p > cut:
                return math.inf
        if near.any():
            d_limb, _ = NearestTree(X).query(self.P_near[near],
                                             distance_upper_bound=self.scan_cap)
            d[near] = np.minimum(d[near], d_limb)
        return (self.const_body + b) / self.n_b + (self.const_scan + float(d.sum())) / self.n_p


def grid_candidates(twists: int, bends_deg) -> list[tuple]:
    """(direction, twist rad, bend rad) triples of the cube grid: each cube direction
    unbent, then each with every twist and every bend above 0 (degrees ``bends_deg``)."""
    out = [(d, 0.0, 0.0) for d in cube_directions()]
    for d in cube_directions():
        for k in range(twists):
            for b in bends_deg:
                if b > 0:
                    out.append((d, 2 * math.pi * k / twists, math.radians(b)))
    return out


def limb_rotations(c_up, W_up, d, twist, bend, hinge, turns: dict | None = None):
    """World rotations (upper, lower) of a candidate: the upper bone turned from ``c_up``
    onto ``d`` then twisted about it, the lower bone bent about its hinge. ``W_up``: the
    upper joint's world rotation (a matrix or a ``Rotation``); ``turns``: a dict kept across
    the calls of one limb (same ``c_up``), caching the turn of each (direction, twist), the
    same product in the same order, so the same floats."""
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
                bends_deg, top: int = 3, rounds: int = 2, extra=(), grid=None) -> tuple[
                    float, float, np.ndarray, np.ndarray]:
    """Best configuration of one limb by the grid (:func:`grid_candidates`, or
    ``grid(c_up)`` for a limb pointing along ``c_up`` when given) and the ``extra``
    candidates (e.g. :func:`.aim.aimed_candidates`), then a pattern search around the
    ``top`` best. Returns (start score, best score, local rotvec upper, local rotvec
    lower); ``W`` (j, 3, 3) are the current world rotations of the joints. A candidate
    that cannot enter the ``top`` (or, in the pattern search, beat the current best) is
    not scored to the end (:meth:`LimbScorer.score`'s ``above``): the same result."""
    names = list(problem.model.joint_names)
    parent = int(problem.model.joint_parents[upper])
    W_par = Rotation.from_matrix(W[parent]) if parent >= 0 else Rotation.identity()
    c_up = scorer.J_lo - scorer.J_up
    c_up = c_up / max(np.linalg.norm(c_up), 1e-12)
    base = scorer.score(np.eye(3), np.eye(3))
    W_up_inv, W_lo_inv = W[upper].T, W[lower].T
    up_name, lo_name = names[upper], names[lower]
    R_W_up, W_par_inv, turns = Rotation.from_matrix(W[upper]), W_par.inv(), {}
    uppers: dict = {}  # (direction, twist) -> (R_up, upper within limits, its matrix)
    hinges: dict = {}  # bend -> (hinge rotation, lower within limits)

    def evaluate(d, twist, bend, above: float = math.inf):
        # the same products as limb_rotations, each computed once per direction and twist
        # (and per bend): the grid repeats them
        key = (np.asarray(d, np.float64).tobytes(), float(twist))
        if key not in uppers:
            R_up, _ = limb_rotations(c_up, R_W_up, d, twist, 0.0, hinge, turns)
            uppers[key] = (R_up, _within_limits(up_name, (W_par_inv * R_up).as_rotvec()),
                           R_up.as_matrix() @ W_up_inv)
        if bend not in hinges:
            rotvec = np.asarray(hinge) * bend
            hinges[bend] = (Rotation.from_rotvec(rotvec), _within_limits(lo_name, rotvec))
        (R_up, up_ok, M_up), (turn_lo, lo_ok) = uppers[key], hinges[bend]
        if not (up_ok and lo_ok):
            return math.inf
        return scorer.score(M_up, (R_up * turn_lo).as_matrix() @ W_lo_inv, above)

    grid = grid_candidates(twists, bends_deg) if grid is None else grid(c_up)
    scored, kept = [], []  # kept: the ``top`` lowest scores so far
    for c in [*grid, *extra]:  # a candidate that cannot enter the top is not scored fully
        s = evaluate(*c, above=kept[-1] if len(kept) == top else math.inf)
        scored.append((s, c))
        if s < math.inf:
            kept = sorted([*kept, s])[:top]
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
                s = evaluate(*m, above=cur[0])
                if s < cur[0]:
                    cur = (s, m)
        if cur[0] < best[0]:
            best = cur
    d, t, b = best[1]
    R_up, _ = limb_rotations(c_up, R_W_up, d, t, b, hinge, turns)
    return base, best[0], (W_par_inv * R_up).as_rotvec(), np.asarray(hinge) * b


def move_limbs(problem, aim: str, knee_bends, elbow_bends, grid=None) -> list[str]:
    """Move each arm and leg of ``problem`` in turn to its best grid (or ``grid(c_up)``) or aimed
    configuration when that lowers the symmetric score by more than :data:`MIN_GAIN`
    (scored with the limb moved rigidly, the body model not run); return the upper joints
    of the limbs moved. ``aim``: ``"none"``, ``"arms"`` or ``"all"`` (the limbs whose
    aimed candidates, :func:`.aim.aimed_candidates`, join the grid's; the unexplained scan
    is found again before each limb, so a group one limb took is not chased again)."""
    # heavy: torch (~1.1 s to import)
    import torch

    model = problem.model
    names = list(model.joint_names)
    parents = np.asarray(model.joint_parents)
    dom = problem.W_sub.cpu().numpy().argmax(1)
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
                            scan_cap=SCORE_CAP)
        extra = []
        if aim == "all" or (aim == "arms" and up_name.endswith("shoulder")):
            groups = unexplained_groups(problem.P, V)
            below = [j for j in range(len(parents)) if parents[j] == lower]
            end_mask = np.isin(dom, _descendants(parents, below[0])) if below else lo_mask
            if groups and end_mask.any():
                extra = aimed_candidates(W[upper], W[lower], J[upper], J[lower],
                                         V[end_mask].mean(0), hinge, groups)
        bends = knee_bends if up_name.endswith("hip") else elbow_bends
        base, best, rv_up, rv_lo = search_limb(problem, scorer, upper, lower, hinge, W, TWISTS,
                                               bends, extra=extra, grid=grid)
        logger.info("limb %s: %.4f -> %.4f", up_name, base, best)
        if best < base - MIN_GAIN:
            with torch.no_grad():
                problem.pose[upper] = torch.as_tensor(rv_up, dtype=problem.dt)
                problem.pose[lower] = torch.as_tensor(rv_lo, dtype=problem.dt)
            moved.append(up_name)
            posed = None
    return moved


def limb_search(problem, spec, objective: Objective, verbose: bool = False,
                grid=None) -> dict:
    """Try other directions for each arm and leg of the current fit (see module docstring);
    leaves the better of (start, start with moved limbs + a settling pose stage) in
    ``problem`` by the symmetric score (:func:`.search.best_of`; equal: the start).

    Parameters
    ----------
    spec : the :class:`~dressmeup.body.registration.plan.LimbSearch` stage (aim, knee and
        elbow bends, settling steps, whether the temporary scale settles too, rates).
    objective : the objective of the settling steps.
    grid : ``grid(c_up) -> candidates`` in place of the cube grid (:func:`grid_candidates`)
        for a limb now pointing along the unit vector ``c_up``.

    Returns
    -------
    info : ``{"limbs_moved": [joint names], "limb_score": (before, after) m, "limb_kept":
    bool}``.
    """
    start = problem.snapshot()
    moved = move_limbs(problem, spec.aim, spec.knee_bends, spec.elbow_bends, grid=grid)
    info = {"limbs_moved": moved, "limb_kept": False}
    if not moved:
        score = round(symmetric_score(problem, scan_cap=SCORE_CAP), 5)
        return {**info, "limb_score": (score, score)}
    with_moves = problem.snapshot()
    params = [problem.pose, problem.transl] + ([problem.log_scale] if spec.size else [])
    lrs = [spec.rates.pose, spec.rates.transl] + ([SIZE_RATE] if spec.size else [])

    def settled(p) -> None:
        p.restore(with_moves)
        run_adam(p, objective, spec.pose_steps, params, lrs, label="limb search pose",
                 verbose=verbose)

    ranked = best_of(problem, [Candidate("start", lambda p: p.restore(start)),
                               Candidate("moved", settled)],
                     lambda p, _: symmetric_score(p, scan_cap=SCORE_CAP))
    scores = {c.name: c.score for c in ranked}
    info.update(limb_score=(round(scores["start"], 5), round(scores["moved"], 5)),
                limb_kept=ranked[0].name == "moved")
    logger.info("limb search: moved %s, score %.4f -> %.4f (%s)", moved, scores["start"],
                scores["moved"], "kept" if info["limb_kept"] else "dropped")
    return info
