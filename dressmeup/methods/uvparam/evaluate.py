"""Scoring one UV map with the standard metrics, and small table helpers for the benchmarks."""

from __future__ import annotations

import numpy as np

from dressmeup.methods.uvparam.base import UVResult
from dressmeup.metrics import ase_details, qce_details, uv_validity
from dressmeup.metrics.uv import uv_seams

__all__ = ["score_uv", "markdown_table"]


def score_uv(V: np.ndarray, F: np.ndarray, result: UVResult, overlap_resolution: int = 1024) -> dict:
    """QCE (mean, max), ASE (|mean|, signed mean), flip and overlap fractions, charts, seconds.

    Parameters
    ----------
    V : (n, 3) float array
    F : (m, 3) int array
    result : UVResult
    overlap_resolution : int

    Returns
    -------
    dict of floats (``qce``, ``qce_max``, ``ase``, ``ase_signed``, ``flipped``, ``overlap``,
    ``n_charts`` (the method's), ``seam_length``, ``charts`` (measured on the mesh's edges),
    ``packing``, ``seconds``).
    """

    q = qce_details(V, F, result.uv, result.uv_faces)
    a = ase_details(V, F, result.uv, result.uv_faces)
    v = uv_validity(V, F, result.uv, result.uv_faces, resolution=overlap_resolution)
    s = uv_seams(V, F, result.uv, result.uv_faces)
    return {"qce": float(q.mean), "qce_max": float(q.max), "ase": float(a.abs_mean),
            "ase_signed": float(a.mean), "flipped": float(v.flipped_fraction),
            "overlap": float(v.overlap_fraction), "n_charts": result.n_charts,
            "seam_length": s.seam_length, "charts": s.n_charts, "packing": s.packing_efficiency,
            "seconds": float(result.seconds)}


def markdown_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """A Markdown table.

    Parameters
    ----------
    rows : list of dict
    columns : list of (key, header, format) e.g. ``("qce", "QCE ↓", "{:.3f}")``

    Returns
    -------
    str
    """
    head = "| " + " | ".join(h for _, h, _ in columns) + " |"
    sep = "|" + "|".join("---" for _ in columns) + "|"
    lines = [head, sep]
    for r in rows:
        cells = []
        for key, _, fmt in columns:
            val = r.get(key, "")
            try:
                cells.append(fmt.format(val) if val != "" and val is not None else "")
            except (ValueError, TypeError):
                cells.append(str(val))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
