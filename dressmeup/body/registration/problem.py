"""One fit's state: the parameters as torch tensors and the objective over them.

:class:`FitProblem` holds the scan points, the sampled body points, the priors' constants
and the free parameters (``pose (j, 3)`` axis-angle, ``transl (3,)``, ``shape_z`` (the
shape, through a sigmoid for phenotype models), ``log_scale``), and evaluates the loss of
a stage (``global``, ``pose`` or ``shape``). Correspondences are recomputed by k-d tree
(body -> scan every step, scan -> body every ``correspondence_every`` steps) unless frozen.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.body.registration.terms import (
    CORE_JOINTS,
    HAND_JOINTS,
    JOINT_LIMITS,
    PRIOR_SCALE,
    one_sided_cost,
    pose_prior,
)
from dressmeup.body.skeleton import PHENOTYPE_NAMES
from dressmeup.geometry.mesh import vertex_normals
from dressmeup.geometry.neighbors import NearestTree


def joint_skin_mask(model, joints, threshold: float = 0.5) -> np.ndarray:
    """(n,) bool: vertices whose skinning weights on ``joints`` sum above ``threshold``."""
    ids = [list(model.joint_names).index(n) for n in joints if n in model.joint_names]
    if not ids:
        return np.zeros(model.n_vertices, dtype=bool)
    return np.asarray(model.skinning_weights)[:, ids].sum(1) > threshold


def body_neighbourhoods(rest_points: np.ndarray, radius: float, most: int = 16) -> np.ndarray:
    """(b, most) int64: for each body point, the indices of the body points within ``radius``
    (m) of it on the rest body (itself included), padded with ``b`` (see
    :func:`unseen_free_weights`).

    Parameters
    ----------
    rest_points : (b, 3) the fit's body points on the rest body (m).
    radius : neighbourhood radius (m); most : at most this many neighbours (the nearest).
    """
    # heavy: scipy (~0.5 s to import)
    from scipy.spatial import cKDTree

    _, idx = cKDTree(rest_points).query(rest_points, k=min(most, len(rest_points)),
                                        distance_upper_bound=radius, workers=1)
    return np.asarray(idx, dtype=np.int64).reshape(len(rest_points), -1)


def unseen_free_weights(normals, nn_b2s, nn_s2b, neighbourhoods=None):
    """(b,) float weights of the body -> scan pairs: 0 where the body point's nearest scan
    point belongs to a surface of the body facing the other way (its own nearest body
    point's normal opposes this point's), i.e. where the scan did not see this part of the
    body (a side the capture missed, a hole), else 1.

    With ``neighbourhoods`` (:func:`body_neighbourhoods`), also 0 where no scan point has its
    nearest body point in the body point's neighbourhood: no scan surface lies over it. This
    frees the body points of a missing side near the scan's cut edge, whose normals agree with
    the edge's and which the facing test keeps pulling towards it.

    Parameters
    ----------
    normals : (b, 3) body normals (torch); nn_b2s : (b,) scan index of each body point;
    nn_s2b : (p,) body index of each scan point; neighbourhoods : None or (b, m) int64
        torch indices into the body points, padded with b.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    seen = (normals * normals[nn_s2b[nn_b2s]]).sum(-1) > 0
    if neighbourhoods is not None:
        hit = torch.zeros(len(normals) + 1, dtype=torch.bool, device=normals.device)
        hit[nn_s2b] = True  # hit[b], the padding, stays False
        seen = seen & hit[neighbourhoods].any(1)
    return seen.to(normals.dtype)


#: Loose-cloth test (:func:`loose_cloth_mask`): samples every ``step`` m along the segment
#: from a scan point to its body point, skipping ``margin_scan`` m at the scan end and
#: ``margin_body`` m at the body end; a sample within ``eps`` m of a scan point is a crossing.
#: 5 cm at the scan end: a segment leaving its own surface at less than ~17 deg is not a
#: crossing, and a scan limb without the body in it (8-12 cm thick) still shows its far side.
LOOSE_CLOTH_TEST = {"step": 0.01, "eps": 0.015, "margin_scan": 0.05, "margin_body": 0.03}


def loose_cloth_mask(P: np.ndarray, B: np.ndarray, outside: np.ndarray, cloth_max: float,
                     tree) -> np.ndarray:
    """(p,) bool: scan points that are *loose cloth over the body*.

    A scan point outside the body farther than ``cloth_max`` from its nearest body point
    is loose cloth (a skirt, a dress, a wide sleeve) when the straight segment to that body
    point crosses no other scan surface: the body lies right under it, however far. Such a
    point says little about where the body is, and its pull bent the legs under a dress
    into the cloth. A scan part that does not contain the body (the scan's leg 10 cm in
    front of the body's, a T-pose arm beside a body with its arms down) has its own far
    side, or its surface, between the two: it keeps pulling the body towards it.

    Parameters
    ----------
    P : (p, 3) scan points (m); B : (p, 3) the nearest body point of each.
    outside : (p,) bool, the scan point lies outside the body (signed residual < 0).
    cloth_max : gap (m) up to which every scan point pulls.
    tree : nearest-point index of ``P`` (:class:`~dressmeup.geometry.neighbors.NearestTree`
        or a ``scipy.spatial.cKDTree``).
    """
    t = LOOSE_CLOTH_TEST
    D = B - P
    g = np.linalg.norm(D, axis=1)
    idx = np.flatnonzero(outside & (g > cloth_max))
    loose = np.zeros(len(P), dtype=bool)
    if idx.size == 0:
        return loose
    L = g[idx]
    s = t["margin_scan"] + t["step"] * np.arange(int(np.ceil(L.max() / t["step"])) + 1)
    valid = s[None, :] < (L - t["margin_body"])[:, None]
    frac = s[None, :] / L[:, None]
    X = P[idx, None, :] + frac[..., None] * D[idx, None, :]
    rows = np.nonzero(valid)[0]
    d, _ = tree.query(X[valid], k=1, distance_upper_bound=t["eps"], workers=1)
    hit = np.zeros(idx.size, dtype=bool)
    hit[rows[d < t["eps"]]] = True
    loose[idx] = ~hit
    return loose


class FitProblem:
    """Parameters and objective of one registration (see module docstring).

    Parameters
    ----------
    opts : the :class:`~dressmeup.body.registration.optimizer.OptimizationRegistrar`
        (weights, scales, sample counts, seed, device).
    model : BodyModel.
    P : (p, 3) float64 scan points.
    kp : None or (joint ids (k,), targets (k, 3)) keypoints.
    """

    def __init__(self, opts, model, P: np.ndarray, kp):
        # heavy: torch (~1.1 s to import)
        import torch

        self.opts, self.model, self.P, self.kp = opts, model, P, kp
        self.dev = torch.device(opts.device)
        self.dt = torch.float32
        dev, dt = self.dev, self.dt
        self.tree = NearestTree(P)
        self.P_t = torch.as_tensor(P, dtype=dt, device=dev)
        self.loose = None  # (p,) weights of the scan points, 0 for loose cloth
        self.far_cloth_on = opts.far_cloth_from == "start"  # the optimizer switches it on
        self.loose_every = 10  # steps between two loose-cloth tests
        rng = np.random.default_rng(opts.seed)
        self.body_ids = np.sort(rng.choice(model.n_vertices, min(opts.n_body_points, model.n_vertices),
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
        self.kp_weight = float(opts.keypoint_weight)
        if kp is not None:
            self.kp_ids = torch.as_tensor(kp[0], dtype=torch.long, device=dev)
            self.kp_pts = torch.as_tensor(kp[1], dtype=dt, device=dev)

        self.W_sub = torch.as_tensor(np.asarray(model.skinning_weights)[self.body_ids], dtype=dt,
                                     device=dev)
        core = joint_skin_mask(model, CORE_JOINTS)[self.body_ids]
        self.core_t = torch.as_tensor(np.flatnonzero(core) if core.any() else
                                      np.arange(len(self.body_ids)), device=dev)
        hand = joint_skin_mask(model, HAND_JOINTS)[self.body_ids]
        w = np.where(hand, float(opts.hand_weight), 1.0)
        self.point_weight = None if np.all(w == 1.0) else torch.as_tensor(w, dtype=dt, device=dev)
        self.neighbourhoods = None  # (b, m) for the hit test of unseen body points
        radius = opts.unseen_hit_radius
        if radius is not None:
            rest = np.asarray(model.posed(model.default_params()).vertices)[self.body_ids]
            self.neighbourhoods = torch.as_tensor(body_neighbourhoods(rest, float(radius)),
                                                  device=dev)
        self.distal: list[int] = []

        self.shape_z = torch.zeros(len(self.default_shape), dtype=dt, device=dev, requires_grad=True)
        self.pose = torch.zeros((self.n_joints, 3), dtype=dt, device=dev, requires_grad=True)
        self.transl = torch.zeros(3, dtype=dt, device=dev, requires_grad=True)
        self.log_scale = torch.zeros((), dtype=dt, device=dev, requires_grad=True)
        # correspondence / stage state
        self.step = 0
        self.stage_steps = 1
        self.rest_normals = None
        self.nn_s2b = None
        self.nn_b2s = None
        self.freeze = False
        self.core_only = False
        # False while the running stage does not move the shape (set by the stages): the
        # shape then enters the body model without a gradient, so the model's cached rest
        # body is reused instead of re-shaped every step (the same values, and the same
        # gradients for the parameters that move)
        self.shape_moves = True

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

    def body_params(self, keep_scale: bool) -> BodyParams:
        """The current parameters as :class:`BodyParams` (``scale`` 1 unless ``keep_scale``)."""
        # heavy: torch (~1.1 s to import)
        import torch

        with torch.no_grad():
            shape = self.shape_value().cpu().numpy().astype(np.float64)
            scale = float(torch.exp(self.log_scale)) if keep_scale else 1.0
        return BodyParams(model=self.model.name, gender=getattr(self.model, "gender", "neutral"),
                          shape=shape, pose=self.pose.detach().cpu().numpy().astype(np.float64),
                          transl=self.transl.detach().cpu().numpy().astype(np.float64),
                          scale=scale)

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

    def objective(self, stage: str, far_cloth_on: bool = True) -> float:
        """The ``stage`` objective (data term, priors and keypoints, as :meth:`loss` sums
        them; float) at the current parameters, with fresh correspondences and far cloth
        on or off. The shape stage's pull of the temporary scale back to 1 is not counted
        (it grows over a stage from zero weight). The correspondence cache is reset
        afterwards: the next stage starts afresh, as after :meth:`reset_correspondences`."""
        # heavy: torch (~1.1 s to import)
        import torch

        keep = self.far_cloth_on
        self.reset_correspondences()
        self.far_cloth_on = far_cloth_on
        try:
            with torch.no_grad():
                loss, _ = self.loss(stage)
        finally:
            self.far_cloth_on = keep
            self.reset_correspondences()
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
    def reset_correspondences(self) -> None:
        """Forget cached correspondences and normals (a new stage starts)."""
        self.rest_normals, self.nn_s2b, self.nn_b2s, self.step = None, None, None, 0
        self.loose = None

    def _update_rest_normals(self, rest_vertices) -> None:
        # heavy: torch (~1.1 s to import)
        import torch

        Vr = rest_vertices[0].detach().cpu().numpy().astype(np.float64)
        self.rest_normals = torch.as_tensor(vertex_normals(Vr, self.model.faces)[self.body_ids],
                                            dtype=self.dt, device=self.dev)

    def loss(self, stage: str):
        """Loss (torch scalar) and its terms (dict of floats) for ``stage``.

        ``global``: data term only; ``pose``: + pose prior; ``shape``: + shape prior and the
        pull of the temporary size scale back to 1 (unless the scale is fitted).
        """
        # heavy: torch (~1.1 s to import)
        import torch

        o = self.opts
        shape = self.shape_value() if self.shape_moves else self.shape_value().detach()
        out = self.model.forward(shape[None], self.pose[None], self.transl[None],
                                 torch.exp(self.log_scale)[None], vertex_ids=self.body_ids_t)
        Vb = out.vertices[0]
        if self.rest_normals is None or (stage == "shape" and self.step % 10 == 0):
            self._update_rest_normals(out.rest_vertices)
        with torch.no_grad():
            Rb = torch.einsum("kj,jab->kab", self.W_sub, out.transforms[0, :, :3, :3])
            Nb = (Rb @ self.rest_normals[..., None])[..., 0]
            Nb = Nb / (Nb.norm(dim=-1, keepdim=True) + 1e-12)
            Vb_np = Vb.detach().cpu().numpy()
            if not self.freeze or self.nn_b2s is None:
                _, nn_b2s = self.tree.query(Vb_np)
                self.nn_b2s = torch.as_tensor(nn_b2s, device=self.dev)
            if self.nn_s2b is None or (not self.freeze and self.step % o.correspondence_every == 0):
                _, nn = NearestTree(Vb_np).query(self.P)
                self.nn_s2b = torch.as_tensor(nn, device=self.dev)
        self.step += 1
        # body -> scan, signed along the body normal (> 0: body outside the scan)
        d = Vb - self.P_t[self.nn_b2s]
        r = (d * Nb).sum(-1)
        # scan -> body: a scan point inside the body means the body is outside it
        e = Vb[self.nn_s2b] - self.P_t
        r2 = (e * Nb[self.nn_s2b]).sum(-1)
        w = self.point_weight
        wb = w
        if o.skip_unseen:  # body points the scan did not see carry no body -> scan cost
            # (the hit test only in the shape stage: see OptimizationRegistrar.unseen_hit_radius)
            seen = unseen_free_weights(Nb.detach(), self.nn_b2s, self.nn_s2b,
                                       self.neighbourhoods if stage == "shape" else None)
            wb = seen if w is None else w * seen
        if self.core_only:  # rigid stage: torso, hips and head against the scan only
            pairs = ((r[self.core_t], d[self.core_t], None if wb is None else wb[self.core_t],
                      False),)
        else:
            ws = None if w is None else w[self.nn_s2b]
            far = o.far_cloth if self.far_cloth_on and o.cloth_max is not None else "pull"
            if far == "loose":  # loose cloth does not pull
                if self.loose is None or self.step % self.loose_every == 1:
                    mask = loose_cloth_mask(self.P, Vb_np[self.nn_s2b.cpu().numpy()],
                                            (r2 < 0).cpu().numpy(), o.cloth_max, self.tree)
                    self.loose = torch.as_tensor(~mask, dtype=self.dt, device=self.dev)
                ws = self.loose if ws is None else ws * self.loose
            pairs = ((r, d, wb, False), (r2, e, ws, far == "free"))
        data = 0.0
        for res, diff, wt, free in pairs:
            data = data + one_sided_cost(res, diff, wt, o.sigma_out, o.sigma_in, o.inside_weight,
                                         o.point_weight, o.cloth_max, far_free=free)
        loss = data * 1e4  # residuals in metres: scale to ~cm^2
        terms = {"data": float(data.detach()) * 1e4}
        if stage != "global":
            prior = pose_prior(self.pose, self.prior_scale, self.lim_ids, self.lim_lo, self.lim_hi,
                               o.pose_prior_weight, o.limit_weight)
            loss = loss + prior
            terms["prior"] = float(prior.detach())
        if stage == "shape" and not o.optimize_scale:
            # pull the temporary size scale back to 1: the shape takes it over
            frac = min(self.step / max(self.stage_steps, 1), 1.0)
            loss = loss + 1e3 * frac * self.log_scale ** 2
        if stage == "shape":
            reg = o.shape_weight * ((self.shape_value() - self.shape_mean) ** 2).sum()
            loss = loss + reg
            terms["shape"] = float(reg.detach())
        if self.kp is not None and self.kp_weight > 0:
            kl = self.kp_weight * 1e4 * ((out.joints[0, self.kp_ids] - self.kp_pts) ** 2
                                            ).sum(-1).mean()
            loss = loss + kl
            terms["keypoints"] = float(kl.detach())
        return loss, terms
