"""``isomap-refine``: the self-supervised refinement of the coarse retargeting (thesis 4.3.2, 4.4.2).

Model. A per-vertex MLP (6 hidden layers of 512, LeakyReLU, tanh output scaled to
``out_scale`` metres) predicts an offset ``dx_i`` added to the coarse point ``x_i``. Its
per-vertex input is ``x_i`` (relative to the target's root joint), the garment vertex's Isomap
embedding ``phi_G^i`` (128), and the ``k = 32`` target vertices nearest to ``x_i`` as offsets
``u_j - x_i`` (96). Two ResnetPointNet encoders give 128-d codes of the input garment and of
the target body; their concatenation is appended to every vertex's input and modulates every
hidden layer AdaIN-style (:class:`dressmeup.methods.nn.mlp.ConditionedMLP`).

Self-supervised losses on the refined garment ``v'_i = x_i + dx_i``:

- edge length (eq. 4.6-4.7): mean over the garment's edges of ``w_e | |e'| - |e| |``, with
  ``w_e = 0`` for edges near the elbows, armpits (shoulders), waist (pelvis, spine1) and
  knees of the source body (the joint masks of Fig. 4.16), 1 elsewhere;
- correspondence (eq. 4.8): ``mean ||x_i - x'_i||`` where ``x'_i`` re-runs eq. 4.1 + 4.4 from
  the refined point ``v'_i`` on the target (differentiable through the inverse-distance
  weights; neighbour sets are recomputed without gradient each step and restricted to the
  64 target vertices nearest to ``v'_i``, see :func:`correspondence_points`);
- bending: mean over interior edges of ``1 - n_1 . n_2`` (adjacent face normals);
- penetration (not in the thesis; added here): mean of ``relu(margin - (v'_i - p_i) . n_i)``
  with ``p_i`` the nearest target skin vertex and ``n_i`` its normal.

The sample and the losses live in :mod:`dressmeup.methods.retarget.refine_losses`.

Training is self-supervised on (garment, source body, target body) triplets (no ground
truth), on CPU; inference is one forward pass.
"""

from __future__ import annotations

import io
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.errors import MissingModelError
from dressmeup.geometry.mesh import edges as mesh_edges
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.methods.retarget.base import body_context, check_garment
from dressmeup.methods.retarget.isomap import IsomapRetarget
from dressmeup.methods.retarget.refine_losses import (  # noqa: F401  (re-exported)
    MASK_JOINTS,
    RefineSample,
    correspondence_points,
    face_pairs,
    joint_mask,
    refine_losses,
    subsample,
)
from dressmeup.methods.retarget.train import train_network
from dressmeup.progress import progress

log = logging.getLogger(__name__)

__all__ = ["IsomapRefine", "IsomapRefineFast", "RefineSample", "refine_losses", "joint_mask",
           "correspondence_points", "WEIGHTS_DIR", "MASK_JOINTS"]

WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
_FORMAT = "dressmeup-isomap-refine-v1"


# --------------------------------------------------------------------------------------------
# the network
# --------------------------------------------------------------------------------------------
def _build_network(in_dim: int, code_dim: int, width: int, depth: int, pointnet_hidden: int, out_scale: float):
    # heavy: torch (~1.1 s to import)
    import torch
    from torch import nn

    from dressmeup.methods.nn.mlp import ConditionedMLP
    from dressmeup.methods.nn.pointnet import ResnetPointNet

    class RefineNet(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.encoder_garment = ResnetPointNet(c_dim=code_dim, hidden=pointnet_hidden)
            self.encoder_body = ResnetPointNet(c_dim=code_dim, hidden=pointnet_hidden)
            self.decoder = ConditionedMLP(in_dim, 3, code_dim=2 * code_dim, width=width, depth=depth,
                                          out_scale=out_scale)

        def forward(self, features: torch.Tensor, garment_points: torch.Tensor,
                    body_points: torch.Tensor) -> torch.Tensor:
            code = torch.cat([self.encoder_garment(garment_points), self.encoder_body(body_points)])
            return self.decoder(features, code)

    return RefineNet()


def _decode_with_partial(decoder, x, neighbors, phi_term, code):
    """:class:`~dressmeup.methods.nn.mlp.ConditionedMLP` forward with the first layer split by input.

    The first layer's input is ``[x (3), phi (d), neighbours (3k), code]``; ``phi_term`` is
    ``phi @ W_phi^T`` (per garment, precomputed) and the code's share is one vector per target,
    so only ``x`` and the neighbours are multiplied per vertex. Same result as
    ``decoder(cat([x, phi, neighbours]), code)`` up to float round-off (tested).
    """
    # heavy: torch (~1.1 s to import)
    import torch
    from torch import nn

    first = decoder.layers[0]
    W, b = first.weight, first.bias
    nk = neighbors.shape[1]
    d = W.shape[1] - 3 - nk - decoder.code_dim
    h = x @ W[:, :3].T + neighbors @ W[:, 3 + d:3 + d + nk].T + phi_term + (W[:, 3 + d + nk:] @ code + b)
    mod = decoder.film(code).view(len(decoder.layers), 2, decoder.width)
    for i in range(len(decoder.layers)):
        if i > 0:
            h = decoder.layers[i](h)
        h = nn.functional.layer_norm(h, (decoder.width,))
        h = (1.0 + mod[i, 0]) * h + mod[i, 1]
        h = decoder.act(h)
    return decoder.out_scale * torch.tanh(decoder.out(h))


class IsomapRefine(IsomapRetarget):
    """``isomap-refine``: Isomap coarse placement + self-supervised refinement network.

    Parameters
    ----------
    dim, k_extrapolate, k_place, embedding_method, n_landmarks, correspondence_noise :
        the coarse stage (see :class:`~dressmeup.methods.retarget.isomap.IsomapRetarget`).
    k_neighbors : int
        Target vertices fed per garment vertex (thesis: 32).
    width, depth : int
        Decoder MLP (thesis: 512, 6).
    code_dim : int
        Size of each PointNet code (thesis: 128).
    pointnet_hidden : int
        PointNet hidden width (demo: 128).
    n_points : int
        Points fed to each PointNet (a fixed-seed subsample).
    out_scale : float
        Largest offset per coordinate, metres (tanh output scale).
    steps : int
        Training steps (one triplet per step) of :meth:`fit`.
    lr : float
        Adam learning rate.
    w_length, w_corres, w_bend, w_penetration : float
        Loss weights (0 disables a term: the loss ablation).
    use_joint_mask : bool
        Joint masks in the edge-length loss.
    margin : float
        Penetration margin, metres.
    joint_mask_radius : float
        Radius of the joint masks, metres.
    weights : str or None
        Checkpoint to load when not fitted; ``None`` looks for the shipped
        ``weights/isomap_refine_<body model>.pt``.
    device : str
        Torch device ("cpu"; CUDA when asked and available).
    carry_offset : bool
        Feed the network the ``isomap-offset`` coarse placement (the loose-garment variant)
        instead of the thesis' eq. 4.4 one.
    precompute : bool
        Per-garment preparation of the coarse stage (see ``isomap``); ``False``: general path.
    seed : int
        Network initialisation, sample order and point subsampling.
    """

    name = "isomap-refine"
    _format = _FORMAT
    weights_stem = "isomap_refine"

    def __init__(self, dim: int = 128, k_extrapolate: int = 32, k_place: int = 32,
                 embedding_method: str = "auto", n_landmarks: int = 2000, correspondence_noise: float = 0.0,
                 k_neighbors: int = 32, width: int = 512, depth: int = 6, code_dim: int = 128,
                 pointnet_hidden: int = 128, n_points: int = 2048, out_scale: float = 0.15,
                 steps: int = 300, lr: float = 3e-4, w_length: float = 1.0, w_corres: float = 1.0,
                 w_bend: float = 0.01, w_penetration: float = 1.0, use_joint_mask: bool = True,
                 margin: float = 0.003, joint_mask_radius: float = 0.08, weights: str | None = None,
                 device: str = "cpu", carry_offset: bool = False, precompute: bool = True, seed: int = 0) -> None:
        self.carry_offset = carry_offset
        self.precompute = precompute
        self.dim = dim
        self.k_extrapolate = k_extrapolate
        self.k_place = k_place
        self.embedding_method = embedding_method
        self.n_landmarks = n_landmarks
        self.correspondence_noise = correspondence_noise
        self.k_neighbors = k_neighbors
        self.width = width
        self.depth = depth
        self.code_dim = code_dim
        self.pointnet_hidden = pointnet_hidden
        self.n_points = n_points
        self.out_scale = out_scale
        self.steps = steps
        self.lr = lr
        self.w_length = w_length
        self.w_corres = w_corres
        self.w_bend = w_bend
        self.w_penetration = w_penetration
        self.use_joint_mask = use_joint_mask
        self.margin = margin
        self.joint_mask_radius = joint_mask_radius
        self.weights = weights
        self.device = device
        self.seed = seed

    # the coarse stage of the thesis has no push-out and no smoothing
    offset = 0.0
    smooth_iterations = 0

    # ----------------------------------------------------------------------------------------
    def prepare(self, garment_V, garment_F, source, target, body_model, truth=None) -> RefineSample:
        """Coarse placement and every fixed per-sample input (see :class:`RefineSample`).

        ``truth`` : (n, 3) float array, optional: the ground-truth garment on the target (world
        frame), kept (in the sample's frame) for validation and the supervised variant.
        """
        t0 = time.perf_counter()
        res, s, t, emb = self.coarse(garment_V, garment_F, source, target, body_model)
        V = np.asarray(garment_V, dtype=np.float64)
        F = np.asarray(garment_F, dtype=np.int64)
        center = t.joints[0].copy()
        TV = t.skin_vertices - center
        x = res.positions - center
        tree = cKDTree(TV)
        k = int(min(self.k_neighbors, len(TV)))
        _, nb = tree.query(x, k=k)
        nb = np.asarray(nb).reshape(len(x), k)
        neighbors = (TV[nb] - x[:, None, :]).reshape(len(x), 3 * k)
        seconds = time.perf_counter() - t0
        E = mesh_edges(F)
        mask = joint_mask(V, s.joints, getattr(body_model, "joint_names", ()), self.joint_mask_radius)
        ew = (~(mask[E[:, 0]] | mask[E[:, 1]])).astype(np.float32)
        return RefineSample(
            x=x.astype(np.float32), phi=res.garment_embedding.astype(np.float32),
            neighbors=neighbors.astype(np.float32),
            garment_points=subsample(V - s.joints[0], self.n_points, self.seed).astype(np.float32),
            body_points=subsample(TV, self.n_points, self.seed + 1).astype(np.float32),
            input_V=V, faces=F, edges=E, edge_weights=ew, face_pairs=face_pairs(F),
            target_V=TV, target_N=t.skin_normals(), target_emb=emb.embedding, center=center,
            seconds_correspondence=seconds, _tree=tree,
            truth=None if truth is None else np.asarray(truth, dtype=np.float64) - center)

    def features(self, sample: RefineSample):
        """Network inputs of a sample: per-vertex features (n, 3 + d + 3k), garment points, body points."""
        # heavy: torch (~1.1 s to import)
        import torch

        feats = np.concatenate([sample.x, sample.phi, sample.neighbors], axis=1)
        dev = torch.device(self.device)
        return (torch.as_tensor(feats, device=dev), torch.as_tensor(sample.garment_points, device=dev),
                torch.as_tensor(sample.body_points, device=dev))

    def new_network(self):
        """A freshly initialised network (seeded) for these hyperparameters."""
        # heavy: torch (~1.1 s to import)
        import torch

        torch.manual_seed(int(self.seed))
        in_dim = 3 + int(self.dim) + 3 * int(self.k_neighbors)
        net = _build_network(in_dim, int(self.code_dim), int(self.width), int(self.depth),
                             int(self.pointnet_hidden), float(self.out_scale))
        return net.to(torch.device(self.device))

    def loss(self, net, sample: RefineSample) -> tuple[Any, dict[str, float]]:
        """Weighted total loss of ``net`` on one sample, and its terms as floats."""
        # heavy: torch (~1.1 s to import)
        import torch

        feats, gp, bp = self.features(sample)
        dx = net(feats, gp, bp)
        v = torch.as_tensor(sample.x, device=dx.device) + dx
        terms = refine_losses(v.cpu(), sample, margin=self.margin, use_joint_mask=self.use_joint_mask,
                              k_extrapolate=self.k_extrapolate, k_place=self.k_place)
        total = (self.w_length * terms["length"] + self.w_corres * terms["corres"]
                 + self.w_bend * terms["bend"] + self.w_penetration * terms["penetration"])
        return total, {k: float(t.detach()) for k, t in terms.items()}

    def fit(self, triplets, body_model, callback=None, val_triplets=None, wall_seconds: float | None = None,
            checkpoint=None, val_every: int = 50, checkpoint_every: int = 50) -> IsomapRefine:
        """Train on ``triplets`` (self-supervised: no ground truth is used for the loss).

        Parameters
        ----------
        triplets : sequence of (garment_V (n, 3), garment_F (m, 3), source BodyParams,
            target BodyParams[, truth (n, 3)]) - a fifth element (the target garment) is used
            only by the supervised variant.
        body_model : BodyModel
        callback : callable(step, total_loss, terms), optional, called every step.
        val_triplets : same form, optional: the validation split (its ground truth, when given,
            scores the validation curve and chooses the kept step).
        wall_seconds, checkpoint, val_every, checkpoint_every : see
            :func:`dressmeup.methods.retarget.train.train_network`.

        Returns
        -------
        self, with ``network_``, ``loss_history_`` (list of (total, terms) per step) and
        ``history_`` (:class:`~dressmeup.methods.retarget.train.TrainHistory`).
        """
        samples = self.prepare_many(triplets, body_model, "preparing training samples")
        val = self.prepare_many(val_triplets or [], body_model, "preparing validation samples")
        return self.fit_samples(samples, getattr(body_model, "name", ""), callback=callback, val_samples=val,
                                wall_seconds=wall_seconds, checkpoint=checkpoint, val_every=val_every,
                                checkpoint_every=checkpoint_every)

    def prepare_many(self, triplets, body_model, desc: str = "preparing") -> list[RefineSample]:
        """:meth:`prepare` of every (garment_V, garment_F, source, target[, truth]) tuple."""

        triplets = list(triplets)
        return [self.prepare(t[0], t[1], t[2], t[3], body_model, truth=t[4] if len(t) > 4 else None)
                for t in progress(triplets, desc=desc, total=len(triplets))]

    def fit_samples(self, samples: list[RefineSample], body_model_name: str = "", callback=None,
                    val_samples: list[RefineSample] | None = None, wall_seconds: float | None = None,
                    checkpoint=None, val_every: int = 50, checkpoint_every: int = 50) -> IsomapRefine:
        """Train on already prepared samples (:meth:`prepare`); see :meth:`fit`.

        The samples must come from the same coarse-stage and input settings (``dim``,
        ``k_neighbors``, ``n_points``, ...) as this object's; the loss settings may differ,
        which is how the loss ablation reuses one preparation for every variant.
        """

        if not samples:
            raise ValueError("samples: expected at least one prepared sample")
        net, history = train_network(self, samples, val_samples, steps=int(self.steps), wall_seconds=wall_seconds,
                                     val_every=val_every, checkpoint=checkpoint, checkpoint_every=checkpoint_every,
                                     callback=callback)
        self.network_ = net
        self.history_ = history
        self.loss_history_ = [(t, terms) for _, t, terms in history.train]
        self.body_model_name_ = body_model_name
        return self

    # ----------------------------------------------------------------------------------------
    def save(self, path, half: bool = False, info: dict | None = None) -> Path:
        """Write the hyperparameters and the network weights (atomic) to ``path`` (.pt).

        ``half`` stores the floating-point weights as float16 (half the file; they are read
        back as float32: the shipped files use it). ``info`` (JSON-like) is stored as the
        checkpoint's ``"training"`` record (data, steps, times).
        """

        # heavy: torch (~1.1 s to import)
        import torch

        if not hasattr(self, "network_"):
            raise ValueError(f"{self.name}: nothing to save, call fit() or load() first")
        params = {k: v for k, v in self.get_params().items() if k not in ("weights", "device")}
        state = {k: v.detach().cpu() for k, v in self.network_.state_dict().items()}
        if half:
            state = {k: v.half() if v.is_floating_point() else v for k, v in state.items()}
        buf = io.BytesIO()
        torch.save({"format": self._format, "hyperparameters": params, "body_model": self.body_model_name_,
                    "training": dict(info or {}), "state_dict": state}, buf)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, buf.getvalue())
        return path

    @classmethod
    def load(cls, path, device: str = "cpu") -> IsomapRefine:
        """Read a checkpoint written by :meth:`save` (hyperparameters included)."""
        # heavy: torch (~1.1 s to import)
        import torch

        path = Path(path)
        if not path.is_file():
            raise MissingModelError(f"{cls.name} weights not found: {path}; train them with "
                                    f"'dressmeup baseline train-retarget --data ROOT --out {path}'")
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
        if not isinstance(ckpt, dict) or ckpt.get("format") != cls._format:
            raise MissingModelError(f"{path}: not an {cls.name} checkpoint (format {cls._format} expected)")
        obj = cls(**ckpt["hyperparameters"], device=device, weights=str(path))
        obj._load_state(ckpt)
        return obj

    def _load_state(self, ckpt: dict) -> None:
        net = self.new_network()
        net.load_state_dict({k: v.float() if v.is_floating_point() else v for k, v in ckpt["state_dict"].items()})
        net.eval()
        self.network_ = net
        self.body_model_name_ = ckpt.get("body_model", "")

    def ensure_network(self, body_model) -> None:
        """Load the weights (``weights`` or the shipped file of ``body_model``) unless fitted or loaded."""
        if hasattr(self, "network_"):
            return
        # heavy: torch (~1.1 s to import)
        import torch

        path = Path(self.weights) if self.weights else WEIGHTS_DIR / f"{self.weights_stem}_{body_model.name}.pt"
        if not path.is_file():
            raise MissingModelError(
                f"{self.name}: no trained weights for body model {body_model.name!r} (looked for {path}); "
                "train them with 'dressmeup baseline train-retarget --data ROOT --out WEIGHTS.pt' and pass "
                "weights=WEIGHTS.pt (CLI: --weights)")
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
        if ckpt.get("format") != self._format:
            raise MissingModelError(f"{path}: not an {self.name} checkpoint (format {self._format} expected)")
        keep = ("weights", "device", "correspondence_noise", "steps", "lr", "carry_offset", "precompute")
        for k, v in ckpt["hyperparameters"].items():
            if k not in keep:
                setattr(self, k, v)
        self._load_state(ckpt)

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """Coarse placement + one forward pass; returns (n, 3) float64.

        With ``precompute`` (default) the garment's preparation (eq. 4.1, the k-NN of eq. 4.4,
        the garment's PointNet code and the embedding's share of the first layer) is computed
        once per garment and source body; a new target then costs posing it, a gather, the
        k nearest target vertices of each coarse point, the body PointNet and the rest of the
        network. ``precompute=False`` runs the general path (both k-NN searches and the whole
        network per call). ``last_timing_`` holds the seconds of the target posing, the
        correspondence part (coarse placement and neighbour search) and the network.
        """
        self.ensure_network(body_model)
        if not self.precompute:
            sample = self.prepare(garment_V, garment_F, source, target, body_model)
            t0 = time.perf_counter()
            out = self.predict_sample(sample)
            self.last_timing_ = {"correspondence": sample.seconds_correspondence,
                                 "network": time.perf_counter() - t0}
            return out
        return self._retarget_prepared(garment_V, garment_F, source, target, body_model)

    def _retarget_prepared(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        # heavy: torch (~1.1 s to import)
        import torch

        V, F = check_garment(garment_V, garment_F)
        t0 = time.perf_counter()
        s = body_context(body_model, source)
        t1 = time.perf_counter()
        emb = self.embedding(body_model)
        prep = self.prepared(V, F, s, emb)
        part = self._garment_partial(prep, V, s)
        t2 = time.perf_counter()
        t = body_context(body_model, target)
        t3 = time.perf_counter()
        center = t.joints[0]
        TV = t.skin_vertices - center
        x = (prep.with_offset(t.skin_vertices, t.skin_normals()) if self.carry_offset
             else prep.coarse(t.skin_vertices)) - center
        if self.correspondence_noise:
            x = x + np.random.default_rng(self.seed).normal(0.0, float(self.correspondence_noise), size=x.shape)
        x = x.astype(np.float32)
        k = int(min(self.k_neighbors, len(TV)))
        _, nb = cKDTree(TV).query(x, k=k)
        nb = np.asarray(nb).reshape(len(x), k)
        neighbors = (TV[nb].astype(np.float32) - x[:, None, :]).reshape(len(x), 3 * k)
        t4 = time.perf_counter()
        dev = torch.device(self.device)
        net = self.network_
        with torch.no_grad():
            body_pts = torch.as_tensor(subsample(TV, self.n_points, self.seed + 1).astype(np.float32), device=dev)
            code = torch.cat([part["garment_code"], net.encoder_body(body_pts)])
            dx = _decode_with_partial(net.decoder, torch.as_tensor(x, device=dev),
                                      torch.as_tensor(neighbors, device=dev), part["phi_term"], code)
        t5 = time.perf_counter()
        self.last_timing_ = {"source_posing": t1 - t0, "preparation": t2 - t1, "target_posing": t3 - t2,
                             "correspondence": t4 - t3, "network": t5 - t4}
        return x.astype(np.float64) + dx.cpu().numpy().astype(np.float64) + center

    def _garment_partial(self, prep, V: np.ndarray, s) -> dict:
        """Per-garment network inputs: the garment's PointNet code and ``phi W_phi^T`` (memoised)."""
        # heavy: torch (~1.1 s to import)
        import torch

        key = (prep.key, id(self.network_), int(self.n_points), int(self.seed))
        memo = self.__dict__.setdefault("_partial_memo", {})
        if key not in memo:
            if len(memo) >= 8:
                memo.pop(next(iter(memo)))
            dev = torch.device(self.device)
            net = self.network_
            d = int(self.dim)
            with torch.no_grad():
                gp = torch.as_tensor(subsample(V - s.joints[0], self.n_points, self.seed).astype(np.float32),
                                     device=dev)
                W = net.decoder.layers[0].weight
                phi_term = torch.as_tensor(prep.phi.astype(np.float32), device=dev) @ W[:, 3:3 + d].T
                memo[key] = {"garment_code": net.encoder_garment(gp), "phi_term": phi_term}
        return memo[key]

    def predict_sample(self, sample: RefineSample) -> np.ndarray:
        """One forward pass on a prepared sample: (n, 3) float64 world positions."""
        # heavy: torch (~1.1 s to import)
        import torch

        if not hasattr(self, "network_"):
            raise ValueError(f"{self.name}: no network; call fit() or load() first")
        with torch.no_grad():
            feats, gp, bp = self.features(sample)
            dx = self.network_(feats, gp, bp).cpu().numpy().astype(np.float64)
        return sample.x.astype(np.float64) + dx + sample.center


class IsomapRefineFast(IsomapRefine):
    """``isomap-refine-fast``: ``isomap-refine`` with a narrower network (the ``fast`` preset).

    Decoder 6 x 256 with 64-d PointNet codes and PointNet hidden width 64 (about 4x fewer
    operations per vertex than the thesis' 6 x 512 / 128); shipped weights
    ``weights/isomap_refine_fast_<body model>.pt``. Same hyperparameters as
    :class:`IsomapRefine`, with these defaults.
    """

    name = "isomap-refine-fast"
    weights_stem = "isomap_refine_fast"

    def __init__(self, dim: int = 128, k_extrapolate: int = 32, k_place: int = 32,
                 embedding_method: str = "auto", n_landmarks: int = 2000, correspondence_noise: float = 0.0,
                 k_neighbors: int = 32, width: int = 256, depth: int = 6, code_dim: int = 64,
                 pointnet_hidden: int = 64, n_points: int = 2048, out_scale: float = 0.15,
                 steps: int = 300, lr: float = 3e-4, w_length: float = 1.0, w_corres: float = 1.0,
                 w_bend: float = 0.01, w_penetration: float = 1.0, use_joint_mask: bool = True,
                 margin: float = 0.003, joint_mask_radius: float = 0.08, weights: str | None = None,
                 device: str = "cpu", carry_offset: bool = False, precompute: bool = True, seed: int = 0) -> None:
        super().__init__(dim=dim, k_extrapolate=k_extrapolate, k_place=k_place, embedding_method=embedding_method,
                         n_landmarks=n_landmarks, correspondence_noise=correspondence_noise,
                         k_neighbors=k_neighbors, width=width, depth=depth, code_dim=code_dim,
                         pointnet_hidden=pointnet_hidden, n_points=n_points, out_scale=out_scale, steps=steps,
                         lr=lr, w_length=w_length, w_corres=w_corres, w_bend=w_bend, w_penetration=w_penetration,
                         use_joint_mask=use_joint_mask, margin=margin, joint_mask_radius=joint_mask_radius,
                         weights=weights, device=device, carry_offset=carry_offset, precompute=precompute,
                         seed=seed)
