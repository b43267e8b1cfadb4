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

The sample and the losses live in :mod:`dressmeup.methods.retarget.refine_losses`; the
precomputed inference path in :mod:`dressmeup.methods.retarget.refine_infer`.

Training is self-supervised on (garment, source body, target body) triplets (no ground
truth), on CPU; inference is one forward pass.
"""

from __future__ import annotations

import io
import logging
import time
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from dressmeup.errors import InputError, MissingModelError
from dressmeup.geometry.mesh import edges as mesh_edges
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.methods.nn.checkpoint import load_checkpoint
from dressmeup.methods.retarget.base import RetargetMethod
from dressmeup.methods.retarget.embedding import TemplateEmbedding
from dressmeup.methods.retarget.isomap import IsomapRetarget
from dressmeup.methods.retarget.refine_config import PRESETS, RefineConfig, get_config
from dressmeup.methods.retarget.refine_infer import retarget_prepared
from dressmeup.methods.retarget.refine_losses import (
    RefineSample,
    face_pairs,
    joint_mask,
    refine_losses,
    subsample,
)
from dressmeup.methods.retarget.train import train_network
from dressmeup.progress import progress

log = logging.getLogger(__name__)

__all__ = ["IsomapRefine", "IsomapRefineFast", "WEIGHTS_DIR"]

WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
_FORMAT = "dressmeup-isomap-refine-v1"


class IsomapRefine(RetargetMethod):
    """``isomap-refine``: Isomap coarse placement + self-supervised refinement network.

    Parameters
    ----------
    config : str or RefineConfig
        A preset of :data:`~dressmeup.methods.retarget.refine_config.PRESETS` (default: the
        class's ``default_preset``, the thesis' network) or a configuration.
    weights : str or None
        Checkpoint to load when not fitted; ``None`` looks for the shipped
        ``weights/<weights_stem>_<body model>.pt``.
    device : str
        Torch device ("cpu"; CUDA when asked and available).
    **overrides
        Settings of :class:`~dressmeup.methods.retarget.refine_config.RefineConfig`
        (validated: an unknown name or a wrong type raises ``InputError``). The settings are
        ``method.config`` (``method.config.width``); :meth:`set_params` replaces it.
    """

    name = "isomap-refine"
    _format = _FORMAT
    weights_stem = "isomap_refine"
    default_preset = "thesis"
    presets: dict[str, RefineConfig] = PRESETS

    def __init__(self, config: str | RefineConfig | None = None, *, weights: str | None = None,
                 device: str = "cpu", **overrides: Any) -> None:
        self.config = get_config(config or self.default_preset, presets=self.presets, **overrides)
        self.weights = weights
        self.device = device

    @classmethod
    def hyperparameter_names(cls) -> list[str]:
        """Every keyword :func:`~dressmeup.methods.retarget.get_method` accepts for this method."""
        kind = type(next(iter(cls.presets.values())))
        return ["config", "weights", "device", *(f.name for f in fields(kind))]

    def get_params(self) -> dict[str, Any]:
        """The settings of the configuration, ``weights`` and ``device``, as a dict."""
        return {**asdict(self.config), "weights": self.weights, "device": self.device}

    def set_params(self, **params: Any) -> IsomapRefine:
        """Change settings by name (validated like the constructor's overrides)."""
        runtime = {k: params.pop(k) for k in ("weights", "device") if k in params}
        self.config = get_config(self.config, presets=self.presets, **params)
        for k, v in runtime.items():
            setattr(self, k, v)
        return self

    def coarse_method(self) -> IsomapRetarget:
        """The coarse stage these settings describe (the thesis': no push-out, no smoothing)."""
        c = self.config
        return IsomapRetarget(dim=c.dim, k_extrapolate=c.k_extrapolate, k_place=c.k_place,
                              embedding_method=c.embedding_method, n_landmarks=c.n_landmarks,
                              correspondence_noise=c.correspondence_noise,
                              carry_offset=c.carry_offset, precompute=c.precompute, seed=c.seed)

    def embedding(self, body_model) -> TemplateEmbedding:
        """The (cached) template embedding of the coarse stage."""
        return self.coarse_method().embedding(body_model)

    def prepared(self, garment_V, garment_F, source_context, embedding: TemplateEmbedding):
        """The coarse stage's per-garment preparation (see :meth:`IsomapRetarget.prepared`)."""
        return self.coarse_method().prepared(garment_V, garment_F, source_context, embedding)

    def coarse(self, garment_V, garment_F, source, target, body_model):
        """The coarse placement (see :meth:`IsomapRetarget.coarse`)."""
        return self.coarse_method().coarse(garment_V, garment_F, source, target, body_model)

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
        k = int(min(self.config.k_neighbors, len(TV)))
        _, nb = tree.query(x, k=k)
        nb = np.asarray(nb).reshape(len(x), k)
        neighbors = (TV[nb] - x[:, None, :]).reshape(len(x), 3 * k)
        seconds = time.perf_counter() - t0
        E = mesh_edges(F)
        mask = joint_mask(V, s.joints, getattr(body_model, "joint_names", ()), self.config.joint_mask_radius)
        ew = (~(mask[E[:, 0]] | mask[E[:, 1]])).astype(np.float32)
        return RefineSample(
            x=x.astype(np.float32), phi=res.garment_embedding.astype(np.float32),
            neighbors=neighbors.astype(np.float32),
            garment_points=subsample(V - s.joints[0], self.config.n_points, self.config.seed).astype(np.float32),
            body_points=subsample(TV, self.config.n_points, self.config.seed + 1).astype(np.float32),
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

        from dressmeup.methods.retarget.refine_net import build_network

        torch.manual_seed(int(self.config.seed))
        in_dim = 3 + int(self.config.dim) + 3 * int(self.config.k_neighbors)
        net = build_network(in_dim, int(self.config.code_dim), int(self.config.width), int(self.config.depth),
                            int(self.config.pointnet_hidden), float(self.config.out_scale))
        return net.to(torch.device(self.device))

    def loss(self, net, sample: RefineSample) -> tuple[Any, dict[str, float]]:
        """Weighted total loss of ``net`` on one sample, and its terms as floats."""
        # heavy: torch (~1.1 s to import)
        import torch

        feats, gp, bp = self.features(sample)
        dx = net(feats, gp, bp)
        v = torch.as_tensor(sample.x, device=dx.device) + dx
        terms = refine_losses(v.cpu(), sample, margin=self.config.margin, use_joint_mask=self.config.use_joint_mask,
                              k_extrapolate=self.config.k_extrapolate, k_place=self.config.k_place)
        total = (self.config.w_length * terms["length"] + self.config.w_corres * terms["corres"]
                 + self.config.w_bend * terms["bend"] + self.config.w_penetration * terms["penetration"])
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
                    checkpoint=None, val_every: int = 50, checkpoint_every: int = 50,
                    until_converged: bool = False) -> IsomapRefine:
        """Train on already prepared samples (:meth:`prepare`); see :meth:`fit` (and
        :func:`~dressmeup.methods.retarget.train.train_network` for ``until_converged``).

        The samples must come from the same coarse-stage and input settings (``dim``,
        ``k_neighbors``, ``n_points``, ...) as this object's; the loss settings may differ,
        which is how the loss ablation reuses one preparation for every variant.
        """

        if not samples:
            raise ValueError("samples: expected at least one prepared sample")
        net, history = train_network(self, samples, val_samples, steps=int(self.config.steps),
                                     wall_seconds=wall_seconds, val_every=val_every,
                                     checkpoint=checkpoint, checkpoint_every=checkpoint_every,
                                     callback=callback, until_converged=until_converged)
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
        params = asdict(self.config)
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
        path = Path(path)
        if not path.is_file():
            raise MissingModelError(f"{cls.name} weights not found: {path}; train them with "
                                    f"'dressmeup baseline train-retarget --data ROOT --out {path}'")
        ckpt = load_checkpoint(path, f"{cls.name} weights", cls._format,
                               ("hyperparameters", "state_dict"))
        obj = cls(device=device, weights=str(path), **ckpt["hyperparameters"])
        obj._load_state(ckpt)
        return obj

    def _load_state(self, ckpt: dict) -> None:
        net = self.new_network()
        try:
            net.load_state_dict({k: v.float() if v.is_floating_point() else v
                                 for k, v in ckpt["state_dict"].items()})
        except (RuntimeError, AttributeError, TypeError) as exc:
            raise InputError(f"{self.name} weights {self.weights}: they do not fit the "
                             f"network ({str(exc).splitlines()[0][:200]})") from exc
        net.eval()
        self.network_ = net
        self.body_model_name_ = ckpt.get("body_model", "")

    def ensure_network(self, body_model) -> None:
        """Load the weights (``weights`` or the shipped file of ``body_model``) unless fitted or loaded."""
        if hasattr(self, "network_"):
            return
        path = Path(self.weights) if self.weights else WEIGHTS_DIR / f"{self.weights_stem}_{body_model.name}.pt"
        if not path.is_file():
            raise MissingModelError(
                f"{self.name}: no trained weights for body model {body_model.name!r} (looked for {path}); "
                "train them with 'dressmeup baseline train-retarget --data ROOT --out WEIGHTS.pt' and pass "
                "weights=WEIGHTS.pt (CLI: --weights)")
        ckpt = load_checkpoint(path, f"{self.name} weights", self._format,
                               ("hyperparameters", "state_dict"))
        keep = ("correspondence_noise", "steps", "lr", "carry_offset", "precompute")
        self.set_params(**{k: v for k, v in ckpt["hyperparameters"].items() if k not in keep})
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
        if not self.config.precompute:
            sample = self.prepare(garment_V, garment_F, source, target, body_model)
            t0 = time.perf_counter()
            out = self.predict_sample(sample)
            self.last_timing_ = {"correspondence": sample.seconds_correspondence,
                                 "network": time.perf_counter() - t0}
            return out
        return retarget_prepared(self, garment_V, garment_F, source, target, body_model)

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
    """``isomap-refine-fast``: ``isomap-refine`` with the ``fast`` preset (decoder 6 x 128,
    64-d PointNet codes, PointNet hidden width 64, 16 target neighbours: about 14x fewer
    operations per vertex than the thesis' 6 x 512 / 128 / 32); shipped weights
    ``weights/isomap_refine_fast_<body model>.pt`` (their own hyperparameters are loaded).
    """

    name = "isomap-refine-fast"
    weights_stem = "isomap_refine_fast"
    default_preset = "fast"
