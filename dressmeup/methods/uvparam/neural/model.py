"""The neural UV model: its configuration (named presets + overrides), its torch modules and
its checkpoints (plain ``torch.save`` dictionaries of tensors and numbers, loaded with
``weights_only=True``). Training: :mod:`dressmeup.methods.uvparam.neural.train`.
"""

from __future__ import annotations

import io
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.methods.nn.checkpoint import load_checkpoint
from dressmeup.methods.uvparam.neural.patchnet import build_patchnet
from dressmeup.methods.uvparam.neural.uv_mlp import build_mlp, count_parameters

__all__ = ["NeuralConfig", "CONFIGS", "NeuralUVModel", "get_config", "build_modules",
           "plain_values", "save_model", "load_model"]


@dataclass(frozen=True)
class NeuralConfig:
    """Hyperparameters of the neural method (defaults: the thesis' reference configuration).

    Attributes
    ----------
    n_patches : int
        K, PatchNet's number of patches.
    patch_width, patch_blocks, k_eig : int
        DiffusionNet width (128), blocks (4) and eigenvectors (64).
    patch_iters, patch_lr : int, float
        PatchNet optimisation steps and Adam learning rate (1e-3).
    lambda_cos, lambda_geo : float
        PatchNet loss weights (1, 1).
    geo_landmarks : int
        Vertices used for the geodesic loss' distance matrix.
    mlp_width, mlp_depth : int
        UV MLP width and number of linear layers; 320 x 8 gives ~0.66M parameters per MLP,
        ~1.3M for the pair (the thesis' size).
    uv_iters, uv_lr : int, float
        UV MLP optimisation steps and learning rate (1e-3).
    weights : tuple of 4 floats
        (cycle, isometric, angle, area) = (1, 1, 0.001, 0.001) as in the thesis.
    sigma : float
        Geodesic threshold of the isometric loss (0.2, in units of the bounding-box diagonal).
    pairs_per_iter : int
        Random subset of the isometric pairs used per step.
    consolidation_steps, min_chart_fraction : int, float
        Face assignment: neighbour averaging steps, island merge threshold.
    train_vertices : int
        Meshes with more vertices are decimated to about this many for training.
    seed : int
    """

    n_patches: int = 8
    patch_width: int = 128
    patch_blocks: int = 4
    k_eig: int = 64
    patch_iters: int = 300
    patch_lr: float = 1e-3
    lambda_cos: float = 1.0
    lambda_geo: float = 1.0
    geo_landmarks: int = 1200
    mlp_width: int = 320
    mlp_depth: int = 8
    uv_iters: int = 1500
    uv_lr: float = 1e-3
    weights: tuple = (1.0, 1.0, 0.001, 0.001)
    sigma: float = 0.2
    pairs_per_iter: int = 40000
    consolidation_steps: int = 2
    min_chart_fraction: float = 0.01
    train_vertices: int = 2500
    seed: int = 0


#: named configurations: the thesis' sizes and a smaller, faster one
CONFIGS = {
    "reference": NeuralConfig(),
    "fast": NeuralConfig(patch_width=64, patch_blocks=4, mlp_width=128, mlp_depth=6,
                         patch_iters=200, uv_iters=800),
}


def get_config(config: str | NeuralConfig = "fast", **overrides: Any) -> NeuralConfig:
    """Resolve a configuration name (``"reference"``, ``"fast"``) and keyword overrides.

    Raises
    ------
    ValueError
        Unknown name or unknown override.
    """
    if isinstance(config, NeuralConfig):
        base = config
    elif config in CONFIGS:
        base = CONFIGS[config]
    else:
        raise ValueError(f"config: expected one of {', '.join(CONFIGS)} or a NeuralConfig, got {config!r}")
    names = {f.name for f in fields(NeuralConfig)}
    bad = sorted(set(overrides) - names)
    if bad:
        raise ValueError(f"unknown neural hyperparameter(s) {bad}; valid: {sorted(names)}")
    if "weights" in overrides:
        overrides["weights"] = tuple(float(w) for w in overrides["weights"])
    return replace(base, **overrides)


@dataclass
class NeuralUVModel:
    """A trained neural UV parameterisation (torch modules + configuration + training log)."""

    config: NeuralConfig
    patchnet: Any
    forward_mlp: Any
    backward_mlp: Any
    history: dict = field(default_factory=dict)

    @property
    def n_parameters(self) -> dict:
        return {"patchnet": count_parameters(self.patchnet),
                "forward_mlp": count_parameters(self.forward_mlp),
                "backward_mlp": count_parameters(self.backward_mlp)}


def build_modules(cfg: NeuralConfig):
    """Fresh ``(patchnet, forward_mlp, backward_mlp)`` of the sizes of ``cfg``, seeded by
    ``cfg.seed`` (PatchNet), ``+ 1`` and ``+ 2`` (the MLPs)."""
    patchnet = build_patchnet(cfg.n_patches, cfg.patch_width, cfg.patch_blocks, seed=cfg.seed)
    fwd = build_mlp(3 + cfg.patch_width, 2, cfg.mlp_width, cfg.mlp_depth, out_scale=1.0, seed=cfg.seed + 1)
    bwd = build_mlp(2 + cfg.patch_width, 3, cfg.mlp_width, cfg.mlp_depth, out_scale=1.0, seed=cfg.seed + 2)
    return patchnet, fwd, bwd


def plain_values(value: Any) -> Any:
    """Loss histories as plain Python numbers/strings/lists (loadable with weights_only)."""
    if isinstance(value, dict):
        return {str(k): plain_values(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain_values(v) for v in value]
    if isinstance(value, (str, bool, int)) or value is None:
        return value
    return float(value)


def save_model(model: NeuralUVModel, path: str | Path, half: bool = False) -> None:
    """Write a checkpoint (configuration, state dicts, loss history) atomically.

    Parameters
    ----------
    model : NeuralUVModel
    path : str or Path
    half : bool
        Store the weights as float16 (half the size; :func:`load_model` restores float32).
        Used for the checkpoints shipped in the package.
    """

    # heavy: torch (~1.1 s to import)
    import torch

    def weights(module):
        sd = module.state_dict()
        return {k: (v.half() if half and v.is_floating_point() else v) for k, v in sd.items()}

    state = {"format": "dressmeup-neural-uv-v1", "config": asdict(model.config),
             "patchnet": weights(model.patchnet), "forward_mlp": weights(model.forward_mlp),
             "backward_mlp": weights(model.backward_mlp), "history": plain_values(model.history)}
    buf = io.BytesIO()
    torch.save(state, buf)
    atomic_write_bytes(path, buf.getvalue())


def load_model(path: str | Path) -> NeuralUVModel:
    """Read a checkpoint written by :func:`save_model`.

    Raises
    ------
    FileNotFoundError
        Missing file.
    InputError
        Not a neural-UV checkpoint (or over the limits of :mod:`dressmeup.limits`).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"neural UV checkpoint {path} does not exist (train one with "
                                "'dressmeup baseline train-uvparam')")
    state = load_checkpoint(path, "neural UV checkpoint", "dressmeup-neural-uv-v1",
                            ("config", "patchnet", "forward_mlp", "backward_mlp"))
    def weights(sd):  # float16 checkpoints (shipped ones) back to float32
        return {k: (v.float() if v.is_floating_point() else v) for k, v in sd.items()}

    try:
        c = dict(state["config"])
        c["weights"] = tuple(c["weights"])
        cfg = NeuralConfig(**c)
        patchnet, fwd, bwd = build_modules(cfg)
        patchnet.load_state_dict(weights(state["patchnet"]))
        fwd.load_state_dict(weights(state["forward_mlp"]))
        bwd.load_state_dict(weights(state["backward_mlp"]))
    except (RuntimeError, ValueError, TypeError, KeyError, AttributeError) as exc:
        raise InputError(f"neural UV checkpoint {path}: damaged or of another version "
                         f"({str(exc).splitlines()[0][:200]})") from exc
    return NeuralUVModel(cfg, patchnet.eval(), fwd.eval(), bwd.eval(), state.get("history", {}))
