"""Editions of user-built data: :func:`create_edition` pins a dataset or mesh set by the
sha256 of its manifest (``kind: "real"``), after checking that the data are finished, intact
and hold items of the task.
"""

from __future__ import annotations

import os
from pathlib import Path

from dressmeup.bench.edition import SCHEMA, TASKS, Edition, edition_from_dict, list_editions
from dressmeup.bench.tasks import get_task
from dressmeup.bench.tasks.common import manifest_sha256
from dressmeup.data import layout
from dressmeup.data.integrity import verify_checksums, verify_listed_files
from dressmeup.data.uvmeshes import is_mesh_set
from dressmeup.errors import InputError
from dressmeup.io.jsonio import parse_json_file
from dressmeup.io.tables import read_frame


def _dataset_info(root: Path) -> dict:
    """``dataset.json`` of a finished build (a dict), or {} for a mesh set without one."""
    path = root / layout.DATASET_JSON
    if not path.is_file():
        if is_mesh_set(root):
            return {}
        raise InputError(f"{path} not found: --data must be a dataset root (dataset.json + "
                         "manifest.parquet)")
    info = parse_json_file(path)
    if not isinstance(info, dict):
        raise InputError(f"{path}: a JSON {type(info).__name__}, expected the dataset's "
                         "description (an object)")
    if info.get("complete") is False:
        raise InputError(f"{path}: the build is not finished (complete: false); run the "
                         "command that built it again to finish it, then create the edition")
    return info


def _check_files(root: Path) -> int:
    """Recompute every file's sha256 against the manifest (a tampered or damaged file
    refuses the edition, naming it)."""
    if is_mesh_set(root):
        rows = read_frame(root / layout.MANIFEST, "manifest").to_dict("records")
        return verify_listed_files(root, rows, "mesh_id", "path", "sha256")
    return verify_checksums(root)


def create_edition(data_root: str | os.PathLike, task: str, name: str, *,
                   split: str = "test", metrics: list[str] | None = None,
                   primary_metric: str | None = None, per_category: list[str] | None = None,
                   version: int = 1, description: str | None = None) -> Edition:
    """An edition pinned to a dataset the user built (e.g. with an adapter from a licensed
    copy of CLOTH3D), so a lab can run the same protocol on data that cannot be shipped.

    The dataset is pinned by the sha256 of its ``manifest.parquet`` (``kind: "real"``):
    scoring refuses any other data. Options are the task's defaults.

    Parameters
    ----------
    data_root : the dataset root (``dataset.json`` + ``manifest.parquet``).
    task : one of :data:`TASKS`.
    name : edition name (letters, digits, ``.``, ``-``, ``_``).
    split : the manifest split scored (must hold items of the task).
    metrics : metric names in table order (default: every metric of the task).
    primary_metric : the metric leaderboards sort by (default: the first metric).
    per_category : metrics shown per category (default: the primary metric).
    version : edition version (bump on any protocol change).
    description : free text (default: says what data and split it pins).

    Returns
    -------
    Edition, validated (save it with :meth:`Edition.save`).

    Raises
    ------
    InputError
        Unknown task, a bad or shipped edition name, no dataset at ``data_root``, an
        unfinished build (``complete: false``), a file whose sha256 differs from the
        manifest, data of another kind than the task's, or no items of the task in
        ``split`` (the message says which).
    """

    if task not in TASKS:
        raise InputError(f"--task must be one of {', '.join(TASKS)}, got {task!r}")
    if name in list_editions():
        raise InputError(f"--name {name!r} is a shipped edition's name; choose another (an "
                         "edition file is found by path, a shipped one by name)")
    root = Path(data_root)
    if not root.is_dir():
        raise InputError(f"--data {root} is not a folder (give the dataset root)")
    sha = manifest_sha256(root)
    ds_name = _dataset_info(root).get("name")
    kinds = {True: "a UV mesh set", False: "a garment dataset"}
    if (task == "uvparam") != is_mesh_set(root):
        raise InputError(f"--data {root} is {kinds[is_mesh_set(root)]}, but {task} editions "
                         f"are scored on {kinds[task == 'uvparam']}")
    _check_files(root)
    t = get_task(task)
    metrics = list(metrics) if metrics else [m.name for m in t.metrics]
    primary = primary_metric or metrics[0]
    data = {"schema": SCHEMA, "name": name, "version": version, "task": task,
            "dataset": {"kind": "real", "manifest_sha256": sha,
                        **({"name": str(ds_name)} if ds_name else {})},
            "split": split, "metrics": metrics, "primary_metric": primary,
            "per_category": list(per_category) if per_category is not None else [primary],
            "description": description or ""}
    ed = edition_from_dict(data, source=f"<created from {root}>")
    items = t.items(ed, root)
    if not items:
        raise InputError(f"dataset {root} has no {task} items in split {split!r}")
    if description is None:
        data["description"] = (f"{task} on the user-built dataset "
                               f"{ds_name or root.name} (split {split}, {len(items)} items), "
                               f"pinned by manifest sha256 {sha[:12]}")
        ed = edition_from_dict(data, source=f"<created from {root}>")
    return ed
