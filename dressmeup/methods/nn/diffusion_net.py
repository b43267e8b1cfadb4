"""DiffusionNet (Sharp et al., 2022) in plain torch, with cached differential operators.

A DiffusionNet maps per-vertex features to per-vertex features through blocks of

1. learned-time heat diffusion, done in a truncated Laplace-Beltrami eigenbasis
   ``x_diffused = Phi (exp(-lambda t) * (Phi^T M x))`` with one learned time ``t >= 0`` per
   channel (spectral acceleration);
2. spatial gradient features: the tangent gradients of the diffused channels, combined by a
   learned complex-linear map and reduced with an inner product, so that they do not depend
   on the choice of tangent frames;
3. a per-vertex MLP on ``[x, x_diffused, gradient features]`` added residually to ``x``.

The geometric side (the lumped mass, the cotangent-Laplacian eigenbasis and the two sparse
gradient matrices, computed once per mesh and cached) lives in
:mod:`dressmeup.methods.nn.diffusion_ops`, as the published implementation keeps its
geometry apart from its layers; its names are importable from here too.
"""

from __future__ import annotations

__all__ = ["DiffusionNet"]


def _torch_modules():
    # heavy: torch (~1.1 s to import)
    import torch
    from torch import nn

    class LearnedTimeDiffusion(nn.Module):
        """Heat diffusion of each channel for its own learned time, in the spectral basis."""

        def __init__(self, channels: int):
            super().__init__()
            self.diffusion_time = nn.Parameter(torch.zeros(channels))

        def forward(self, x, ops):
            # keep t >= 1e-8 by clamping the parameter's *data*, outside the autograd graph
            # (as the DiffusionNet authors do): a clamp inside the graph has a zero gradient
            # at the bound, so times initialised at 0 would never move
            with torch.no_grad():
                self.diffusion_time.data.clamp_(min=1e-8)
            t = self.diffusion_time
            evecs, evals, mass = ops["evecs"], ops["evals"], ops["mass"]
            spec = evecs.transpose(0, 1) @ (mass[:, None] * x)
            coefs = torch.exp(-evals[:, None] * t[None, :])
            return evecs @ (coefs * spec)

    class SpatialGradientFeatures(nn.Module):
        """Rotation-invariant features from tangent gradients: tanh(<g, A g>)."""

        def __init__(self, channels: int):
            super().__init__()
            self.A_re = nn.Linear(channels, channels, bias=False)
            self.A_im = nn.Linear(channels, channels, bias=False)

        def forward(self, gx, gy):
            b_re = self.A_re(gx) - self.A_im(gy)
            b_im = self.A_re(gy) + self.A_im(gx)
            return torch.tanh(gx * b_re + gy * b_im)

    class DiffusionNetBlock(nn.Module):
        def __init__(self, width: int, gradient_features: bool = True):
            super().__init__()
            self.diffusion = LearnedTimeDiffusion(width)
            self.gradient_features = gradient_features
            n_in = 2 * width
            if gradient_features:
                self.grad = SpatialGradientFeatures(width)
                n_in += width
            self.mlp = nn.Sequential(nn.Linear(n_in, width), nn.ReLU(), nn.Linear(width, width))

        def forward(self, x, ops):
            xd = self.diffusion(x, ops)
            feats = [x, xd]
            if self.gradient_features:
                gx = torch.sparse.mm(ops["grad_x"], xd)
                gy = torch.sparse.mm(ops["grad_y"], xd)
                feats.append(self.grad(gx, gy))
            return x + self.mlp(torch.cat(feats, dim=-1))

    class DiffusionNetModule(nn.Module):
        def __init__(self, c_in, c_out, width, n_blocks, gradient_features, last_activation):
            super().__init__()
            self.first = nn.Linear(c_in, width)
            self.blocks = nn.ModuleList(DiffusionNetBlock(width, gradient_features) for _ in range(n_blocks))
            self.last = nn.Linear(width, c_out)
            self.last_activation = last_activation

        def features(self, x, ops):
            h = self.first(x)
            for blk in self.blocks:
                h = blk(h, ops)
            return h

        def forward(self, x, ops):
            out = self.last(self.features(x, ops))
            if self.last_activation == "softmax":
                out = torch.softmax(out, dim=-1)
            elif self.last_activation == "log_softmax":
                out = torch.log_softmax(out, dim=-1)
            return out

    return DiffusionNetModule


def DiffusionNet(c_in: int, c_out: int, width: int = 128, n_blocks: int = 4,
                 gradient_features: bool = True, last_activation: str | None = None,
                 seed: int | None = 0):
    """Build a DiffusionNet ``torch.nn.Module``.

    Parameters
    ----------
    c_in, c_out : int
        Input and output channels per vertex.
    width : int
        Hidden channels (128 in the thesis).
    n_blocks : int
        Diffusion blocks (4 in the thesis).
    gradient_features : bool
        Use spatial gradient features.
    last_activation : {None, "softmax", "log_softmax"}
    seed : int or None
        Seed for the weight initialisation (``None``: torch's global generator).

    Returns
    -------
    torch.nn.Module
        ``module(x (n, c_in) tensor, ops: dict from Operators.to_torch()) -> (n, c_out)``;
        ``module.features(x, ops) -> (n, width)`` gives the last hidden features.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    if last_activation not in (None, "softmax", "log_softmax"):
        raise ValueError(f"last_activation: expected None, 'softmax' or 'log_softmax', got {last_activation!r}")
    cls = _torch_modules()
    if seed is None:
        return cls(c_in, c_out, width, n_blocks, gradient_features, last_activation)
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        return cls(c_in, c_out, width, n_blocks, gradient_features, last_activation)
