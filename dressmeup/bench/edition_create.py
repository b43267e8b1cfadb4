"""Editions pinned to data on disk, after checking that the data are finished and intact:
:func:`create_edition` pins a user-built dataset or mesh set by the sha256 of its manifest
(``kind: "real"``); :func:`pin_expected_manifest` writes into a generated edition's file the
sha256 of the manifest its generator wrote (``dataset.expected_manifest_sha256``), once the
data are shown to be that edition's (generator, parameters, seed, every split, the test
split's secret).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from dressmeup.bench.edition import (
    ALL_SPLITS,
    SCHEMA,
    TASKS,
    Edition,
    edition_from_dict,
    list_editions,
    load_edition,
)
from dressmeup.bench.tasks import get_task
from dressmeup.bench.tasks.common import manifest_sha256
from dressmeup.data import layout
from dressmeup.data.integrity import verify_checksums, verify_listed_files
from dressmeup.data.synth.config import synth_config
from dressmeup.data.synth.dataset4 import Gen4Config
from dressmeup.data.uvmeshes import is_mesh_set
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
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


def _data_folder(data_root: str | os.PathLike) -> Path:
    """``data_root`` as a Path; a missing folder is refused."""
    root = Path(data_root)
    if not root.is_dir():
        raise InputError(f"--data {root} is not a folder (give the dataset root)")
    return root


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
    root = _data_folder(data_root)
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


@dataclass(frozen=True)
class ManifestPin:
    """What :func:`pin_expected_manifest` did to an edition file.

    Attributes
    ----------
    path : the edition file.
    sha256 : the data's manifest sha256, now ``dataset.expected_manifest_sha256``.
    previous : the pin the file held before (None: none).
    old_hash, new_hash : the edition's hash before and after (equal when nothing changed).
    """

    path: Path
    sha256: str
    previous: str | None
    old_hash: str
    new_hash: str

    @property
    def changed(self) -> bool:
        """Whether the file was rewritten."""
        return self.previous != self.sha256


def generated_params_problems(ed: Edition, info: dict) -> list[str]:
    """Why ``dataset.json`` content ``info`` does not describe the data of generated edition
    ``ed`` (its generator version, parameters and seed, every split, the test split seeded by
    the edition's committed secret); [] when it does. Generator-4 editions only (``...-v5``;
    older editions' pins are final)."""
    pin = ed.dataset
    if not str(pin.params.get("version", "")).startswith("4."):
        raise InputError(f"edition {ed.name}: generator {pin.generator_version}; only "
                         "generator-4 editions (...-v5) are pinned this way")
    gen = info.get("generator") if isinstance(info.get("generator"), dict) else {}
    got = dict(gen.get("params") or {})
    want = Gen4Config.from_synth(synth_config(**pin.params, seed=pin.seed)).params(pin.seed)
    want = json.loads(json.dumps(want))  # the types dataset.json holds (lists, floats)
    problems = []
    if gen.get("version") != pin.generator_version or gen.get("seed") != pin.seed:
        problems.append(f"generator {gen.get('version')!r} seed {gen.get('seed')!r}, the "
                        f"edition's is {pin.generator_version!r} seed {pin.seed!r}")
    splits = got.pop("splits", None)
    if sorted(splits or []) != sorted(ALL_SPLITS):
        problems.append(f"splits {splits!r}: the edition pins every split "
                        f"({', '.join(ALL_SPLITS)})")
    commit = got.pop("test_split_commitment", None)
    if commit != pin.test_split_commitment:
        problems.append("the test split was seeded " + (
            "publicly" if commit is None else f"by a secret with commitment {commit[:12]}...")
            + ", the edition's " + (f"by the secret with commitment "
                                    f"{pin.test_split_commitment[:12]}..."
                                    if pin.test_split_commitment else "publicly"))
    for key in sorted(set(want) | set(got)):
        if want.get(key) != got.get(key):
            problems.append(f"generator parameter {key!r} differs from the edition's")
    return problems


def pin_expected_manifest(edition_file: str | os.PathLike, data_root: str | os.PathLike, *,
                          replace: bool = False) -> ManifestPin:
    """Pin a generated edition to the manifest of its data.

    Checks that ``data_root`` is a finished, intact build of the edition (every file's
    sha256 against the manifest; :func:`generated_params_problems`), then writes the sha256
    of its ``manifest.parquet`` into the file as ``dataset.expected_manifest_sha256``
    (atomically, as 2-space-indented JSON like the shipped editions, for which only that
    line changes). Scoring then refuses other data unless asked to
    score them as not comparable.

    Parameters
    ----------
    edition_file : an edition JSON file (a shipped edition is changed in its own file).
    data_root : the data ``dressmeup synth --edition ... [--secret FILE]`` wrote.
    replace : replace a different pin the file already holds (results scored under the old
        pin are then of another edition).

    Returns
    -------
    ManifestPin

    Raises
    ------
    InputError
        No such file, not a generated generator-4 edition, no finished dataset at
        ``data_root``, a damaged file, data of other parameters, splits or secret, or a
        different pin already there without ``replace`` (the message says which).
    """
    path = Path(edition_file)
    if not path.is_file():
        raise InputError(f"{path}: no such edition file (give the path of the edition JSON "
                         "to pin, e.g. dressmeup/bench/editions/NAME.json in a checkout)")
    ed = load_edition(path)
    if ed.dataset.kind != "generated":
        raise InputError(f"{path}: edition {ed.name} pins a real dataset by its manifest "
                         "already (dataset.manifest_sha256)")
    root = _data_folder(data_root)
    info = _dataset_info(root)
    problems = generated_params_problems(ed, info)
    if problems:
        raise InputError(f"--data {root} is not the data of edition {ed.name}: "
                         + "; ".join(problems) + f" (generate them with dressmeup synth OUT "
                         f"--edition {path} [--secret FILE])")
    _check_files(root)
    sha = manifest_sha256(root)
    previous = ed.dataset.expected_manifest_sha256
    if previous == sha:
        return ManifestPin(path, sha, previous, ed.hash, ed.hash)
    if previous and not replace:
        raise InputError(f"{path}: edition {ed.name} already expects manifest "
                         f"{previous[:12]}..., the data at {root} have {sha[:12]}...; pass "
                         "--replace to pin these instead (results scored under the old pin "
                         "are then of another edition)")
    raw = parse_json_file(path)
    raw["dataset"]["expected_manifest_sha256"] = sha
    new = edition_from_dict(raw, source=str(path))
    atomic_write_text(path, json.dumps(raw, indent=2, ensure_ascii=False) + "\n")
    return ManifestPin(path, sha, previous, ed.hash, new.hash)
