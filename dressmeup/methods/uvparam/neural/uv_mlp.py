"""The forward (3D -> UV) and backward (UV -> 3D) MLPs of the surface-parameterisation module.

Both are plain MLPs with LeakyReLU between layers and tanh at the output (thesis 3.4.1).
The forward MLP takes ``[x, y, z, psi]`` (normalised position and the patch's 128-d
DiffusionNet code) and gives ``(u, v)``; the backward MLP takes ``[u, v, psi]`` and gives
``(x, y, z)``. One pair of MLPs serves all patches of an object: the code ``psi`` tells the
patches apart (and, for per-category training, the objects).
"""

from __future__ import annotations

__all__ = ["build_mlp", "count_parameters"]


def build_mlp(n_in: int, n_out: int, width: int, depth: int, out_scale: float = 1.0, seed: int = 0):
    """An MLP of ``depth`` linear layers, LeakyReLU between them, ``out_scale * tanh`` at the end.

    Parameters
    ----------
    n_in, n_out : int
    width : int
        Hidden width.
    depth : int
        Number of linear layers (8 in the thesis), at least 2.
    out_scale : float
        Range of the output (tanh times this).
    seed : int

    Returns
    -------
    torch.nn.Module mapping (N, n_in) to (N, n_out).
    """
    # heavy: torch (~1.1 s to import)
    import torch
    from torch import nn

    if depth < 2:
        raise ValueError(f"depth: expected at least 2 layers, got {depth}")

    class ScaledTanh(nn.Module):
        def forward(self, x):
            return out_scale * torch.tanh(x)

    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        layers = [nn.Linear(n_in, width), nn.LeakyReLU(0.01)]
        for _ in range(depth - 2):
            layers += [nn.Linear(width, width), nn.LeakyReLU(0.01)]
        layers += [nn.Linear(width, n_out), ScaledTanh()]
        return nn.Sequential(*layers)


def count_parameters(module) -> int:
    """Number of trainable parameters of a torch module."""
    return int(sum(p.numel() for p in module.parameters() if p.requires_grad))
