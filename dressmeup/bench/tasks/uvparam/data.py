"""UV parameterisation task: the items of a mesh set (:mod:`dressmeup.data.uvmeshes`) and
the submission files.

A submission holds ``<mesh_id>.npz`` with ``uv (k, 2)`` float and ``uv_faces (m, 3)`` int
(per-corner UVs, ``m`` = the mesh's face count), or ``uv (n, 2)`` alone (per vertex); optional
``chart_ids (m,)`` and ``seconds`` (the method's wall time on that mesh).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.tasks.base import Item
from dressmeup.bench.tasks.common import (
    array_problems,
    check_pin,
    faces_problems,
    load_npz_arrays,
)
from dressmeup.data.uvmeshes import meshes
from dressmeup.errors import InputError

FILE_SUFFIXES = (".npz",)
def dataset_problems(edition: Any, data_root: Path) -> tuple[dict[str, Any], list[str]]:
    """Check the mesh set against the edition pin (see :func:`check_pin`)."""
    info, problems = check_pin(edition, data_root)
    if problems and not (Path(data_root) / "manifest.parquet").is_file():
        problems.append(f"build the mesh set with: dressmeup synth {data_root} --edition "
                        f"{edition.name} (or 'dressmeup demo')")
    return info, problems


def items(edition: Any, data_root: Path) -> list[Item]:
    """One item per mesh of the edition's split (v1 mesh sets hold only ``test`` meshes)."""
    return [Item(m.mesh_id, m.category,
                 expect={"n_vertices": m.n_vertices, "n_faces": m.n_faces},
                 meta={"mesh_path": str(m.path)})
            for m in meshes(data_root, getattr(edition, "split", None) or None)]


def read_prediction(path: Path) -> dict[str, np.ndarray]:
    """Arrays of a UV prediction file (``uv`` required; ``uv_faces``, ``chart_ids``,
    ``seconds`` optional)."""
    arrays = load_npz_arrays(path, ("uv", "uv_faces", "chart_ids", "seconds"))
    if "uv" not in arrays:
        raise InputError(f"{path.name}: no 'uv' array")
    return arrays


def check_file(path: Path, item: Item, edition: Any) -> list[str]:
    """Problems of one UV prediction file."""
    try:
        a = read_prediction(path)
    except (InputError, OSError, ValueError) as exc:
        return [f"unreadable: {exc}"]
    uv = a["uv"]
    nv, nf = item.expect["n_vertices"], item.expect["n_faces"]
    if "uv_faces" in a:
        problems = array_problems("uv", uv, 2)
        uvf = a["uv_faces"]
        if uvf.ndim != 2 or uvf.shape[1] != 3 or uvf.shape[0] != nf:
            problems.append(f"'uv_faces' has shape {uvf.shape}, expected ({nf}, 3) "
                            "(one row per mesh face)")
        elif uv.ndim == 2:
            problems += faces_problems("uv_faces", uvf, uv.shape[0])
    else:
        problems = array_problems("uv", uv, 2, nv)
    if "chart_ids" in a and a["chart_ids"].shape != (nf,):
        problems.append(f"'chart_ids' has shape {a['chart_ids'].shape}, expected ({nf},)")
    if "seconds" in a:
        s = a["seconds"]
        if s.size != 1 or not np.isfinite(s).all() or float(s.reshape(-1)[0]) < 0:
            problems.append(f"'seconds' must be one number >= 0, got {s!r}")
    return problems
