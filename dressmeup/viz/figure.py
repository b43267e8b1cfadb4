"""Writing matplotlib figures: one place for the atomic PNG write every picture uses."""

from __future__ import annotations

import os
from pathlib import Path

from dressmeup.io.atomic import atomic_path


def save_png(fig, path: str | os.PathLike, dpi: int = 110, tight: bool = False) -> Path:
    """Write ``fig`` to ``path`` as a PNG atomically (parent folders created), then close it.

    Parameters
    ----------
    fig : matplotlib figure.
    path : output file.
    dpi : resolution.
    tight : crop to the drawn content (``bbox_inches="tight"``).
    """
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    kw = {"bbox_inches": "tight"} if tight else {}
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", **kw)
    plt.close(fig)
    return path
