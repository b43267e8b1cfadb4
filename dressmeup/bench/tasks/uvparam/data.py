"""UV parameterisation task: the mesh set, its items and the submission files.

The meshes of a ``uvparam`` edition are generated from code by id
(:func:`dressmeup.methods.uvparam.shapes.make_test_mesh`, e.g. ``sphere-2k``, ``torus-30k``,
``body-native``); :func:`build_mesh_set` writes them once into a folder that ``--data``
points at::

    ROOT/
      dataset.json        generator record (name, version, params.mesh_ids, seed)
      manifest.parquet    mesh_id, category (the shape), split, path, vertex/face counts, sha256
      meshes/<mesh_id>.ply

A submission holds ``<mesh_id>.npz`` with ``uv (k, 2)`` float and ``uv_faces (m, 3)`` int
(per-corner UVs, ``m`` = the mesh's face count), or ``uv (n, 2)`` alone (per vertex); optional
``chart_ids (m,)`` and ``seconds`` (the method's wall time on that mesh).
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
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
from dressmeup.errors import InputError

FILE_SUFFIXES = (".npz",)
GENERATOR = "dressmeup-uvparam-shapes"
#: generator version of mesh sets with garments (``params.garments``) beside the shapes
MESHSET_V2 = "uvparam-meshes-v2"


@dataclass(frozen=True)
class UVMesh:
    """One mesh of a UV benchmark mesh set.

    Attributes
    ----------
    mesh_id : id, e.g. ``torus-30k`` (also the submission file stem).
    category : the shape (``sphere``, ``torus``, ``blob``, ``sheet``, ``skirt``, ``body``).
    path : the mesh file (PLY).
    n_vertices, n_faces : counts.
    """

    mesh_id: str
    category: str
    path: Path
    n_vertices: int
    n_faces: int


def build_mesh_set(root: str | os.PathLike, mesh_ids: Sequence[str] | None = None,
                   edition: Any = None) -> Path:
    """Generate the meshes of a ``uvparam`` edition into ``root`` (skips existing ones).

    Parameters
    ----------
    root : output folder.
    mesh_ids : ids to build (default: the edition's ``params.mesh_ids``).
    edition : an edition (name/path/object) whose pin gives the mesh ids.

    Returns
    -------
    ``root``.
    """
    import pandas as pd

    from dressmeup.bench.edition import file_sha256, load_edition
    from dressmeup.io.atomic import atomic_path, atomic_write_text
    from dressmeup.io.mesh import save_mesh
    from dressmeup.methods.uvparam.shapes import SHAPES_VERSION, make_test_mesh, parse_mesh_id
    from dressmeup.progress import progress

    seed = 0
    garments = None
    if edition is not None:
        ed = load_edition(edition)
        mesh_ids = list(ed.dataset.params["mesh_ids"])
        seed = ed.dataset.seed
        garments = ed.dataset.params.get("garments")
    if not mesh_ids and not garments:
        raise InputError("build_mesh_set: give mesh_ids or an edition")
    root = Path(root)
    (root / "meshes").mkdir(parents=True, exist_ok=True)
    rows = []
    for mesh_id in progress(list(mesh_ids), desc="building UV test meshes"):
        shape, _ = parse_mesh_id(mesh_id)
        path = root / "meshes" / f"{mesh_id}.ply"
        if not path.is_file():
            V, F = make_test_mesh(mesh_id)
            save_mesh(path, V, F)
        from dressmeup.io.mesh import load_mesh

        m = load_mesh(path)
        rows.append({"mesh_id": mesh_id, "category": "shapes" if garments else shape,
                     "split": "test", "path": f"meshes/{mesh_id}.ply",
                     "n_vertices": len(m.vertices), "n_faces": len(m.faces),
                     "sha256": file_sha256(path), "group": "shapes", "kind": shape})
    params: dict[str, Any] = {"mesh_ids": list(mesh_ids)}
    version = SHAPES_VERSION
    if garments:
        rows += _garment_rows(root, dict(garments))
        params["garments"] = dict(garments)
        version = MESHSET_V2
    else:
        rows = [{k: v for k, v in r.items() if k not in ("group", "kind")} for r in rows]
    info = {"name": "uvparam-meshes", "format": "dressmeup-meshset", "units": "m",
            "generator": {"name": GENERATOR, "version": version, "params": params,
                          "seed": seed}}
    with atomic_path(root / "manifest.parquet") as tmp:
        pd.DataFrame(rows).to_parquet(tmp, index=False)
    atomic_write_text(root / "dataset.json", json.dumps(info, indent=2) + "\n")
    return root


def _garment_rows(root: Path, garments: dict[str, Any]) -> list[dict[str, Any]]:
    """Generate the garments (one draped pose each) with the synthetic generator into
    ``root/source`` and copy each garment's mesh to ``meshes/<garment_type>-<garment_id>.ply``.

    The split (train/val/test by garment, stratified by category) is the generator's.
    """
    import pandas as pd

    from dressmeup.bench.edition import file_sha256
    from dressmeup.data.synth import generate_dataset
    from dressmeup.data.synth.generate import GENERATOR_VERSION
    from dressmeup.io.mesh import load_mesh, save_mesh

    want = garments.pop("generator_version", None)
    if want is not None and want != GENERATOR_VERSION:
        raise InputError(f"this edition's garments come from synthetic generator {want}; this "
                         f"toolkit has {GENERATOR_VERSION}: use the toolkit version the "
                         "edition was made with")
    src = generate_dataset(root / "source", **garments)
    man = pd.read_parquet(src / "manifest.parquet").sort_values("sample_id")
    rows = []
    for r in man.drop_duplicates("garment_id").itertuples():
        mesh_id = f"{r.garment_type}-{r.garment_id}"
        path = root / "meshes" / f"{mesh_id}.ply"
        if not path.is_file():  # geometry only: the generator's own UVs and texture stay out
            g = load_mesh(src / r.garment_path)
            save_mesh(path, g.vertices, g.faces)
        m = load_mesh(path)
        rows.append({"mesh_id": mesh_id, "category": r.category, "split": r.split,
                     "path": f"meshes/{mesh_id}.ply", "n_vertices": len(m.vertices),
                     "n_faces": len(m.faces), "sha256": file_sha256(path),
                     "group": "garments", "kind": r.garment_type})
    return rows


def dataset_problems(edition: Any, data_root: Path) -> tuple[dict[str, Any], list[str]]:
    """Check the mesh set against the edition pin (see :func:`check_pin`)."""
    info, problems = check_pin(edition, data_root)
    if problems and not (Path(data_root) / "manifest.parquet").is_file():
        problems.append(f"build the mesh set with: python -c \"from dressmeup.bench.tasks."
                        f"uvparam.data import build_mesh_set; build_mesh_set('{data_root}', "
                        f"edition='{edition.name}')\" (or 'dressmeup demo')")
    return info, problems


def meshes(data_root: str | os.PathLike, split: str | None = None) -> list[UVMesh]:
    """The meshes of a mesh set folder, sorted by id (paths checked to stay inside ROOT).

    ``split`` keeps only that split's meshes (``train``/``val``/``test``)."""
    import pandas as pd

    from dressmeup.data.layout import resolve_inside

    root = Path(data_root)
    df = pd.read_parquet(root / "manifest.parquet")
    if split is not None:
        df = df[df["split"] == split]
    out = [UVMesh(r.mesh_id, r.category, resolve_inside(root, r.path, "path"),
                  int(r.n_vertices), int(r.n_faces)) for r in df.itertuples()]
    return sorted(out, key=lambda m: m.mesh_id)


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
