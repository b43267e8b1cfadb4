"""Fusion task: one item per sample with a scan; the submission holds the reconstructed
mesh ``<sample_id>.ply`` / ``.obj`` (any topology) or ``.npz`` with ``vertices`` and ``faces``.
The ground truth is the sample's ``scan.ply``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.tasks.base import Item
from dressmeup.bench.tasks.common import array_problems, check_pin, faces_problems, load_npz_arrays
from dressmeup.bench.tasks.sampletask import sample_items
from dressmeup.errors import InputError
from dressmeup.io.mesh import load_mesh

FILE_SUFFIXES = (".ply", ".obj", ".npz")


def dataset_problems(edition: Any, data_root: Path):
    """Check the dataset against the edition pin."""
    return check_pin(edition, data_root)


def items(edition: Any, data_root: Path) -> list[Item]:
    """One item per sample of the split that has a scan."""
    return sample_items(edition, data_root, need="scan_path")


def read_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A predicted mesh ``(V (n, 3) float64, F (m, 3) int64)`` from .ply/.obj/.npz."""
    if path.suffix.lower() == ".npz":
        a = load_npz_arrays(path, ("vertices", "faces"))
        if "vertices" not in a or "faces" not in a:
            raise InputError(f"{path.name}: needs 'vertices' and 'faces' arrays")
        return a["vertices"], a["faces"]

    m = load_mesh(path)
    return m.vertices, m.faces


def check_file(path: Path, item: Item, edition: Any) -> list[str]:
    """Problems of one reconstructed mesh file."""
    try:
        V, F = read_mesh(path)
    except (InputError, OSError, ValueError) as exc:
        return [f"unreadable: {exc}"]
    problems = array_problems("vertices", V, 3)
    if not problems:
        problems += faces_problems("faces", F, V.shape[0])
        if F.ndim == 2 and len(F) == 0:
            problems.append("the mesh has no faces")
    return problems
