"""Correspondence task: one item per garment sample of the split; the submission holds a
per-vertex embedding ``<sample_id>.npz`` with ``embedding (n, d)`` float (n = the garment's
vertex count)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dressmeup.bench.tasks.base import Item
from dressmeup.bench.tasks.common import array_problems, check_pin, load_npz_arrays
from dressmeup.bench.tasks.sampletask import sample_items
from dressmeup.errors import InputError

FILE_SUFFIXES = (".npz",)


def dataset_problems(edition: Any, data_root: Path):
    """Check the dataset against the edition pin."""
    return check_pin(edition, data_root)


def items(edition: Any, data_root: Path) -> list[Item]:
    """One item per garment sample of the split."""
    return sample_items(edition, data_root,
                        expect=lambda row: {"n_vertices": int(row.garment_vertices)})


def check_file(path: Path, item: Item, edition: Any) -> list[str]:
    """Problems of one embedding file."""
    try:
        a = load_npz_arrays(path, ("embedding",))
    except (InputError, OSError, ValueError) as exc:
        return [f"unreadable: {exc}"]
    if "embedding" not in a:
        return ["unreadable: no 'embedding' array"]
    E = a["embedding"]
    if E.ndim != 2:
        return [f"'embedding' has shape {E.shape}, expected (n, d)"]
    return array_problems("embedding", E, E.shape[1], item.expect["n_vertices"])
