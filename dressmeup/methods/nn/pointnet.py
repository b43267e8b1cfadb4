"""PointNet encoders: a global code for a point cloud.

:class:`ResnetPointNet` follows the shape described for the Dress Me Up refinement module
(thesis 4.4.2) and the Occupancy-Networks "ResnetPointnet": a linear lift of each point to
``2h`` features, five residual fully connected blocks (``2h -> h``) each followed by a max-pool
over the points whose result is concatenated back to every point, and a final max-pool and
linear map to a ``c``-dimensional code. Inputs are not normalised.
"""

from __future__ import annotations

import torch
from torch import nn

__all__ = ["ResnetBlockFC", "ResnetPointNet"]


class ResnetBlockFC(nn.Module):
    """Residual block of two linear layers with ReLU pre-activations.

    ``y = shortcut(x) + fc1(relu(fc0(relu(x))))``; the shortcut is linear (no bias) when the
    widths differ. The second layer starts at zero so that a fresh block is the identity
    (or its linear shortcut).

    Parameters
    ----------
    size_in, size_out : int
        Input and output widths.
    size_h : int, optional
        Hidden width (default ``min(size_in, size_out)``).
    """

    def __init__(self, size_in: int, size_out: int | None = None, size_h: int | None = None) -> None:
        super().__init__()
        size_out = size_in if size_out is None else size_out
        size_h = min(size_in, size_out) if size_h is None else size_h
        self.fc_0 = nn.Linear(size_in, size_h)
        self.fc_1 = nn.Linear(size_h, size_out)
        nn.init.zeros_(self.fc_1.weight)
        self.act = nn.ReLU()
        self.shortcut = None if size_in == size_out else nn.Linear(size_in, size_out, bias=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``x (..., size_in) -> (..., size_out)``."""
        dx = self.fc_1(self.act(self.fc_0(self.act(x))))
        xs = x if self.shortcut is None else self.shortcut(x)
        return xs + dx


class ResnetPointNet(nn.Module):
    """Global point-cloud encoder with five residual blocks and max-pool concatenation.

    Parameters
    ----------
    c_dim : int
        Code size (thesis: 128).
    dim : int
        Point dimension (3).
    hidden : int
        Hidden width ``h`` (demo: 128, so the lift is 3 -> 256).
    n_blocks : int
        Residual blocks (thesis: 5).
    """

    def __init__(self, c_dim: int = 128, dim: int = 3, hidden: int = 128, n_blocks: int = 5) -> None:
        super().__init__()
        if n_blocks < 1:
            raise ValueError(f"n_blocks: expected >= 1, got {n_blocks}")
        self.fc_pos = nn.Linear(dim, 2 * hidden)
        self.blocks = nn.ModuleList(
            [ResnetBlockFC(2 * hidden, hidden) for _ in range(n_blocks)])
        self.fc_c = nn.Linear(hidden, c_dim)
        self.act = nn.ReLU()

    def forward(self, points: torch.Tensor) -> torch.Tensor:
        """Encode point clouds.

        Parameters
        ----------
        points : (b, p, dim) or (p, dim) float tensor

        Returns
        -------
        (b, c_dim) or (c_dim,) float tensor.
        """
        squeeze = points.ndim == 2
        if squeeze:
            points = points[None]
        if points.ndim != 3:
            raise ValueError(f"points: expected shape (b, p, d) or (p, d), got {tuple(points.shape)}")
        net = self.blocks[0](self.fc_pos(points))
        for block in self.blocks[1:]:
            pooled = net.max(dim=1, keepdim=True).values.expand_as(net)
            net = block(torch.cat([net, pooled], dim=2))
        code = self.fc_c(self.act(net.max(dim=1).values))
        return code[0] if squeeze else code
