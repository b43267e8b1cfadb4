"""Where a fit starts: placement on the scan, yaw search, pose hypotheses.

- :func:`place_on_scan`: centre the body on the scan and (upright scans without
  keypoints) match the vertical extent with a temporary uniform scale, which the shape takes
  over in the last stage (limb lengths then need not be faked by bending the knees).
- :func:`yaw_search`: from the current pose, try root yaw angles with a short rigid
  stage fitting the torso, hips and head, keep the best.
- :func:`hypothesis_search`: the multi-hypothesis start without keypoints. From the A-pose,
  the best yaws of the yaw search x the canonical poses of :mod:`.hypotheses` each get a
  short rigid stage on the whole body; the best few get a short pose stage; the best of
  those goes on. Cost: ``yaw_candidates * n_yaw + len(poses) * (yaws_kept + 1) * n_rigid +
  (keep + 1) * n_pose`` steps at most (the yaw opposite the best, :func:`kept_yaws`; the
  hypothesis facing away, :func:`refined_hypotheses`).
- :func:`keypoint_start`: the canonical pose that fits given or detected 3D keypoints.

Every "several candidates, keep the best" here goes through :func:`.search.best_of`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from dressmeup.body.registration.hypotheses import canonical_pose
from dressmeup.body.registration.problem import Objective
from dressmeup.body.registration.search import Candidate, Scored, best_of
from dressmeup.body.registration.stages import SIZE_RATE, run_adam
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


def yaw_search(problem, objective: Objective, n_steps: int, rates,
               yaws=(0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi),
               verbose: bool = False) -> list[Scored]:
    """Try each root yaw (radians about +y) from the current pose with ``n_steps`` rigid
    steps on the core joints' skin (``objective`` as the stages', made rigid and core-only);
    keep the best and return every candidate, best first, scored by the core data cost of
    its last step (``info["yaw"]``: its start yaw).

    Candidates are compared on the torso, hips and head only: with the limbs, a wrong yaw
    can win (A-pose arms sideways match a walking scan's legs seen from the side).
    """
    # heavy: torch (~1.1 s to import)
    import torch

    rigid = replace(objective, stage="global", core_only=True)

    def turned(yaw: float) -> Candidate:
        def run(p) -> dict:
            with torch.no_grad():
                p.pose[0] = torch.tensor([0.0, yaw, 0.0], dtype=p.dt)
            label = f"yaw {math.degrees(yaw):.0f}"
            terms = run_adam(p, rigid, n_steps, [p.pose, p.transl], [rates.pose, rates.transl],
                             label=label, verbose=verbose)
            logger.info("%s: core data %.4f", label, terms["data"])
            return {"yaw": yaw, "core_data": terms["data"]}
        return Candidate(f"yaw {math.degrees(yaw):.0f}", run)

    return best_of(problem, [turned(y) for y in yaws], lambda p, info: info["core_data"],
                   start=problem.snapshot())


def kept_yaws(ranked: list[Scored], n_kept: int) -> list[Scored]:
    """The yaw candidates that go on to the pose hypotheses: the ``n_kept`` best and also
    the candidate that started facing the opposite way of the best, if it is not among
    them. A torso alone is nearly symmetric front to back: a body bent forward and one
    leaning back facing the other way fit its core alike, and only the whole body (legs,
    arms, feet) tells them apart in the hypothesis stage.

    Parameters
    ----------
    ranked : yaw candidates best first (:func:`yaw_search`; ``info["yaw"]`` in rad).
    n_kept : how many of the best go on (at least 1).
    """
    out = list(ranked[:max(int(n_kept), 1)])
    target = ranked[0].info["yaw"] + math.pi
    for cand in ranked[len(out):]:
        if abs(math.remainder(cand.info["yaw"] - target, 2 * math.pi)) < 1e-6:
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
    leaves unexplained (smaller caps than 0.1 m made the limb searches worse on tuning
    data).
    """
    scan_cap = cap if scan_cap is None else scan_cap
    V = problem.posed_numpy()[problem.body_ids]
    d1 = capped_distances(problem.tree, V, cap)
    d2 = capped_distances(NearestTree(V), problem.P, scan_cap)
    return float(d1.mean() + d2.mean())


def compose_root(heading: np.ndarray, tilt: np.ndarray) -> np.ndarray:
    """Axis-angle (3,) of a hypothesis' root: its own ``tilt`` (e.g. a deep bend's forward
    lean, in the model frame) first, then the search's ``heading`` (the yaw search's root)."""
    return (Rotation.from_rotvec(heading) * Rotation.from_rotvec(tilt)).as_rotvec()


def hypothesis_search(problem, spec, objective: Objective, verbose: bool = False) -> dict:
    """Multi-hypothesis start (see module docstring); leaves the best in ``problem``.

    Parameters
    ----------
    spec : the :class:`~dressmeup.body.registration.plan.HypothesisSearch` stage (poses,
        yaw candidates, yaws and hypotheses kept, step counts, learning rates).
    objective : the objective of its pose steps (its rigid steps use it as ``global``;
        the yaw candidates, core-only).

    Returns
    -------
    info : dict with the ranked hypotheses (name, yaw in degrees, symmetric score) and the
    step count.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    model, rates = problem.model, spec.rates
    n_yaw, n_rigid, n_pose = spec.steps
    rest = model.posed(model.default_params()).joints
    n = max(spec.yaw_candidates, 1)
    yaws = tuple(2 * math.pi * k / n for k in range(n))
    problem.set_params(pose=canonical_pose("a-pose", model.joint_names, rest))
    place_on_scan(problem, True)
    ranked = yaw_search(problem, objective, n_yaw, rates, yaws=yaws, verbose=verbose)
    roots = [c.snapshot["pose"][0].clone() for c in kept_yaws(ranked, spec.yaws_kept)]
    rigid_objective = replace(objective, stage="global")

    def rigid(name: str, root) -> Candidate:
        def run(p) -> dict:
            hyp = canonical_pose(name, model.joint_names, rest)
            p.set_params(pose=hyp, scale=1.0)
            with torch.no_grad():  # untilted: the heading as is (a round trip through
                # scipy would move its last bits, and with them every fit)
                p.pose[0] = root if not hyp[0].any() else torch.as_tensor(
                    compose_root(root.cpu().numpy(), hyp[0]), dtype=p.dt)
            place_on_scan(p, True)
            run_adam(p, rigid_objective, n_rigid, [p.pose, p.transl], [rates.pose, rates.transl],
                     label=f"hypothesis {name}", verbose=verbose)
            return {"yaw": math.degrees(float(root.norm()) * float(torch.sign(root[1]) or 1.0))}
        return Candidate(name, run)

    def refined(cand: Scored) -> Candidate:
        def run(p) -> dict:
            p.restore(cand.snapshot)
            run_adam(p, objective, n_pose, [p.pose, p.transl, p.log_scale],
                     [rates.pose, rates.transl, SIZE_RATE], label=f"hypothesis {cand.name} pose",
                     verbose=verbose)
            return cand.info
        return Candidate(cand.name, run)

    def score(p, info) -> float:
        return symmetric_score(p)

    hypotheses = best_of(problem, [rigid(name, root) for name in spec.hypotheses
                                   for root in roots], score)
    finals = best_of(problem, [refined(c) for c in refined_hypotheses(hypotheses, spec.keep)],
                     score)
    logger.info("hypotheses: %s", ", ".join(f"{c.name}@{c.info['yaw']:.0f} {c.score:.3f}"
                                            for c in finals))
    best = finals[0]
    return {"init": f"hypothesis {best.name} (yaw {best.info['yaw']:.0f} deg)",
            "hypotheses_rigid": [(c.name, round(c.info["yaw"]), round(c.score, 4))
                                 for c in hypotheses],
            "hypotheses_refined": [(c.name, round(c.info["yaw"]), round(c.score, 4))
                                   for c in finals],
            "init_steps": len(yaws) * n_yaw + len(hypotheses) * n_rigid + len(finals) * n_pose}


def refined_hypotheses(rigid: list[Scored], keep: int) -> list[Scored]:
    """The rigid hypotheses that get the short pose stage: the ``keep`` best and, when all
    of them face within 90 degrees of the best, also the best one facing further away,
    refined last (so it changes the fit only when it wins). A rigid stage ranks a bent
    torso and an upright body facing the other way alike (a torso bent over its legs with
    the arms hanging looks, from its back, like a body sitting with its thighs forward);
    the pose stage is what tells them apart.

    Parameters
    ----------
    rigid : scored hypotheses best first, ``info["yaw"]`` in degrees.
    """
    out = list(rigid[:max(int(keep), 1)])
    if rigid:
        best = rigid[0].info["yaw"]

        def away(h: Scored) -> bool:
            return abs(math.remainder(h.info["yaw"] - best, 360.0)) > 90.0

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


def keypoint_start(problem, spec, objective: Objective, verbose: bool = False) -> dict:
    """Start from 3D keypoints: each canonical pose of ``spec`` (a
    :class:`~dressmeup.body.registration.plan.KeypointStart`) is aligned to the keypoints by
    a similarity transform (closed form), the best one is placed (rotation as the root, the
    scale as the temporary size) and ``spec.pose_steps`` steps of ``objective`` fit
    keypoints and scan together.

    Returns info like :func:`hypothesis_search`.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    model, rates = problem.model, spec.rates
    ids, targets = problem.kp
    if len(ids) < 4:
        raise ValueError("keypoint_start: need at least 4 keypoints")
    rest = model.posed(model.default_params()).joints
    ranked = []
    for name in spec.hypotheses:
        hyp = canonical_pose(name, model.joint_names, rest)
        params = model.default_params()
        params.pose = hyp
        R, s, _, rms = _rigid_similarity(model.posed(params).joints[ids], targets)
        ranked.append((rms, name, hyp, R, s))
    ranked.sort(key=lambda r: r[0])
    rms, name, hyp, R, s = ranked[0]
    pose = hyp.copy()
    pose[0] = (Rotation.from_matrix(R) * Rotation.from_rotvec(hyp[0])).as_rotvec()
    problem.set_params(pose=pose, scale=float(np.clip(s, 0.5, 1.5)))
    # translation: the posed joints onto the keypoints (mean offset)
    with torch.no_grad():
        out = model.forward(problem.shape_value()[None], problem.pose[None], None,
                            torch.exp(problem.log_scale)[None])
        J = out.joints[0].cpu().numpy()[ids]
    problem.set_params(transl=(targets - J).mean(0))
    run_adam(problem, objective, spec.pose_steps, [problem.pose, problem.transl, problem.log_scale],
             [rates.pose, rates.transl, SIZE_RATE], label="keypoint start", verbose=verbose)
    yaw = math.degrees(Rotation.from_rotvec(problem.pose[0].detach().cpu().numpy()).as_euler("YXZ")[0])
    logger.info("keypoint start: %s (rms %.3f m)", name, rms)
    return {"init": f"keypoints + {name} (yaw {yaw:.0f} deg)",
            "hypotheses_keypoint_rms": [(n, round(r, 4)) for r, n, *_ in ranked],
            "init_score": symmetric_score(problem), "init_steps": spec.pose_steps}
