"""Hyperparameters of the refinement networks (``isomap-refine``, ``-fast``, ``-sup``): one
frozen configuration per method, built from a named preset and validated overrides."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from dressmeup.hyperparameters import resolve_config


@dataclass(frozen=True)
class RefineConfig:
    """Hyperparameters of ``isomap-refine`` (defaults: the thesis' network, preset ``thesis``).

    Attributes
    ----------
    dim, k_extrapolate, k_place, embedding_method, n_landmarks, correspondence_noise :
        the coarse stage (see :class:`~dressmeup.methods.retarget.isomap.IsomapRetarget`).
    carry_offset : bool
        Feed the network the ``isomap-offset`` coarse placement (the loose-garment variant)
        instead of the thesis' eq. 4.4 one.
    precompute : bool
        Per-garment preparation of the coarse stage (see ``isomap``); ``False``: general path.
    k_neighbors : int
        Target vertices fed per garment vertex (thesis: 32).
    width, depth : int
        Decoder MLP (thesis: 512, 6).
    code_dim : int
        Size of each PointNet code (thesis: 128).
    pointnet_hidden : int
        PointNet hidden width.
    n_points : int
        Points fed to each PointNet (a fixed-seed subsample).
    out_scale : float
        Largest offset per coordinate, metres (tanh output scale).
    steps : int
        Training steps (one triplet per step).
    lr : float
        Adam learning rate.
    w_length, w_corres, w_bend, w_penetration : float
        Self-supervised loss weights (0 disables a term: the loss ablation).
    use_joint_mask : bool
        Joint masks in the edge-length loss.
    margin : float
        Penetration margin, metres.
    joint_mask_radius : float
        Radius of the joint masks, metres.
    seed : int
        Network initialisation, sample order and point subsampling.
    """

    dim: int = 128
    k_extrapolate: int = 32
    k_place: int = 32
    embedding_method: str = "auto"
    n_landmarks: int = 2000
    correspondence_noise: float = 0.0
    carry_offset: bool = False
    precompute: bool = True
    k_neighbors: int = 32
    width: int = 512
    depth: int = 6
    code_dim: int = 128
    pointnet_hidden: int = 128
    n_points: int = 2048
    out_scale: float = 0.15
    steps: int = 300
    lr: float = 3e-4
    w_length: float = 1.0
    w_corres: float = 1.0
    w_bend: float = 0.01
    w_penetration: float = 1.0
    use_joint_mask: bool = True
    margin: float = 0.003
    joint_mask_radius: float = 0.08
    seed: int = 0


@dataclass(frozen=True)
class SupConfig(RefineConfig):
    """Hyperparameters of ``isomap-refine-sup``: :class:`RefineConfig` (whose self-supervised
    loss weights are unused) and the supervised losses.

    Attributes
    ----------
    w_l1, w_normal, w_laplace : float
        Weights of the L1, normal and Laplacian losses (thesis: unstated; ours 1 / 0.01 / 1,
        chosen once for comparable magnitudes).
    flat_threshold : float
        ``1 - cos`` of neighbouring ground-truth normals under which the normal loss is masked.
    """

    w_l1: float = 1.0
    w_normal: float = 0.01
    w_laplace: float = 1.0
    flat_threshold: float = 0.01


#: ``thesis``: the thesis' decoder 6 x 512 with 128-d PointNet codes and 32 target neighbours.
#: ``medium``: decoder 6 x 256, 64-d codes, PointNet hidden width 64 (about 4x fewer operations
#: per vertex; ``isomap-refine-sup``'s shipped size). ``fast``: decoder 6 x 128, 64-d codes,
#: hidden 64 and 16 target neighbours (about 14x fewer; sized for a new target of a
#: 30k-vertex garment in about 0.1 s on two cores).
PRESETS: dict[str, RefineConfig] = {
    "thesis": RefineConfig(),
    "medium": RefineConfig(width=256, code_dim=64, pointnet_hidden=64),
    "fast": RefineConfig(width=128, code_dim=64, pointnet_hidden=64, k_neighbors=16),
}
SUP_PRESETS: dict[str, SupConfig] = {"thesis": SupConfig()}


def get_config(preset: str | RefineConfig = "thesis", presets: dict[str, Any] | None = None,
               **overrides: Any) -> RefineConfig:
    """The configuration of preset ``preset`` (or the configuration given) with ``overrides``.

    Raises
    ------
    InputError
        Unknown preset or setting, or a value of the wrong type.
    """
    return resolve_config(presets or PRESETS, preset, overrides, what="refine config")
