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

import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.errors import MissingModelError
from dressmeup.geometry.mesh import edges as mesh_edges
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

log = logging.getLogger(__name__)

__all__ = ["IsomapRefine", "RefineSample", "refine_losses", "joint_mask",
           "correspondence_points", "WEIGHTS_DIR", "MASK_JOINTS"]

WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
_FORMAT = "dressmeup-isomap-refine-v1"


# --------------------------------------------------------------------------------------------
# the network
# --------------------------------------------------------------------------------------------
def _build_network(in_dim: int, code_dim: int, width: int, depth: int, pointnet_hidden: int, out_scale: float):
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
    seed : int
        Network initialisation, sample order and point subsampling.
    """

    name = "isomap-refine"

    def __init__(self, dim: int = 128, k_extrapolate: int = 32, k_place: int = 32,
                 embedding_method: str = "auto", n_landmarks: int = 2000, correspondence_noise: float = 0.0,
                 k_neighbors: int = 32, width: int = 512, depth: int = 6, code_dim: int = 128,
                 pointnet_hidden: int = 128, n_points: int = 2048, out_scale: float = 0.15,
                 steps: int = 300, lr: float = 3e-4, w_length: float = 1.0, w_corres: float = 1.0,
                 w_bend: float = 0.01, w_penetration: float = 1.0, use_joint_mask: bool = True,
                 margin: float = 0.003, joint_mask_radius: float = 0.08, weights: str | None = None,
                 device: str = "cpu", seed: int = 0) -> None:
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
    def prepare(self, garment_V, garment_F, source, target, body_model) -> RefineSample:
        """Coarse placement and every fixed per-sample input (see :class:`RefineSample`)."""
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
            seconds_correspondence=seconds, _tree=tree)

    def features(self, sample: RefineSample):
        """Network inputs of a sample: per-vertex features (n, 3 + d + 3k), garment points, body points."""
        import torch

        feats = np.concatenate([sample.x, sample.phi, sample.neighbors], axis=1)
        dev = torch.device(self.device)
        return (torch.as_tensor(feats, device=dev), torch.as_tensor(sample.garment_points, device=dev),
                torch.as_tensor(sample.body_points, device=dev))

    def new_network(self):
        """A freshly initialised network (seeded) for these hyperparameters."""
        import torch

        torch.manual_seed(int(self.seed))
        in_dim = 3 + int(self.dim) + 3 * int(self.k_neighbors)
        net = _build_network(in_dim, int(self.code_dim), int(self.width), int(self.depth),
                             int(self.pointnet_hidden), float(self.out_scale))
        return net.to(torch.device(self.device))

    def loss(self, net, sample: RefineSample) -> tuple[Any, dict[str, float]]:
        """Weighted total loss of ``net`` on one sample, and its terms as floats."""
        import torch

        feats, gp, bp = self.features(sample)
        dx = net(feats, gp, bp)
        v = torch.as_tensor(sample.x, device=dx.device) + dx
        terms = refine_losses(v.cpu(), sample, margin=self.margin, use_joint_mask=self.use_joint_mask,
                              k_extrapolate=self.k_extrapolate, k_place=self.k_place)
        total = (self.w_length * terms["length"] + self.w_corres * terms["corres"]
                 + self.w_bend * terms["bend"] + self.w_penetration * terms["penetration"])
        return total, {k: float(t.detach()) for k, t in terms.items()}

    def fit(self, triplets, body_model, callback=None) -> IsomapRefine:
        """Train self-supervised on ``triplets``.

        Parameters
        ----------
        triplets : sequence of (garment_V (n, 3), garment_F (m, 3), source BodyParams,
            target BodyParams) - no ground truth is used.
        body_model : BodyModel
        callback : callable(step, total_loss, terms), optional, called every step.

        Returns
        -------
        self, with ``network_`` and ``loss_history_`` (list of (total, terms) per step).
        """
        from dressmeup.progress import progress

        triplets = list(triplets)
        if not triplets:
            raise ValueError("triplets: expected at least one (garment_V, garment_F, source, target) triplet")
        samples = [self.prepare(gv, gf, s, t, body_model)
                   for gv, gf, s, t in progress(triplets, desc="preparing", total=len(triplets))]
        return self.fit_samples(samples, getattr(body_model, "name", ""), callback=callback)

    def fit_samples(self, samples: list[RefineSample], body_model_name: str = "",
                    callback=None) -> IsomapRefine:
        """Train on already prepared samples (:meth:`prepare`); see :meth:`fit`.

        The samples must come from the same coarse-stage and input settings (``dim``,
        ``k_neighbors``, ``n_points``, ...) as this object's; the loss settings may differ,
        which is how the loss ablation reuses one preparation for every variant.
        """
        import torch

        from dressmeup.progress import progress

        if not samples:
            raise ValueError("samples: expected at least one prepared sample")
        net = self.new_network()
        opt = torch.optim.Adam(net.parameters(), lr=float(self.lr))
        rng = np.random.default_rng(int(self.seed))
        order = np.concatenate([rng.permutation(len(samples)) for _ in range(int(self.steps) // len(samples) + 1)])
        history = []
        net.train()
        for step in progress(range(int(self.steps)), desc="training isomap-refine", total=int(self.steps)):
            total, terms = self.loss(net, samples[order[step]])
            opt.zero_grad()
            total.backward()
            opt.step()
            history.append((float(total.detach()), terms))
            if callback is not None:
                callback(step, float(total), terms)
        net.eval()
        self.network_ = net
        self.loss_history_ = history
        self.body_model_name_ = body_model_name
        return self

    # ----------------------------------------------------------------------------------------
    def save(self, path) -> Path:
        """Write the hyperparameters and the network weights (atomic) to ``path`` (.pt)."""
        import io

        import torch

        from dressmeup.io.atomic import atomic_write_bytes

        if not hasattr(self, "network_"):
            raise ValueError("isomap-refine: nothing to save, call fit() or load() first")
        params = {k: v for k, v in self.get_params().items() if k not in ("weights", "device")}
        buf = io.BytesIO()
        torch.save({"format": _FORMAT, "hyperparameters": params, "body_model": self.body_model_name_,
                    "state_dict": {k: v.detach().cpu() for k, v in self.network_.state_dict().items()}}, buf)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, buf.getvalue())
        return path

    @classmethod
    def load(cls, path, device: str = "cpu") -> IsomapRefine:
        """Read a checkpoint written by :meth:`save` (hyperparameters included)."""
        import torch

        path = Path(path)
        if not path.is_file():
            raise MissingModelError(f"isomap-refine weights not found: {path}; train them with "
                                    f"'dressmeup baseline train-retarget --data ROOT --out {path}'")
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
        if not isinstance(ckpt, dict) or ckpt.get("format") != _FORMAT:
            raise MissingModelError(f"{path}: not an isomap-refine checkpoint (format {_FORMAT} expected)")
        obj = cls(**ckpt["hyperparameters"], device=device, weights=str(path))
        obj._load_state(ckpt)
        return obj

    def _load_state(self, ckpt: dict) -> None:
        net = self.new_network()
        net.load_state_dict(ckpt["state_dict"])
        net.eval()
        self.network_ = net
        self.body_model_name_ = ckpt.get("body_model", "")

    def ensure_network(self, body_model) -> None:
        """Load the weights (``weights`` or the shipped file of ``body_model``) unless fitted or loaded."""
        if hasattr(self, "network_"):
            return
        import torch

        path = Path(self.weights) if self.weights else WEIGHTS_DIR / f"isomap_refine_{body_model.name}.pt"
        if not path.is_file():
            raise MissingModelError(
                f"isomap-refine: no trained weights for body model {body_model.name!r} (looked for {path}); "
                "train them with 'dressmeup baseline train-retarget --data ROOT --out WEIGHTS.pt' and pass "
                "weights=WEIGHTS.pt (CLI: --weights)")
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
        if ckpt.get("format") != _FORMAT:
            raise MissingModelError(f"{path}: not an isomap-refine checkpoint")
        keep = ("weights", "device", "correspondence_noise", "steps", "lr")
        for k, v in ckpt["hyperparameters"].items():
            if k not in keep:
                setattr(self, k, v)
        self._load_state(ckpt)

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """Coarse placement + one forward pass; returns (n, 3) float64.

        ``last_timing_`` holds the seconds of the correspondence search (coarse placement and
        neighbour search) and of the network forward pass.
        """

        self.ensure_network(body_model)
        sample = self.prepare(garment_V, garment_F, source, target, body_model)
        t0 = time.perf_counter()
        out = self.predict_sample(sample)
        self.last_timing_ = {"correspondence": sample.seconds_correspondence,
                             "network": time.perf_counter() - t0}
        return out

    def predict_sample(self, sample: RefineSample) -> np.ndarray:
        """One forward pass on a prepared sample: (n, 3) float64 world positions."""
        import torch

        if not hasattr(self, "network_"):
            raise ValueError("isomap-refine: no network; call fit() or load() first")
        with torch.no_grad():
            feats, gp, bp = self.features(sample)
            dx = self.network_(feats, gp, bp).cpu().numpy().astype(np.float64)
        return sample.x.astype(np.float64) + dx + sample.center
