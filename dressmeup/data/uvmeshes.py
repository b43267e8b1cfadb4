"""UV benchmark mesh sets: analytic test meshes and synthetic garments in one folder.

The meshes of a ``uvparam`` edition are generated from code by id
(:func:`dressmeup.data.shapes.make_test_mesh`, e.g. ``sphere-2k``, ``torus-30k``,
``body-native``) and, in version 2 mesh sets, garments of the synthetic generator;
:func:`build_mesh_set` writes them once into a folder that ``--data`` points at::

    ROOT/
      dataset.json        generator record (name, version, params.mesh_ids, seed)
      manifest.parquet    mesh_id, category (the shape), split, path, vertex/face counts, sha256
      meshes/<mesh_id>.ply
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from dressmeup.data.layout import resolve_inside
from dressmeup.data.shapes import SHAPES_VERSION, make_test_mesh, parse_mesh_id
from dressmeup.data.synth import generate_dataset
from dressmeup.data.synth.generate import GENERATOR_VERSION
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_path, atomic_write_text
from dressmeup.io.hashing import sha256_file
from dressmeup.io.mesh import load_mesh, save_mesh
from dressmeup.progress import progress

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


def build_mesh_set(root: str | os.PathLike, mesh_ids: Sequence[str] = (),
                   garments: dict[str, Any] | None = None, seed: int = 0) -> Path:
    """Generate a UV mesh set into ``root`` (skips meshes already there).

    Parameters
    ----------
    root : output folder.
    mesh_ids : ids of :func:`dressmeup.data.shapes.make_test_mesh` to build.
    garments : parameters of :func:`dressmeup.data.synth.generate_dataset` whose garments join
        the set (one draped pose each; the mesh set is then of version ``MESHSET_V2``).
    seed : recorded in ``dataset.json`` (the generator parameters carry their own seed).

    Returns
    -------
    ``root``.
    """
    garments = dict(garments) if garments else None
    if not mesh_ids and not garments:
        raise InputError("build_mesh_set: give mesh_ids or garments")
    root = Path(root)
    (root / "meshes").mkdir(parents=True, exist_ok=True)
    rows = []
    for mesh_id in progress(list(mesh_ids), desc="building UV test meshes"):
        shape, _ = parse_mesh_id(mesh_id)
        path = root / "meshes" / f"{mesh_id}.ply"
        if not path.is_file():
            V, F = make_test_mesh(mesh_id)
            save_mesh(path, V, F)
        m = load_mesh(path)
        rows.append({"mesh_id": mesh_id, "category": "shapes" if garments else shape,
                     "split": "test", "path": f"meshes/{mesh_id}.ply",
                     "n_vertices": len(m.vertices), "n_faces": len(m.faces),
                     "sha256": sha256_file(path), "group": "shapes", "kind": shape})
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
                     "n_faces": len(m.faces), "sha256": sha256_file(path),
                     "group": "garments", "kind": r.garment_type})
    return rows


def meshes(data_root: str | os.PathLike, split: str | None = None) -> list[UVMesh]:
    """The meshes of a mesh set folder, sorted by id (paths checked to stay inside ROOT).

    ``split`` keeps only that split's meshes (``train``/``val``/``test``)."""
    root = Path(data_root)
    df = pd.read_parquet(root / "manifest.parquet")
    if split is not None:
        df = df[df["split"] == split]
    out = [UVMesh(r.mesh_id, r.category, resolve_inside(root, r.path, "path"),
                  int(r.n_vertices), int(r.n_faces)) for r in df.itertuples()]
    return sorted(out, key=lambda m: m.mesh_id)
