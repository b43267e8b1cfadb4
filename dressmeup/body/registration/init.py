"""Where a fit starts: placement on the scan, yaw search, pose hypotheses.

- :func:`place_on_scan`: centre the body on the scan and (upright scans without
  keypoints) match the vertical extent with a temporary uniform scale, which the shape takes
  over in the last stage (limb lengths then need not be faked by bending the knees).
- :func:`yaw_search`: from the current pose, try 4 root yaw angles with a short rigid
  stage fitting the torso, hips and head, keep the best.
- :func:`hypothesis_search`: the multi-hypothesis start without keypoints. The best yaws of
  the yaw search x the canonical poses of :mod:`.hypotheses` each get a short rigid stage
  on the whole body; the best few get a short pose stage; the best of those goes on.
  Cost: ``len(yaw_postures) * yaw_candidates * n_yaw + len(poses) * (yaws_kept + 1) *
  n_rigid + (keep + 1) * n_pose`` steps at most (the yaw opposite the best,
  :func:`kept_yaws`; the hypothesis facing away, :func:`refined_hypotheses`).
"""

from __future__ import annotations

import logging
import math

import numpy as np

from dressmeup.body.registration.hypotheses import UPRIGHT_HYPOTHESES, canonical_pose
from dressmeup.body.registration.stages import run_adam
from dressmeup.geometry.neighbors import NearestTree

logger = logging.getLogger(__name__)


def place_on_scan(problem, size_init: bool) -> None:
    """Translate (and with ``size_init`` scale) the current body onto the scan's centre."""
    # heavy: torch (~1.1 s to import)
    import torch

    V = problem.posed_numpy()
    scale = float(torch.exp(problem.log_scale.detach()))
    Vd = (V - problem.transl.detach().cpu().numpy()) / scale
    if size_init:
        ratio = float(np.ptp(problem.P[:, 1]) / max(np.ptp(Vd[:, 1]), 1e-6))
        scale = min(max(ratio, 0.5), 1.5)
        problem.set_params(scale=scale)
    problem.set_params(transl=problem.P.mean(0) - scale * surface_centroid(Vd, problem.model.faces))


def surface_centroid(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(3,) area-weighted centroid of a mesh surface: what the mean of uniformly sampled
    scan points estimates (the vertex mean leans towards densely meshed hands and face)."""
    tri = V[F]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return (tri.mean(1) * area[:, None]).sum(0) / max(float(area.sum()), 1e-12)


def yaw_search(problem, n_steps: int, lr_pose: float, lr_transl: float,
               yaws=(0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi),
               verbose: bool = False) -> list[tuple[float, dict, float]]:
    """Try each root yaw (radians about +y) from the current pose with ``n_steps`` rigid
    steps on the core joints' skin; keep the best and return every candidate as
    ``(core data cost, snapshot, start yaw)``, best first.

    Candidates are compared on the torso, hips and head only: with the limbs, a wrong yaw
    can win (A-pose arms sideways match a walking scan's legs seen from the side).
    """
    # heavy: torch (~1.1 s to import)
    import torch

    base = problem.snapshot()
    scored: list[tuple[float, dict]] = []
    problem.core_only = True
    try:
        for yaw in yaws:
            problem.restore(base)
            with torch.no_grad():
                problem.pose[0] = torch.tensor([0.0, yaw, 0.0], dtype=problem.dt)
            label = f"yaw {math.degrees(yaw):.0f}"
            terms = run_adam(problem, "global", n_steps, [problem.pose, problem.transl],
                             [lr_pose, lr_transl], label=label, verbose=verbose)
            logger.info("%s: core data %.4f", label, terms["data"])
            scored.append((terms["data"], problem.snapshot(), yaw))
    finally:
        problem.core_only = False
    scored.sort(key=lambda t: t[0])
    problem.restore(scored[0][1])
    return scored


def kept_yaws(ranked: list[tuple[float, dict, float]], n_kept: int,
              keep_opposite: bool) -> list[tuple[float, dict, float]]:
    """The yaw candidates that go on to the pose hypotheses: the ``n_kept`` best and
    (``keep_opposite``) also the candidate that started facing the opposite way of the
    best, if it is not among them. A torso alone is nearly symmetric front to back: a body
    bent forward and one leaning back facing the other way fit its core alike, and only the
    whole body (legs, arms, feet) tells them apart in the hypothesis stage.

    Parameters
    ----------
    ranked : ``(core cost, snapshot, start yaw rad)`` best first (:func:`yaw_search`).
    n_kept : how many of the best go on (at least 1).
    """
    out = list(ranked[:max(int(n_kept), 1)])
    if keep_opposite:
        target = ranked[0][2] + math.pi
        for cand in ranked[len(out):]:
            if abs(math.remainder(cand[2] - target, 2 * math.pi)) < 1e-6:
                out.append(cand)
    return out


def capped_distances(tree, X: np.ndarray, cap: float) -> np.ndarray:
    """(k,) distance (m) from each of ``X`` (k, 3) to its nearest point in ``tree`` (a
    :class:`~dressmeup.geometry.neighbors.NearestTree` or a ``cKDTree``), capped at ``cap``:
    the same values as ``minimum(tree.query(X)[0], cap)``, but the search stops at ``cap``
    (a far limb's points cost a fraction of a full search)."""
    d, _ = tree.query(X, k=1, distance_upper_bound=cap, workers=1)
    return np.minimum(d, cap)


def symmetric_score(problem, cap: float = 0.1, scan_cap: float | None = None) -> float:
    """Mean capped nearest-neighbour distance (m) body -> scan (capped at ``cap``) plus
    scan -> body (capped at ``scan_cap``; None: ``cap``).

    Hypotheses are ranked by this, not by the fit's one-sided data term: that term forgives
    scan points outside the body (clothes), so a body with its arms down would look as good
    as one with its arms out on a T-pose scan. The scan -> body cap decides what loose cloth
    is worth: with a cap above the cloth's distance from the body, a limb folded up into a
    skirt or dress explains cloth points and can outscore the right limb, whose bare shin it
    leaves unexplained (the limb search's option ``limb_scan_cap``).
    """
    scan_cap = cap if scan_cap is None else scan_cap
    V = problem.posed_numpy()[problem.body_ids]
    d1 = capped_distances(problem.tree, V, cap)
    d2 = capped_distances(NearestTree(V), problem.P, scan_cap)
    return float(d1.mean() + d2.mean())


def compose_root(heading: np.ndarray, tilt: np.ndarray) -> np.ndarray:
    """Axis-angle (3,) of a hypothesis' root: its own ``tilt`` (e.g. a deep bend's forward
    lean, in the model frame) first, then the search's ``heading`` (the yaw search's root)."""
    # heavy: scipy (~0.5 s to import)
    from scipy.spatial.transform import Rotation

    return (Rotation.from_rotvec(heading) * Rotation.from_rotvec(tilt)).as_rotvec()


def hypothesis_search(problem, poses, n_yaw: int, n_rigid: int, n_pose: int, keep: int,
                      yaws_kept: int, lr_pose: float, lr_transl: float, size_init: bool,
                      verbose: bool = False, yaw_candidates: int = 4,
                      keep_opposite: bool = True, refine_opposite: bool = False,
                      yaw_postures: tuple[str, ...] = ("a-pose",)) -> dict:
    """Multi-hypothesis start (see module docstring); leaves the best in ``problem``.

    Parameters
    ----------
    poses : names of :data:`~dressmeup.body.registration.hypotheses.CANONICAL_POSES`.
    n_yaw, n_rigid, n_pose : steps of the yaw candidates, of the whole-body rigid stage of
        each (pose, yaw) hypothesis, and of the short pose stage of the ``keep`` best.
    yaws_kept : how many of the ``yaw_candidates`` yaws go on to the pose hypotheses.
    yaw_candidates : yaws tried on the core, evenly spaced over the full turn.
    size_init : match each hypothesis' vertical extent to the scan with a uniform scale.
    keep_opposite : the yaw facing opposite the best is always among the kept yaws
        (:func:`kept_yaws`).
    refine_opposite : also refine the best rigid hypothesis facing away from the best one
        when none of the ``keep`` best does (:func:`refined_hypotheses`).
    yaw_postures : canonical poses (untilted roots) the yaw search runs from, each over the
        ``yaw_candidates`` yaws; every start yaw keeps its best core cost over the postures
        (:func:`best_per_start_yaw`). An upright torso ranks a deeply bent scan's headings
        almost at random; a bent one ranks them.

    Returns
    -------
    info : dict with the ranked hypotheses (name, yaw in degrees, data cost) and step counts.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    model = problem.model
    rest = model.posed(model.default_params()).joints
    yaws = tuple(2 * math.pi * k / max(yaw_candidates, 1) for k in range(max(yaw_candidates, 1)))
    rankings = []
    for posture in yaw_postures:
        if posture not in UPRIGHT_HYPOTHESES:
            raise ValueError(f"yaw_postures: {posture!r} tilts the root; a yaw search "
                             "posture must not (its root is the heading)")
        problem.set_params(pose=canonical_pose(posture, model.joint_names, rest))
        place_on_scan(problem, size_init)
        rankings.append(yaw_search(problem, n_yaw, lr_pose, lr_transl, yaws=yaws,
                                   verbose=verbose))
    ranked_yaws = best_per_start_yaw(rankings)
    roots = [snap["pose"][0].clone()
             for _, snap, _ in kept_yaws(ranked_yaws, yaws_kept, keep_opposite)]
    rigid: list[tuple[float, str, float, dict]] = []
    for name in poses:
        hyp = canonical_pose(name, model.joint_names, rest)
        for root in roots:
            problem.set_params(pose=hyp, scale=1.0)
            with torch.no_grad():  # untilted: the heading as is (a round trip through
                # scipy would move its last bits, and with them every fit)
                problem.pose[0] = root if not hyp[0].any() else torch.as_tensor(
                    compose_root(root.cpu().numpy(), hyp[0]), dtype=problem.dt)
            place_on_scan(problem, size_init)
            run_adam(problem, "global", n_rigid, [problem.pose, problem.transl],
                     [lr_pose, lr_transl], label=f"hypothesis {name}", verbose=verbose)
            yaw = math.degrees(float(root.norm()) * float(torch.sign(root[1]) or 1.0))
            rigid.append((symmetric_score(problem), name, yaw, problem.snapshot()))
    rigid.sort(key=lambda t: t[0])
    refined: list[tuple[float, str, float, dict]] = []
    for _, name, yaw, snap in refined_hypotheses(rigid, keep, refine_opposite):
        problem.restore(snap)
        params = [problem.pose, problem.transl]
        lrs = [lr_pose, lr_transl]
        if size_init:
            params.append(problem.log_scale)
            lrs.append(0.003)
        run_adam(problem, "pose", n_pose, params, lrs, label=f"hypothesis {name} pose",
                 verbose=verbose)
        refined.append((symmetric_score(problem), name, yaw, problem.snapshot()))
    refined.sort(key=lambda t: t[0])
    problem.restore(refined[0][3])
    logger.info("hypotheses: %s", ", ".join(f"{n}@{y:.0f} {c:.3f}" for c, n, y, _ in refined))
    return {"init": f"hypothesis {refined[0][1]} (yaw {refined[0][2]:.0f} deg)",
            "hypotheses_rigid": [(n, round(y), round(c, 4)) for c, n, y, _ in rigid],
            "hypotheses_refined": [(n, round(y), round(c, 4)) for c, n, y, _ in refined],
            "init_steps": len(yaw_postures) * len(yaws) * n_yaw + len(rigid) * n_rigid
            + len(refined) * n_pose}


def best_per_start_yaw(rankings: list[list[tuple[float, dict, float]]]
                       ) -> list[tuple[float, dict, float]]:
    """Merge :func:`yaw_search` results from several postures: for each start yaw the
    candidate with the lowest core cost (the costs compare: same scan, same core skin),
    best first. One ranking is returned as is."""
    if len(rankings) == 1:
        return rankings[0]
    best: dict[float, tuple[float, dict, float]] = {}
    for ranked in rankings:
        for cand in ranked:
            if cand[2] not in best or cand[0] < best[cand[2]][0]:
                best[cand[2]] = cand
    return sorted(best.values(), key=lambda t: t[0])


def refined_hypotheses(rigid: list[tuple], keep: int, opposite: bool) -> list[tuple]:
    """The rigid hypotheses that get the short pose stage: the ``keep`` best and
    (``opposite``), when all of them face within 90 degrees of the best, also the best one
    facing further away, refined last (so it changes the fit only when it wins). A rigid
    stage ranks a bent torso and an upright body facing the other way alike (a torso bent
    over its legs with the arms hanging looks, from its back, like a body sitting with its
    thighs forward); the pose stage is what tells them apart.

    Parameters
    ----------
    rigid : ``(score, name, yaw degrees, snapshot)`` best first.
    """
    out = list(rigid[:max(int(keep), 1)])
    if opposite and rigid:
        best = rigid[0][2]

        def away(h) -> bool:
            return abs(math.remainder(h[2] - best, 360.0)) > 90.0

        if not any(away(h) for h in out):
            out += [h for h in rigid[len(out):] if away(h)][:1]
    return out


def _rigid_similarity(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, float, np.ndarray, float]:
    """Least-squares ``s R A + t ~ B`` (Umeyama) for (k, 3) point sets; returns
    (R (3,3), s, t (3,), rms residual)."""
    ca, cb = A.mean(0), B.mean(0)
    A0, B0 = A - ca, B - cb
    U, S, Vt = np.linalg.svd(B0.T @ A0)
    D = np.eye(3)
    D[2, 2] = np.sign(np.linalg.det(U @ Vt))
    R = U @ D @ Vt
    s = float((S * np.diag(D)).sum() / max((A0 ** 2).sum(), 1e-12))
    t = cb - s * R @ ca
    rms = float(np.sqrt((((s * A @ R.T + t) - B) ** 2).sum(1).mean()))
    return R, s, t, rms


def keypoint_start(problem, poses, n_pose: int, lr_pose: float, lr_transl: float,
                   size_init: bool, verbose: bool = False) -> dict:
    """Start from 3D keypoints: each canonical pose is aligned to the keypoints by a
    similarity transform (closed form), the best one is placed (rotation as the root, the
    scale as the temporary size) and ``n_pose`` pose steps fit keypoints and scan together.

    Returns info like :func:`hypothesis_search`.
    """
    # heavy: torch (~1.1 s to import), scipy (~0.5 s to import)
    import torch
    from scipy.spatial.transform import Rotation

    model = problem.model
    ids, targets = problem.kp
    if len(ids) < 4:
        raise ValueError("keypoint_start: need at least 4 keypoints")
    rest_params = model.default_params()
    ranked = []
    for name in poses:
        hyp = canonical_pose(name, model.joint_names, model.posed(rest_params).joints)
        rest_params.pose = hyp
        J = model.posed(rest_params).joints[ids]
        R, s, t, rms = _rigid_similarity(J, targets)
        ranked.append((rms, name, hyp, R, s))
    ranked.sort(key=lambda r: r[0])
    rms, name, hyp, R, s = ranked[0]
    pose = hyp.copy()
    pose[0] = (Rotation.from_matrix(R) * Rotation.from_rotvec(hyp[0])).as_rotvec()
    scale = float(np.clip(s, 0.5, 1.5)) if size_init else 1.0
    problem.set_params(pose=pose, scale=scale)
    # translation: the posed joints onto the keypoints (mean offset)
    with torch.no_grad():
        out = model.forward(problem.shape_value()[None], problem.pose[None], None,
                            torch.exp(problem.log_scale)[None])
        J = out.joints[0].cpu().numpy()[ids]
    problem.set_params(transl=(targets - J).mean(0))
    params, lrs = [problem.pose, problem.transl], [lr_pose, lr_transl]
    if size_init:
        params.append(problem.log_scale)
        lrs.append(0.003)
    run_adam(problem, "pose", n_pose, params, lrs, label="keypoint start", verbose=verbose)
    yaw = math.degrees(Rotation.from_rotvec(problem.pose[0].detach().cpu().numpy()).as_euler("YXZ")[0])
    logger.info("keypoint start: %s (rms %.3f m)", name, rms)
    return {"init": f"keypoints + {name} (yaw {yaw:.0f} deg)",
            "hypotheses_keypoint_rms": [(n, round(r, 4)) for r, n, *_ in ranked],
            "init_score": symmetric_score(problem), "init_steps": n_pose}
