"""Registration: fit a body model to a scan (clothed or not) by optimisation in torch.

``register(scan, model, init=None, keypoints=None, ...) -> BodyParams`` runs three stages
with Adam on axis-angle pose, translation and shape (``scale`` stays fixed, 1 by default):

1. **global**: root orientation and translation (plus a search over 4 yaw angles when no
   ``init`` is given), from the model's zero pose and average shape placed at the scan;
2. **pose**: all joint rotations and translation, shape fixed;
3. **shape**: shape, pose and translation together.

Data term (both directions, correspondences by nearest neighbour, recomputed every step):
residuals are measured along the body's outward normal, ``r = (body - scan) . n``. A body
point *outside* the scan (``r > 0`` body-to-scan, or a scan point inside the body) costs a
Geman-McClure penalty of scale ``sigma_out``; *inside* (clothing, ``r < 0``) costs
``inside_weight`` times a Geman-McClure of the smaller scale ``sigma_in``, which saturates
for cloth a few centimetres off the skin, so loose clothing does not inflate the body.
A point-to-point term with a small weight keeps correspondences from sliding.
Priors: squared norm of the joint rotations (root excluded), soft joint limits
(:data:`JOINT_LIMITS`), and a shape regulariser (towards the model's average shape;
phenotype shapes are kept in [0, 1] by a sigmoid). Optional 3D keypoints pull the model's
joints. Registrars are looked up by name (:func:`get_registrar`): ``optimization`` (this
one) and ``from-file`` (imports precomputed parameters); external tools can add theirs
with :func:`add_registrar`.
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.body.skeleton import PHENOTYPE_NAMES, SMPL22_JOINT_NAMES
from dressmeup.errors import InputError

logger = logging.getLogger(__name__)

#: Soft limits (radians) on the axis-angle components (x, y, z) of the SMPL-like joints in
#: the SMPL frame (y up, facing +z, left on +x). Knees bend one way; elbows bend forward.
JOINT_LIMITS: dict[str, tuple[tuple[float, float], ...]] = {
    "left_hip": ((-2.6, 0.9), (-1.0, 1.0), (-0.5, 1.2)),
    "right_hip": ((-2.6, 0.9), (-1.0, 1.0), (-1.2, 0.5)),
    "left_knee": ((-0.15, 2.7), (-0.3, 0.3), (-0.3, 0.3)),
    "right_knee": ((-0.15, 2.7), (-0.3, 0.3), (-0.3, 0.3)),
    "left_elbow": ((-0.6, 0.6), (-2.7, 0.15), (-0.6, 0.6)),
    "right_elbow": ((-0.6, 0.6), (-0.15, 2.7), (-0.6, 0.6)),
    "spine1": ((-0.6, 1.0), (-0.5, 0.5), (-0.5, 0.5)),
    "spine2": ((-0.5, 0.7), (-0.5, 0.5), (-0.4, 0.4)),
    "spine3": ((-0.5, 0.7), (-0.5, 0.5), (-0.4, 0.4)),
    "neck": ((-0.7, 0.9), (-0.9, 0.9), (-0.6, 0.6)),
    "head": ((-0.6, 0.7), (-0.9, 0.9), (-0.6, 0.6)),
    "left_collar": ((-0.4, 0.4), (-0.5, 0.5), (-0.5, 0.5)),
    "right_collar": ((-0.4, 0.4), (-0.5, 0.5), (-0.5, 0.5)),
    "left_ankle": ((-0.8, 0.9), (-0.6, 0.6), (-0.5, 0.5)),
    "right_ankle": ((-0.8, 0.9), (-0.6, 0.6), (-0.5, 0.5)),
    "left_foot": ((-0.5, 0.5), (-0.3, 0.3), (-0.3, 0.3)),
    "right_foot": ((-0.5, 0.5), (-0.3, 0.3), (-0.3, 0.3)),
    "left_wrist": ((-1.2, 1.2), (-1.0, 1.0), (-1.5, 1.5)),
    "right_wrist": ((-1.2, 1.2), (-1.0, 1.0), (-1.5, 1.5)),
}


#: Joints whose skin decides the yaw candidate (limbs excluded: their pose is unknown yet).
CORE_JOINTS = ("pelvis", "spine1", "spine2", "spine3", "neck", "head", "left_collar",
               "right_collar")

#: Joints held at their current rotation during the first third of the pose stage, so the
#: trunk and the proximal limb joints settle before hands, feet and head follow.
DISTAL_JOINTS = ("left_ankle", "right_ankle", "left_foot", "right_foot", "left_wrist",
                 "right_wrist", "head")

#: Per-joint multipliers of the pose prior: toes and ankles move little in scans, and their
#: rotation is poorly seen by the data, so they are held closer to the rest pose.
PRIOR_SCALE: dict[str, float] = {
    "left_foot": 50.0, "right_foot": 50.0, "left_ankle": 10.0, "right_ankle": 10.0,
    "left_collar": 10.0, "right_collar": 10.0,
}


@dataclass
class RegistrationResult:
    """What a fit returns besides the parameters: per-stage losses and timing."""

    params: BodyParams
    seconds: float
    losses: dict[str, float] = field(default_factory=dict)


# --------------------------------------------------------------------- scans
def prepare_scan(scan, n_points: int = 8000, seed: int = 0) -> np.ndarray:
    """Turn a scan into points (p, 3) float64.

    Parameters
    ----------
    scan : ``(V, F)`` tuple, an object with ``vertices``/``faces`` (trimesh), or (p, 3)
        points. Meshes are sampled uniformly by area (``n_points`` samples, seeded).
    """
    if hasattr(scan, "vertices") and hasattr(scan, "faces"):
        scan = (np.asarray(scan.vertices), np.asarray(scan.faces))
    if isinstance(scan, (tuple, list)) and len(scan) == 2:
        V = np.asarray(scan[0], dtype=np.float64)
        F = np.asarray(scan[1], dtype=np.int64)
        if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] == 0:
            raise InputError(f"scan vertices: expected shape (n, 3), got {V.shape}")
        if F.ndim != 2 or F.shape[1] != 3 or F.size == 0 or F.min() < 0 or F.max() >= len(V):
            raise InputError(f"scan faces: expected (m, 3) indices into the vertices, got {F.shape}")
        tri = V[F]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        if area.sum() <= 0:
            raise InputError("scan: all faces are degenerate")
        rng = np.random.default_rng(seed)
        fid = rng.choice(len(F), size=n_points, p=area / area.sum())
        u, v = rng.uniform(size=(2, n_points))
        flip = u + v > 1
        u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
        t = tri[fid]
        return t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    P = np.asarray(scan, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] < 10:
        raise InputError(f"scan: expected a mesh (V, F) or points (p, 3) with p >= 10, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise InputError("scan: contains NaN or infinite coordinates")
    if P.shape[0] > n_points:
        P = P[np.random.default_rng(seed).choice(P.shape[0], n_points, replace=False)]
    return P


def _keypoint_arrays(keypoints, model):
    """(j,3) array with NaN rows, or {name: xyz} -> (joint ids (k,), targets (k, 3))."""
    if keypoints is None:
        return None
    names = list(model.joint_names)
    if isinstance(keypoints, dict):
        ids, pts = [], []
        for name, xyz in keypoints.items():
            if name not in names:
                raise InputError(f"keypoints: unknown joint {name!r}; expected one of {names}")
            ids.append(names.index(name))
            pts.append(np.asarray(xyz, dtype=np.float64).reshape(3))
        return np.array(ids, dtype=np.int64), np.array(pts)
    K = np.asarray(keypoints, dtype=np.float64)
    if K.shape != (len(names), 3):
        raise InputError(f"keypoints: expected shape ({len(names)}, 3) (NaN rows for missing) or a "
                         f"dict of joint name -> xyz, got {K.shape}")
    ok = np.all(np.isfinite(K), axis=1)
    return np.flatnonzero(ok), K[ok]


def _gm(r2, sigma: float):
    """Geman-McClure of squared residuals, scaled to behave like r^2 near zero."""
    s2 = sigma * sigma
    return s2 * r2 / (r2 + s2)


def _numpy_vertex_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (n, 3) of a mesh."""
    tri = V[F]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    vn = np.zeros_like(V)
    for k in range(3):
        np.add.at(vn, F[:, k], fn)
    return vn / (np.linalg.norm(vn, axis=1, keepdims=True) + 1e-12)


# ------------------------------------------------------------------ registrar
@dataclass
class OptimizationRegistrar:
    """Fit by optimisation (see module docstring). All options are keyword arguments.

    Parameters
    ----------
    iterations : steps for the (global, pose, shape) stages.
    shape_in_pose_stage : let the shape move (at half rate) already in the pose stage, so
        limb lengths adapt before the pose settles (avoids tip-toe / bent-leg minima).
    refine_rounds, lbfgs_steps : optional final ICP-like L-BFGS rounds (0: off).
    inside_weight : weight of body-inside-scan residuals (1 for naked scans gives a
        symmetric term; the default 0.5 with the saturating ``sigma_in`` suits clothes too).
    sigma_out, sigma_in : Geman-McClure scales (m) of outside / inside residuals.
    pose_prior_weight, limit_weight, shape_weight, keypoint_weight : prior weights.
    n_scan_points, n_body_points : points used by the data term.
    correspondence_every : recompute scan-to-body nearest neighbours every this many steps.
    yaw_search : try 4 root yaw angles when no ``init`` is given; each gets
        ``n_global // 2`` rigid steps fitting the torso, hips and head
        (:data:`CORE_JOINTS`) to the scan, and the best goes on.
    optimize_scale : also fit the uniform ``scale`` (else the result has ``scale = 1``).
    size_init : without ``init``/keypoints, start from a uniform scale matching the scan's
        vertical extent, refined in the pose stage and handed over to the shape in the
        shape stage (a penalty pulls it back to 1).
    seed : sampling seed; device : torch device; verbose : progress bar.
    num_threads : torch threads during the fit (restored afterwards; None leaves torch's
        setting). One thread is fastest for these small problems on a shared CPU.
    """

    iterations: tuple[int, int, int] = (60, 160, 160)
    inside_weight: float = 0.5
    sigma_out: float = 0.15
    sigma_in: float = 0.01
    point_weight: float = 0.3
    pose_prior_weight: float = 1e-2
    limit_weight: float = 1e-2
    shape_weight: float = 1e-4
    keypoint_weight: float = 1.0
    n_scan_points: int = 8000
    n_body_points: int = 5000
    correspondence_every: int = 2
    refine_rounds: int = 0
    shape_in_pose_stage: bool = True
    lbfgs_steps: int = 10
    lr_pose: float = 0.015
    lr_transl: float = 0.01
    lr_shape: float = 0.05
    yaw_search: bool = True
    optimize_scale: bool = False
    size_init: bool = True
    seed: int = 0
    device: str = "cpu"
    num_threads: int | None = 1
    verbose: bool = True

    def fit(self, scan, model, init: BodyParams | None = None, keypoints=None) -> RegistrationResult:
        """Fit ``model`` to ``scan``; see :func:`register` for the arguments."""
        import torch

        previous = torch.get_num_threads()
        if self.num_threads:
            torch.set_num_threads(int(self.num_threads))
        try:
            return self._fit(scan, model, init, keypoints)
        finally:
            torch.set_num_threads(previous)

    def _fit(self, scan, model, init, keypoints) -> RegistrationResult:
        import torch
        from scipy.spatial import cKDTree

        from dressmeup.progress import progress

        t_start = time.perf_counter()
        dev = torch.device(self.device)
        dt = torch.float32
        P = prepare_scan(scan, self.n_scan_points, self.seed)
        kp = _keypoint_arrays(keypoints, model)
        tree = cKDTree(P)
        P_t = torch.as_tensor(P, dtype=dt, device=dev)
        rng = np.random.default_rng(self.seed)
        body_ids = np.sort(rng.choice(model.n_vertices, min(self.n_body_points, model.n_vertices),
                                      replace=False))
        body_ids_t = torch.as_tensor(body_ids, device=dev)
        j = len(model.joint_names)
        phenotype = tuple(getattr(model, "shape_names", ())) == PHENOTYPE_NAMES
        default_shape = np.asarray(model.default_shape, dtype=np.float64)

        # ---------------- parameters
        if init is not None:
            init.check_model(model)
            shape0 = np.r_[init.shape, default_shape[init.shape.size:]]
            pose0, transl0, scale0 = init.pose.copy(), init.transl.copy(), init.scale
        else:
            shape0, pose0, transl0, scale0 = default_shape.copy(), np.zeros((j, 3)), None, 1.0
        if phenotype:
            z0 = np.log(np.clip(shape0, 1e-3, 1 - 1e-3) / (1 - np.clip(shape0, 1e-3, 1 - 1e-3)))
        else:
            z0 = shape0
        shape_z = torch.tensor(z0, dtype=dt, device=dev, requires_grad=True)
        pose = torch.tensor(pose0, dtype=dt, device=dev, requires_grad=True)
        log_scale = torch.tensor(math.log(scale0), dtype=dt, device=dev, requires_grad=True)

        def shape_value():
            return torch.sigmoid(shape_z) if phenotype else shape_z

        if transl0 is None:  # place the body's centre on the scan's centre
            with torch.no_grad():
                out = model.forward(shape_value()[None], pose[None])
                Vd = out.vertices[0].cpu().numpy()
            if self.size_init and kp is None:
                # Upright scan: match the vertical extent with a temporary uniform scale,
                # which the shape takes over in the last stage (limb lengths then need not
                # be faked by bending the knees).
                ratio = float(np.ptp(P[:, 1]) / max(np.ptp(Vd[:, 1]), 1e-6))
                with torch.no_grad():
                    log_scale.fill_(math.log(min(max(ratio, 0.5), 1.5)))
            transl0 = P.mean(0) - float(torch.exp(log_scale.detach())) * Vd.mean(0)
        transl = torch.tensor(transl0, dtype=dt, device=dev, requires_grad=True)

        lim_ids, lim_lo, lim_hi = [], [], []
        for name, bounds in JOINT_LIMITS.items():
            if name in model.joint_names:
                lim_ids.append(list(model.joint_names).index(name))
                lim_lo.append([b[0] for b in bounds])
                lim_hi.append([b[1] for b in bounds])
        lim_ids_t = torch.as_tensor(lim_ids, dtype=torch.long, device=dev)
        lim_lo_t = torch.as_tensor(lim_lo, dtype=dt, device=dev).reshape(-1, 3)
        lim_hi_t = torch.as_tensor(lim_hi, dtype=dt, device=dev).reshape(-1, 3)
        shape_mean = torch.as_tensor(default_shape, dtype=dt, device=dev)
        prior_scale = torch.ones(j, dtype=dt, device=dev)
        for name, factor in PRIOR_SCALE.items():
            if name in model.joint_names:
                prior_scale[list(model.joint_names).index(name)] = factor
        prior_scale = prior_scale[1:, None]
        if kp is not None:
            kp_ids = torch.as_tensor(kp[0], dtype=torch.long, device=dev)
            kp_pts = torch.as_tensor(kp[1], dtype=dt, device=dev)

        W_sub = torch.as_tensor(model.skinning_weights[body_ids], dtype=dt, device=dev)
        core_joints = [list(model.joint_names).index(n) for n in CORE_JOINTS
                       if n in model.joint_names]
        core = model.skinning_weights[body_ids][:, core_joints].sum(1) > 0.5
        core_t = torch.as_tensor(np.flatnonzero(core) if core.any() else
                                 np.arange(len(body_ids)), device=dev)
        state: dict = {"step": 0, "rest_normals": None, "nn_s2b": None}

        def update_rest_normals(rest_vertices):
            Vr = rest_vertices[0].detach().cpu().numpy().astype(np.float64)
            state["rest_normals"] = torch.as_tensor(
                _numpy_vertex_normals(Vr, model.faces)[body_ids], dtype=dt, device=dev)

        def loss_fn(pose_t, transl_t, stage: str):
            out = model.forward(shape_value()[None], pose_t[None], transl_t[None],
                                torch.exp(log_scale)[None], vertex_ids=body_ids_t)
            Vb = out.vertices[0]
            if state["rest_normals"] is None or (stage == "shape" and state["step"] % 10 == 0):
                update_rest_normals(out.rest_vertices)
            with torch.no_grad():
                Rb = torch.einsum("kj,jab->kab", W_sub, out.transforms[0, :, :3, :3])
                Nb = (Rb @ state["rest_normals"][..., None])[..., 0]
                Nb = Nb / (Nb.norm(dim=-1, keepdim=True) + 1e-12)
                Vb_np = Vb.detach().cpu().numpy()
                if not state.get("freeze") or state.get("nn_b2s") is None:
                    _, nn_b2s = tree.query(Vb_np, k=1, workers=1)
                    state["nn_b2s"] = torch.as_tensor(nn_b2s, device=dev)
                if state["nn_s2b"] is None or (not state.get("freeze") and
                                               state["step"] % self.correspondence_every == 0):
                    _, nn = cKDTree(Vb_np).query(P, k=1, workers=1)
                    state["nn_s2b"] = torch.as_tensor(nn, device=dev)
            state["step"] += 1
            nn_b2s = state["nn_b2s"]
            nn_s2b = state["nn_s2b"]
            # body -> scan, signed along the body normal (> 0: body outside the scan)
            d = Vb - P_t[nn_b2s]
            r = (d * Nb).sum(-1)
            # scan -> body: a scan point inside the body means the body is outside it
            e = Vb[nn_s2b] - P_t
            r2 = (e * Nb[nn_s2b]).sum(-1)
            data = 0.0
            pairs = ((r, d), (r2, e))
            if state.get("core_only"):  # yaw search: torso and head against the scan only
                pairs = ((r[core_t], d[core_t]),)
            for res, diff in pairs:
                cost = torch.where(res > 0, _gm(res * res, self.sigma_out),
                                   self.inside_weight * _gm(res * res, self.sigma_in))
                pt = self.point_weight * _gm((diff * diff).sum(-1), self.sigma_out)
                data = data + (cost + pt).mean()
            loss = data * 1e4  # residuals in metres: scale to ~cm^2
            terms = {"data": float(data.detach()) * 1e4}
            if stage != "global":
                prior = self.pose_prior_weight * (prior_scale * pose_t[1:] ** 2).sum()
                if len(lim_ids):
                    p = pose_t[lim_ids_t]
                    viol = torch.relu(lim_lo_t - p) + torch.relu(p - lim_hi_t)
                    prior = prior + self.limit_weight * 1e2 * (viol ** 2).sum()
                loss = loss + prior
                terms["prior"] = float(prior.detach())
            if stage == "shape" and not self.optimize_scale:
                # pull the temporary size scale back to 1: the shape takes it over
                progress_frac = min(state["step"] / max(n_shape, 1), 1.0)
                loss = loss + 1e3 * progress_frac * log_scale ** 2
            if stage == "shape":
                reg = self.shape_weight * ((shape_value() - shape_mean) ** 2).sum()
                loss = loss + reg
                terms["shape"] = float(reg.detach())
            if kp is not None:
                kl = self.keypoint_weight * 1e4 * ((out.joints[0, kp_ids] - kp_pts) ** 2).sum(-1).mean()
                loss = loss + kl
                terms["keypoints"] = float(kl.detach())
            return loss, terms

        distal = [list(model.joint_names).index(n) for n in DISTAL_JOINTS
                  if n in model.joint_names]

        def run(stage: str, n: int, params: list, lrs: list, label: str | None = None):
            if n <= 0:
                return {}
            opt = torch.optim.Adam([{"params": [p], "lr": lr} for p, lr in zip(params, lrs, strict=True)])
            sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=n, eta_min=0.05 * min(lrs))
            terms: dict = {}
            state["rest_normals"], state["nn_s2b"], state["step"] = None, None, 0
            bar = progress(range(n), desc=f"register: {label or stage}", disable=None if self.verbose else True)
            for it in bar:
                opt.zero_grad()
                loss, terms = loss_fn(pose, transl, stage)
                loss.backward()
                if stage == "global":  # only the root rotation moves in this stage
                    pose.grad[1:] = 0
                elif stage == "pose" and it < n // 3 and len(distal):
                    pose.grad[distal] = 0
                opt.step()
                sched.step()
            return terms

        def run_lbfgs(stage: str, n_outer: int, params: list):
            """ICP-like refinement: fixed correspondences, a few L-BFGS steps, repeat."""
            terms: dict = {}
            if n_outer <= 0:
                return terms
            opt = torch.optim.LBFGS(params, lr=1.0, max_iter=self.lbfgs_steps,
                                    history_size=20, line_search_fn="strong_wolfe")
            for _ in progress(range(n_outer), desc=f"register: {stage}",
                              disable=None if self.verbose else True):
                state["freeze"] = False
                state["rest_normals"], state["nn_s2b"], state["nn_b2s"] = None, None, None
                with torch.no_grad():
                    loss_fn(pose, transl, "shape")  # refresh correspondences and normals
                state["freeze"] = True

                def closure():
                    opt.zero_grad()
                    loss, t = loss_fn(pose, transl, "shape")
                    loss.backward()
                    terms.update(t)
                    return loss

                opt.step(closure)
            state["freeze"] = False
            return terms

        n_global, n_pose, n_shape = self.iterations
        if init is None and self.yaw_search and n_global > 0:
            # Candidates are compared on the torso, hips and head only: with the limbs, a
            # wrong yaw can win (A-pose arms sideways match a walking scan's legs seen
            # from the side).
            best = None
            base_transl = transl.detach().clone()
            state["core_only"] = True
            for yaw in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi):
                with torch.no_grad():
                    pose.zero_()
                    pose[0] = torch.tensor([0.0, yaw, 0.0], dtype=dt)
                    transl.copy_(base_transl)
                label = f"yaw {math.degrees(yaw):.0f}"
                terms = run("global", max(n_global // 2, 5), [pose, transl],
                            [self.lr_pose, self.lr_transl], label=label)
                logger.info("%s: core data %.4f", label, terms["data"])
                if best is None or terms["data"] < best[0]:
                    best = (terms["data"], pose.detach().clone(), transl.detach().clone())
            with torch.no_grad():
                pose.copy_(best[1])
                transl.copy_(best[2])
        # The rigid stage fits the torso, hips and head only (limb poses are unknown yet).
        state["core_only"] = True
        losses = {}
        losses.update({f"global_{k}": v for k, v in run(
            "global", n_global, [pose, transl], [self.lr_pose, self.lr_transl]).items()})
        state["core_only"] = False
        pose_params, pose_lrs = [pose, transl], [self.lr_pose, self.lr_transl]
        if self.shape_in_pose_stage:
            pose_params.append(shape_z)
            pose_lrs.append(self.lr_shape * 0.5)
        if self.size_init and init is None and kp is None:
            pose_params.append(log_scale)
            pose_lrs.append(0.003)
        losses.update({f"pose_{k}": v for k, v in run(
            "pose", n_pose, pose_params, pose_lrs).items()})
        shape_params = [pose, transl, shape_z]
        shape_lrs = [self.lr_pose * 0.5, self.lr_transl * 0.5, self.lr_shape]
        if self.optimize_scale or abs(float(log_scale.detach())) > 0:
            shape_params.append(log_scale)
            shape_lrs.append(0.01)
        losses.update({f"shape_{k}": v for k, v in run("shape", n_shape, shape_params,
                                                       shape_lrs).items()})
        losses.update({f"refine_{k}": v for k, v in run_lbfgs(
            "refine", self.refine_rounds, shape_params).items()})
        with torch.no_grad():
            shape_np = shape_value().cpu().numpy().astype(np.float64)
        params = BodyParams(model=model.name, gender=getattr(model, "gender", "neutral"),
                            shape=shape_np, pose=pose.detach().cpu().numpy().astype(np.float64),
                            transl=transl.detach().cpu().numpy().astype(np.float64),
                            scale=float(torch.exp(log_scale.detach())) if self.optimize_scale
                            else 1.0)
        return RegistrationResult(params=params, seconds=time.perf_counter() - t_start,
                                  losses=losses)


@dataclass
class FromFileRegistrar:
    """A registrar that imports precomputed parameters (another tool's fit).

    Parameters
    ----------
    path : the parameter file; format : importer name or ``auto``
        (see :func:`dressmeup.body.importers.import_body_params`).
    """

    path: str | os.PathLike | None = None
    format: str = "auto"

    def fit(self, scan, model, init: BodyParams | None = None, keypoints=None) -> RegistrationResult:
        """Return the imported parameters (the scan is not used)."""
        from dressmeup.body.importers import import_body_params

        if self.path is None:
            raise InputError("from-file registrar: pass path= to the parameter file")
        t0 = time.perf_counter()
        params = import_body_params(Path(self.path), format=self.format, body_model=model)
        return RegistrationResult(params=params, seconds=time.perf_counter() - t0)


_REGISTRARS: dict[str, Callable[..., object]] = {
    "optimization": OptimizationRegistrar,
    "from-file": FromFileRegistrar,
}


def add_registrar(name: str, factory: Callable[..., object]) -> None:
    """Register ``factory(**options)`` returning an object with ``fit(scan, model, init,
    keypoints) -> RegistrationResult`` (or ``BodyParams``) under ``name``."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty string, got {name!r}")
    _REGISTRARS[name] = factory


def available_registrars() -> list[str]:
    """Names accepted by :func:`get_registrar`."""
    return sorted(_REGISTRARS)


def get_registrar(name: str = "optimization", **options):
    """Return the registrar ``name`` built with ``options``."""
    if name not in _REGISTRARS:
        raise ValueError(f"registrar: unknown {name!r}; known: {available_registrars()}")
    return _REGISTRARS[name](**options)


def register(scan, model, init: BodyParams | None = None, keypoints=None,
             registrar: str = "optimization", return_result: bool = False, **options):
    """Fit a body model to a scan and return its parameters.

    Parameters
    ----------
    scan : ``(V (n,3), F (m,3))``, a trimesh, or points ``(p, 3)`` in metres.
    model : a BodyModel (e.g. ``get_body_model("anny")``) or its name.
    init : optional starting parameters (else zero pose, average shape, centred, yaw search).
    keypoints : optional 3D joint positions: ``(j, 3)`` in the model's joint order with NaN
        rows for missing joints, or ``{joint_name: (3,)}``.
    registrar : registrar name (``optimization``, ``from-file``, or one added with
        :func:`add_registrar`).
    return_result : return the :class:`RegistrationResult` (timing, losses) instead.
    **options : registrar options (see :class:`OptimizationRegistrar`).

    Returns
    -------
    BodyParams (vertices = scale * model(shape, pose) + transl), or RegistrationResult.
    """
    if isinstance(model, str):
        from dressmeup.body.models import get_body_model

        model = get_body_model(model)
    result = get_registrar(registrar, **options).fit(scan, model, init=init, keypoints=keypoints)
    if isinstance(result, BodyParams):
        result = RegistrationResult(params=result, seconds=float("nan"))
    return result if return_result else result.params


__all__ = [
    "JOINT_LIMITS",
    "SMPL22_JOINT_NAMES",
    "FromFileRegistrar",
    "OptimizationRegistrar",
    "RegistrationResult",
    "add_registrar",
    "available_registrars",
    "get_registrar",
    "prepare_scan",
    "register",
]
