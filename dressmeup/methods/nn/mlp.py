"""Per-point MLP decoders conditioned on global codes (AdaIN / FiLM style).

:class:`ConditionedMLP` is the decoder of the Dress Me Up refinement module (thesis 4.4.2):
hidden layers of equal width with LeakyReLU, every hidden layer modulated by the global
code like AdaIN (a per-channel scale and bias predicted from the code, applied to the
layer's normalised features), and a tanh output.
"""

from __future__ import annotations

import torch
from torch import nn

__all__ = ["ConditionedMLP"]


class ConditionedMLP(nn.Module):
    """Per-point MLP with AdaIN-style conditioning of every hidden layer.

    For hidden layer ``l``: ``h = LeakyReLU((1 + gamma_l(c)) * LN(W_l h) + beta_l(c))``, where
    ``LN`` is a parameter-free layer normalisation over the channels of each point (the
    "instance" normalisation that AdaIN re-styles), and ``gamma_l, beta_l`` are linear maps of
    the code ``c``, initialised at zero so that training starts from the unconditioned MLP.

    Parameters
    ----------
    in_dim : int
        Per-point input features.
    out_dim : int
        Per-point outputs.
    code_dim : int
        Global code size (0 disables conditioning).
    width : int
        Hidden width (thesis: 512).
    depth : int
        Number of hidden layers (thesis: 6).
    out_scale : float
        The output is ``out_scale * tanh(.)``.
    negative_slope : float
        LeakyReLU slope.
    """

    def __init__(self, in_dim: int, out_dim: int = 3, code_dim: int = 256, width: int = 512,
                 depth: int = 6, out_scale: float = 1.0, negative_slope: float = 0.01) -> None:
        super().__init__()
        if depth < 1 or width < 1:
            raise ValueError(f"depth/width: expected positive values, got depth={depth}, width={width}")
        self.layers = nn.ModuleList()
        d = in_dim + code_dim
        for _ in range(depth):
            self.layers.append(nn.Linear(d, width))
            d = width
        self.code_dim = code_dim
        if code_dim > 0:
            self.film = nn.Linear(code_dim, 2 * width * depth)
            nn.init.zeros_(self.film.weight)
            nn.init.zeros_(self.film.bias)
        self.out = nn.Linear(width, out_dim)
        nn.init.uniform_(self.out.weight, -1e-3, 1e-3)
        nn.init.zeros_(self.out.bias)
        self.act = nn.LeakyReLU(negative_slope)
        self.width = width
        self.out_scale = float(out_scale)

    def forward(self, x: torch.Tensor, code: torch.Tensor | None = None) -> torch.Tensor:
        """Decode.

        Parameters
        ----------
        x : (n, in_dim) float tensor, per-point features.
        code : (code_dim,) float tensor, the global code (required when ``code_dim > 0``);
            it is also appended to every point's input (thesis: "fed as input" and "condition
            every layer").

        Returns
        -------
        (n, out_dim) float tensor in ``[-out_scale, out_scale]``.
        """
        if self.code_dim > 0:
            if code is None or code.shape[-1] != self.code_dim:
                raise ValueError(f"code: expected shape ({self.code_dim},), got "
                                 f"{None if code is None else tuple(code.shape)}")
            code = code.reshape(-1)
            h = torch.cat([x, code[None].expand(x.shape[0], -1)], dim=1)
            mod = self.film(code).view(len(self.layers), 2, self.width)
        else:
            h = x
            mod = None
        for i, layer in enumerate(self.layers):
            h = layer(h)
            if mod is not None:
                h = nn.functional.layer_norm(h, (self.width,))
                h = (1.0 + mod[i, 0]) * h + mod[i, 1]
            h = self.act(h)
        return self.out_scale * torch.tanh(self.out(h))
