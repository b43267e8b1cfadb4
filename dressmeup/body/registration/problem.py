"""One fit's state: the parameters as torch tensors and the objective over them.

:class:`FitProblem` holds the scan points, the sampled body points, the priors' constants
and the free parameters (``pose (j, 3)`` axis-angle, ``transl (3,)``, ``shape_z`` (the
shape, through a sigmoid for phenotype models), ``log_scale``), and evaluates the loss
that an :class:`Objective` names (stage ``global``, ``pose`` or ``shape``; the core
joints only; the far-cloth rule on or off; the keypoint weight). The nearest-point pairs
of a run of steps live in a :class:`Correspondences` (body -> scan every step, scan ->
body every second step, by k-d tree).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.body.registration.terms import (
    CORE_JOINTS,
    JOINT_LIMITS,
    PRIOR_SCALE,
    body_neighbourhoods,
    joint_skin_mask,
    one_sided_cost,
    pose_prior,
    unseen_free_weights,
)
from dressmeup.body.skeleton import PHENOTYPE_NAMES
from dressmeup.geometry.mesh import vertex_normals
from dressmeup.geometry.neighbors import NearestTree


@dataclass(frozen=True)
class Objective:
    """Which objective a run of steps minimises or a comparison evaluates.

    Attributes
    ----------
    stage : ``"global"`` (data term only), ``"pose"`` (+ pose prior and joint limits) or
        ``"shape"`` (+ shape prior and, over a stage, the pull of the temporary size scale
        back to 1).
    core_only : the data term on the torso, hips and head only, body -> scan (rigid starts).
    far_cloth : the data term's far-cloth rule (``DataTerm.far_cloth``) on; off, scan
        points beyond ``cloth_max`` pull by their excess.
    keypoints : weight of the keypoint term (0: none, or no keypoints).
    """

    stage: str = "pose"
    core_only: bool = False
    far_cloth: bool = False
    keypoints: float = 0.0

    def __post_init__(self) -> None:
        if self.stage not in ("global", "pose", "shape"):
            raise ValueError(f"stage: expected global, pose or shape, got {self.stage!r}")


class Correspondences:
    """The nearest-point pairs and rest normals of one run of steps, refreshed as the body
    moves: body -> scan every step, scan -> body every second step, the rest normals at the
    first step and, in a shape stage, every 10th.

    Parameters
    ----------
    steps : length of the stage (the shape stage's pull of the temporary scale back to 1
        grows over it); 0 for a single evaluation, which does not count that pull.
    """

    #: scan -> body pairs are refreshed every this many steps
    SCAN_TO_BODY_EVERY = 2
    #: a shape stage refreshes the rest normals every this many steps
    NORMALS_EVERY = 10

    def __init__(self, steps: int = 0) -> None:
        self.steps, self.step = int(steps), 0
        self.rest_normals = None  # (b, 3) torch, the body points' normals on the rest body
        self.nn_b2s = None  # (b,) scan index of each body point
        self.nn_s2b = None  # (p,) body index of each scan point


class FitProblem:
    """Parameters and objective of one registration (see module docstring).

    Parameters
    ----------
    model : BodyModel.
    P : (p, 3) float64 scan points (m).
    kp : None or (joint ids (k,), targets (k, 3)) keypoints.
    data : :class:`~dressmeup.body.registration.config.DataTerm`.
    priors : :class:`~dressmeup.body.registration.config.Priors`.
    seed : seed of the body points' sample; device : torch device.
    """

    def __init__(self, model, P: np.ndarray, kp, data, priors, seed: int = 0,
                 device: str = "cpu"):
        # heavy: torch (~1.1 s to import)
        import torch

        self.model, self.P, self.kp, self.data, self.priors = model, P, kp, data, priors
        self.dev = torch.device(device)
        self.dt = torch.float32
        dev, dt = self.dev, self.dt
        self.tree = NearestTree(P)
        self.P_t = torch.as_tensor(P, dtype=dt, device=dev)
        rng = np.random.default_rng(seed)
        self.body_ids = np.sort(rng.choice(model.n_vertices, min(data.n_body_points,
                                                                 model.n_vertices),
                                           replace=False))
        self.body_ids_t = torch.as_tensor(self.body_ids, device=dev)
        names = list(model.joint_names)
        self.n_joints = len(names)
        self.phenotype = tuple(getattr(model, "shape_names", ())) == PHENOTYPE_NAMES
        self.default_shape = np.asarray(model.default_shape, dtype=np.float64)

        lim_ids, lim_lo, lim_hi = [], [], []
        for name, bounds in JOINT_LIMITS.items():
            if name in names:
                lim_ids.append(names.index(name))
                lim_lo.append([b[0] for b in bounds])
                lim_hi.append([b[1] for b in bounds])
        self.lim_ids = torch.as_tensor(lim_ids, dtype=torch.long, device=dev)
        self.lim_lo = torch.as_tensor(lim_lo, dtype=dt, device=dev).reshape(-1, 3)
        self.lim_hi = torch.as_tensor(lim_hi, dtype=dt, device=dev).reshape(-1, 3)
        self.shape_mean = torch.as_tensor(self.default_shape, dtype=dt, device=dev)
        prior_scale = torch.ones(self.n_joints, dtype=dt, device=dev)
        for name, factor in PRIOR_SCALE.items():
            if name in names:
                prior_scale[names.index(name)] = factor
        self.prior_scale = prior_scale[1:, None]
        if kp is not None:
            self.kp_ids = torch.as_tensor(kp[0], dtype=torch.long, device=dev)
            self.kp_pts = torch.as_tensor(kp[1], dtype=dt, device=dev)

        self.W_sub = torch.as_tensor(np.asarray(model.skinning_weights)[self.body_ids], dtype=dt,
                                     device=dev)
        core = joint_skin_mask(model, CORE_JOINTS)[self.body_ids]
        self.core_t = torch.as_tensor(np.flatnonzero(core) if core.any() else
                                      np.arange(len(self.body_ids)), device=dev)
        self.neighbourhoods = None  # (b, m) for the hit test of unseen body points
        if data.unseen_hit_radius is not None:
            rest = np.asarray(model.posed(model.default_params()).vertices)[self.body_ids]
            self.neighbourhoods = torch.as_tensor(
                body_neighbourhoods(rest, float(data.unseen_hit_radius)), device=dev)

        self.shape_z = torch.zeros(len(self.default_shape), dtype=dt, device=dev, requires_grad=True)
        self.pose = torch.zeros((self.n_joints, 3), dtype=dt, device=dev, requires_grad=True)
        self.transl = torch.zeros(3, dtype=dt, device=dev, requires_grad=True)
        self.log_scale = torch.zeros((), dtype=dt, device=dev, requires_grad=True)
        self._normals = None  # (shape bytes, rest normals of the body points)

    @classmethod
    def from_config(cls, config, model, P: np.ndarray, kp=None) -> FitProblem:
        """The problem of ``config`` (a :class:`~.config.RegistrationConfig`) on scan points
        ``P`` (p, 3), as a fit builds it."""
        return cls(model, P, kp, config.data, config.priors, seed=config.runtime.seed,
                   device=config.runtime.device)

    # ------------------------------------------------------------ parameters
    def set_params(self, shape: np.ndarray | None = None, pose: np.ndarray | None = None,
                   transl: np.ndarray | None = None, scale: float | None = None) -> None:
        """Overwrite some parameters (numpy, float64 ok); ``shape`` in model units."""
        # heavy: torch (~1.1 s to import)
        import torch

        with torch.no_grad():
            if shape is not None:
                s = np.asarray(shape, dtype=np.float64)
                if self.phenotype:
                    s = np.clip(s, 1e-3, 1 - 1e-3)
                    s = np.log(s / (1 - s))
                self.shape_z.copy_(torch.as_tensor(s, dtype=self.dt))
            if pose is not None:
                self.pose.copy_(torch.as_tensor(np.asarray(pose), dtype=self.dt))
            if transl is not None:
                self.transl.copy_(torch.as_tensor(np.asarray(transl), dtype=self.dt))
            if scale is not None:
                self.log_scale.fill_(math.log(float(scale)))

    def shape_value(self):
        """The shape in model units (sigmoid of ``shape_z`` for phenotype models)."""
        # heavy: torch (~1.1 s to import)
        import torch

        return torch.sigmoid(self.shape_z) if self.phenotype else self.shape_z

    def snapshot(self) -> dict[str, Any]:
        """Copies of the free parameters (restore with :meth:`restore`)."""
        return {k: getattr(self, k).detach().clone() for k in ("shape_z", "pose", "transl",
                                                                 "log_scale")}

    def restore(self, snap: dict[str, Any]) -> None:
        """Set the free parameters back to a :meth:`snapshot`."""
        # heavy: torch (~1.1 s to import)
        import torch

        with torch.no_grad():
            for k, v in snap.items():
                getattr(self, k).copy_(v)

    def body_params(self) -> BodyParams:
        """The current parameters as :class:`BodyParams` (``scale`` 1: a fit ends with its
        size in the shape)."""
        # heavy: torch (~1.1 s to import)
        import torch

        with torch.no_grad():
            shape = self.shape_value().cpu().numpy().astype(np.float64)
        return BodyParams(model=self.model.name, gender=getattr(self.model, "gender", "neutral"),
                          shape=shape, pose=self.pose.detach().cpu().numpy().astype(np.float64),
                          transl=self.transl.detach().cpu().numpy().astype(np.float64),
                          scale=1.0)

    def scale_into_shape(self, steps: int = 60, lr: float = 0.1) -> float:
        """Hand the temporary uniform scale over to the shape, in the rest pose.

        The start matches the scan's size with a uniform scale; the shape stage pulls that
        scale back to 1 while the data term has to grow the shape, and a body far from the
        average size (a 2 m person: scale ~1.3) can get there only partly and compensate by
        pose (tip-toes, bent knees). Here the shape is fitted first so that the unscaled
        rest body matches the scaled one: ``min_s |V(s) - c(s) - scale (V(s0) - c(s0))|^2``
        over the sampled body points (``c``: their centroid), ``steps`` Adam steps; then the
        scale is set to 1 and the translation moved so the posed body's centroid stays.

        Returns
        -------
        rms : float, remaining rest-shape mismatch (m) after the handover.
        """
        # heavy: torch (~1.1 s to import)
        import torch

        with torch.no_grad():
            scale = torch.exp(self.log_scale)
            if abs(float(self.log_scale)) < 1e-6:
                return 0.0
            rest0, _ = self.model.rest(self.shape_value()[None].detach())
            target = rest0[0, self.body_ids_t]
            target = scale * (target - target.mean(0))
            before = self.posed_numpy()[self.body_ids].mean(0)
        z = self.shape_z.detach().clone().requires_grad_(True)
        opt = torch.optim.Adam([z], lr=lr)
        rms = torch.zeros(())
        for _ in range(max(int(steps), 1)):
            opt.zero_grad()
            shape = torch.sigmoid(z) if self.phenotype else z
            rest, _ = self.model.rest(shape[None])
            V = rest[0, self.body_ids_t]
            err = ((V - V.mean(0) - target) ** 2).sum(-1).mean()
            err.backward()
            opt.step()
            rms = err.detach().sqrt()
        with torch.no_grad():
            self.shape_z.copy_(z.detach())
            self.log_scale.zero_()
            after = self.posed_numpy()[self.body_ids].mean(0)
            self.transl.add_(torch.as_tensor(before - after, dtype=self.dt, device=self.dev))
        return float(rms)

    def objective(self, objective: Objective) -> float:
        """The value (float) of ``objective`` at the current parameters, with fresh
        correspondences: what a stage's first step would see, without the shape stage's
        pull of the temporary scale back to 1 (it grows over a stage from zero weight)."""
        # heavy: torch (~1.1 s to import)
        import torch

        with torch.no_grad():
            loss, _ = self.loss(objective)
        return float(loss)

    def posed_numpy(self) -> np.ndarray:
        """(n, 3) float64 vertices of the whole body at the current parameters."""
        # heavy: torch (~1.1 s to import)
        import torch

        with torch.no_grad():
            out = self.model.forward(self.shape_value()[None], self.pose[None], self.transl[None],
                                     torch.exp(self.log_scale)[None])
        return out.vertices[0].cpu().numpy().astype(np.float64)

    # ------------------------------------------------------------ objective
    def _rest_normals(self, shape):
        """(b, 3) torch normals of the body points on the rest body of ``shape`` (s,); the
        last shape's are kept (the stages that hold the shape ask for the same ones)."""
        # heavy: torch (~1.1 s to import)
        import torch

        key = shape.detach().cpu().numpy().tobytes()
        if self._normals is None or self._normals[0] != key:
            with torch.no_grad():
                rest, _ = self.model.rest(shape.detach()[None])
            Vr = rest[0].cpu().numpy().astype(np.float64)
            normals = torch.as_tensor(vertex_normals(Vr, self.model.faces)[self.body_ids],
                                      dtype=self.dt, device=self.dev)
            self._normals = (key, normals)
        return self._normals[1]

    def loss(self, objective: Objective, pairs: Correspondences | None = None,
             hold_shape: bool = False):
        """Loss (torch scalar) of ``objective`` and its terms (dict of floats).

        Parameters
        ----------
        objective : what to evaluate (:class:`Objective`).
        pairs : the correspondences of the running stage, updated here (None: fresh ones,
            a single evaluation).
        hold_shape : the shape enters the body model without a gradient, so the model's
            cached rest body is reused (the same values, and the same gradients for the
            other parameters); for steps that do not move the shape.
        """
        # heavy: torch (~1.1 s to import)
        import torch

        pairs = Correspondences() if pairs is None else pairs
        o, stage = self.data, objective.stage
        shape = self.shape_value().detach() if hold_shape else self.shape_value()
        out = self.model.forward(shape[None], self.pose[None], self.transl[None],
                                 torch.exp(self.log_scale)[None], vertex_ids=self.body_ids_t)
        Vb = out.vertices[0]
        if pairs.rest_normals is None or (stage == "shape"
                                          and pairs.step % pairs.NORMALS_EVERY == 0):
            pairs.rest_normals = self._rest_normals(shape)
        with torch.no_grad():
            Rb = torch.einsum("kj,jab->kab", self.W_sub, out.transforms[0, :, :3, :3])
            Nb = (Rb @ pairs.rest_normals[..., None])[..., 0]
            Nb = Nb / (Nb.norm(dim=-1, keepdim=True) + 1e-12)
            Vb_np = Vb.detach().cpu().numpy()
            _, nn_b2s = self.tree.query(Vb_np)
            pairs.nn_b2s = torch.as_tensor(nn_b2s, device=self.dev)
            if pairs.nn_s2b is None or pairs.step % pairs.SCAN_TO_BODY_EVERY == 0:
                _, nn = NearestTree(Vb_np).query(self.P)
                pairs.nn_s2b = torch.as_tensor(nn, device=self.dev)
        pairs.step += 1
        # body -> scan, signed along the body normal (> 0: body outside the scan)
        d = Vb - self.P_t[pairs.nn_b2s]
        r = (d * Nb).sum(-1)
        # scan -> body: a scan point inside the body means the body is outside it
        e = Vb[pairs.nn_s2b] - self.P_t
        r2 = (e * Nb[pairs.nn_s2b]).sum(-1)
        # body points the scan did not see carry no body -> scan cost (the hit test only
        # in the shape stage: earlier, the pull of far body points brings a misplaced limb)
        wb = unseen_free_weights(Nb.detach(), pairs.nn_b2s, pairs.nn_s2b,
                                 self.neighbourhoods if stage == "shape" else None)
        if objective.core_only:  # torso, hips and head against the scan only
            pairs_used = ((r[self.core_t], d[self.core_t], wb[self.core_t], False),)
        else:
            free = objective.far_cloth and o.far_cloth == "free"
            pairs_used = ((r, d, wb, False), (r2, e, None, free))
        data = 0.0
        for res, diff, wt, far_free in pairs_used:
            data = data + one_sided_cost(res, diff, wt, o.sigma_out, o.sigma_in, o.inside_weight,
                                         o.point_weight, o.cloth_max, far_free=far_free)
        loss = data * 1e4  # residuals in metres: scale to ~cm^2
        terms = {"data": float(data.detach()) * 1e4}
        pr = self.priors
        if stage != "global":
            prior = pose_prior(self.pose, self.prior_scale, self.lim_ids, self.lim_lo, self.lim_hi,
                               pr.pose_prior_weight, pr.limit_weight)
            loss = loss + prior
            terms["prior"] = float(prior.detach())
        if stage == "shape":
            if pairs.steps > 0:  # pull the temporary size scale back to 1: the shape takes it
                frac = min(pairs.step / max(pairs.steps, 1), 1.0)
                loss = loss + 1e3 * frac * self.log_scale ** 2
            reg = pr.shape_weight * ((self.shape_value() - self.shape_mean) ** 2).sum()
            loss = loss + reg
            terms["shape"] = float(reg.detach())
        if self.kp is not None and objective.keypoints > 0:
            kl = objective.keypoints * 1e4 * ((out.joints[0, self.kp_ids] - self.kp_pts) ** 2
                                              ).sum(-1).mean()
            loss = loss + kl
            terms["keypoints"] = float(kl.detach())
        return loss, terms
