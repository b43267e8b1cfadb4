"""The refinement network of ``isomap-refine`` (thesis 4.3.2): two ResnetPointNet encoders
(garment, target body) and a per-vertex decoder conditioned on their codes."""

from __future__ import annotations

import torch
from torch import nn

from dressmeup.methods.nn.mlp import ConditionedMLP
from dressmeup.methods.nn.pointnet import ResnetPointNet


class RefineNet(nn.Module):
    """Offsets ``(n, 3)`` of the garment vertices from their features ``(n, in_dim)``, the
    garment's points ``(p, 3)`` and the target body's points ``(p, 3)`` (one code each)."""

    def __init__(self, in_dim: int, code_dim: int, width: int, depth: int, pointnet_hidden: int,
                 out_scale: float) -> None:
        super().__init__()
        self.encoder_garment = ResnetPointNet(c_dim=code_dim, hidden=pointnet_hidden)
        self.encoder_body = ResnetPointNet(c_dim=code_dim, hidden=pointnet_hidden)
        self.decoder = ConditionedMLP(in_dim, 3, code_dim=2 * code_dim, width=width, depth=depth,
                                      out_scale=out_scale)

    def forward(self, features: torch.Tensor, garment_points: torch.Tensor,
                body_points: torch.Tensor) -> torch.Tensor:
        code = torch.cat([self.encoder_garment(garment_points), self.encoder_body(body_points)])
        return self.decoder(features, code)


def build_network(in_dim: int, code_dim: int, width: int, depth: int, pointnet_hidden: int,
                  out_scale: float) -> RefineNet:
    """A freshly initialised :class:`RefineNet` (seed torch first for a reproducible one)."""
    return RefineNet(in_dim, code_dim, width, depth, pointnet_hidden, out_scale)


#: rows of the garment decoded at a time by :func:`decode_with_partial`: a 2048 x 512 float32
#: activation (4 MB) stays in cache between the layers' GEMM, normalisation and activation,
#: where a whole 29k-vertex garment's (60 MB) would stream through memory several times a
#: layer (timings: docs/baselines.md)
DECODE_ROWS = 2048


def decode_with_partial(decoder, x, neighbors, phi_term, code):
    """:class:`~dressmeup.methods.nn.mlp.ConditionedMLP` forward with the first layer split by input.

    The first layer's input is ``[x (3), phi (d), neighbours (3k), code]``; ``phi_term`` is
    ``phi @ W_phi^T`` (per garment, precomputed) and the code's share is one vector per target,
    so only ``x`` and the neighbours are multiplied per vertex. Rows are decoded in blocks of
    :data:`DECODE_ROWS` (each row's result does not depend on the others), and each layer's
    FiLM modulation is the affine part of its layer normalisation. Same result as
    ``decoder(cat([x, phi, neighbours]), code)`` up to float round-off (tested).

    Parameters
    ----------
    x : (n, 3), neighbors : (n, 3k), phi_term : (n, width) float32 tensors; code : (c,).

    Returns
    -------
    (n, 3) float32 tensor: the offsets.
    """
    first = decoder.layers[0]
    W, b = first.weight, first.bias
    nk = neighbors.shape[1]
    d = W.shape[1] - 3 - nk - decoder.code_dim
    W_x, W_nb = W[:, :3].T, W[:, 3 + d:3 + d + nk].T
    shared = W[:, 3 + d + nk:] @ code + b
    mod = decoder.film(code).view(len(decoder.layers), 2, decoder.width)
    scale, shift = 1.0 + mod[:, 0], mod[:, 1]
    out = []
    for s in range(0, len(x), DECODE_ROWS):
        rows = slice(s, s + DECODE_ROWS)
        h = x[rows] @ W_x + neighbors[rows] @ W_nb + phi_term[rows] + shared
        for i in range(len(decoder.layers)):
            if i > 0:
                h = decoder.layers[i](h)
            h = decoder.act(nn.functional.layer_norm(h, (decoder.width,), scale[i], shift[i]))
        out.append(decoder.out_scale * torch.tanh(decoder.out(h)))
    return torch.cat(out)
