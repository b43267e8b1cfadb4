"""`DatasetWriter`: build a dataset sample by sample, atomically and resumably.

Every file is written to a temporary name beside its target and renamed into place; the
manifest is rewritten (atomically) after each sample's files are complete. A sample appears
in the manifest only once all its files exist with their checksums, so an interrupted build
never exposes a half-written sample; re-opening the same ROOT resumes (``has_sample`` tells
a generator what to skip) and rewrites any stray files of the unfinished sample.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup import __version__
from dressmeup.cache import hash_arrays
from dressmeup.data import layout
from dressmeup.data.manifest import MANIFEST_VERSION, read_manifest, write_manifest
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_path, atomic_write_bytes, atomic_write_text
from dressmeup.io.hashing import sha256_file
from dressmeup.io.images import read_image
from dressmeup.io.jsonable import json_default
from dressmeup.io.jsonio import parse_json_file
from dressmeup.io.mesh import load_mesh, save_mesh
from dressmeup.io.outlock import output_lock

log = logging.getLogger(__name__)

#: dataset.json keys that change while a build runs and are ignored when resuming.
_VOLATILE = {"complete", "n_samples", "n_garments", "n_subjects", "toolkit_version",
             "manifest_version", "format", "units", "splits", "timings"}


def _jsonable(obj: Any) -> Any:
    return json.loads(json.dumps(obj, sort_keys=True, default=json_default))


def _mesh_arrays(mesh: Any, name: str) -> tuple[np.ndarray, np.ndarray, Any, Any]:
    """Accept a GarmentMesh-like object, a trimesh, or a (V, F[, uv, uv_faces]) tuple."""
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        V, F = mesh.vertices, mesh.faces
        uv = getattr(mesh, "uv", None)
        uvf = getattr(mesh, "uv_faces", None)
        if uv is not None and not isinstance(uv, np.ndarray):
            uv = None  # trimesh visual objects etc.
    elif isinstance(mesh, (tuple, list)) and len(mesh) in (2, 3, 4):
        V, F = mesh[0], mesh[1]
        uv = mesh[2] if len(mesh) > 2 else None
        uvf = mesh[3] if len(mesh) > 3 else None
    else:
        raise InputError(f"{name}: expected a mesh object or (vertices, faces[, uv, uv_faces]), "
                         f"got {type(mesh).__name__}")
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3 or len(V) == 0:
        raise InputError(f"{name}.vertices: expected shape (n>0, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or len(F) == 0 or not np.issubdtype(F.dtype, np.integer):
        raise InputError(f"{name}.faces: expected integer shape (m>0, 3), got {F.shape} {F.dtype}")
    if not np.isfinite(V).all():
        raise InputError(f"{name}.vertices: contains NaN or inf")
    if F.min() < 0 or F.max() >= len(V):
        raise InputError(f"{name}.faces: indices out of range [0, {len(V)})")
    if uv is not None:
        uv = np.asarray(uv, dtype=np.float64)
        uvf = F if uvf is None else np.asarray(uvf)
        if uv.ndim != 2 or uv.shape[1] != 2:
            raise InputError(f"{name}.uv: expected shape (k, 2), got {uv.shape}")
        if uvf.shape != F.shape or uvf.min() < 0 or uvf.max() >= len(uv):
            raise InputError(f"{name}.uv_faces: expected shape {F.shape} with indices < {len(uv)}")
    return V, F.astype(np.int64), uv, uvf


class DatasetWriter:
    """Write a DressMeUp-style dataset under ``root`` (docs/spec.md section 3).

    Parameters
    ----------
    root : dataset folder (created if missing).
    info : fields of ``dataset.json`` (name, version, licence, body model, categories,
        citation, generator provenance, ...). When ``root`` already holds a dataset, its
        ``dataset.json`` must agree with ``info`` (the build resumes), else
        :class:`InputError` is raised. One writer per folder: the writer holds the folder's
        lock (:func:`dressmeup.io.outlock.output_lock`) until :meth:`finalize`, so a second
        process writing the same dataset meanwhile is refused.

    Attributes
    ----------
    previous_info : ``dataset.json`` as an earlier run left it ({} for a new dataset), e.g.
        the build records a resumed build keeps.

    Examples
    --------
    >>> w = DatasetWriter("out", {"name": "mine"})                       # doctest: +SKIP
    >>> w.add_sample(subject_id="S01", garment_id="G01", pose_id="P1",     # doctest: +SKIP
    ...              category="topwear", garment_type="t-shirt", split="train",
    ...              garment=(V, F), body=params)
    >>> w.finalize()                                                       # doctest: +SKIP
    """

    def __init__(self, root: str | os.PathLike, info: Mapping[str, Any]) -> None:
        self.root = Path(root)
        self._lock = contextlib.ExitStack()
        self._lock.enter_context(output_lock(self.root, "dataset"))
        try:
            self._open(info)
        except BaseException:
            self._lock.close()
            raise

    def _open(self, info: Mapping[str, Any]) -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        self.info = _jsonable(dict(info))
        info_path = self.root / layout.DATASET_JSON
        if info_path.exists():
            old = parse_json_file(info_path)  # bounded; UTF-8 and JSON checked
            if not isinstance(old, dict):
                raise InputError(f"{info_path}: a JSON {type(old).__name__}, expected the "
                                 "dataset's description (an object); choose another folder")
            # keys given now must match; keys only in the old file (added by finalize or
            # by a later writer version) are kept
            diff = sorted(k for k in self.info
                          if k not in _VOLATILE and old.get(k) != self.info.get(k))
            if diff:
                raise InputError(f"{self.root} already holds a different dataset (dataset.json "
                                 f"differs in {diff}); choose another folder or delete it")
        self.previous_info: dict[str, Any] = dict(old) if info_path.exists() else {}
        full = {**self.previous_info,
                "format": "dressmeup-dataset", "manifest_version": MANIFEST_VERSION,
                "units": "m", **self.info, "complete": False,
                "toolkit_version": __version__}
        atomic_write_text(info_path, json.dumps(full, indent=2, sort_keys=True) + "\n")
        self._rows: list[dict[str, Any]] = []
        mpath = self.root / layout.MANIFEST
        if mpath.exists():
            self._rows = read_manifest(mpath).to_pylist()
            log.info("resuming %s: %d samples already written", self.root, len(self._rows))
        self._ids = {r["sample_id"] for r in self._rows}
        self._faces_key: dict[str, str] = {}  # sample_id -> hash of its garment faces

    # ------------------------------------------------------------------ queries
    def has_sample(self, sample_id: str) -> bool:
        """True when ``sample_id`` is complete in the manifest (skip it when resuming)."""
        return sample_id in self._ids

    @property
    def rows(self) -> list[dict[str, Any]]:
        """The manifest rows written so far (copies)."""
        return [dict(r) for r in self._rows]

    # ------------------------------------------------------------------ writing
    def _write_body(self, path: Path, body: Any) -> None:
        if isinstance(body, (str, os.PathLike)):
            atomic_write_bytes(path, Path(body).read_bytes())
            return
        if hasattr(body, "save"):
            with atomic_path(path) as tmp:
                body.save(tmp)
            return
        if isinstance(body, Mapping):
            buf = io.BytesIO()
            np.savez(buf, **{k: np.asarray(v) for k, v in body.items()})
            atomic_write_bytes(path, buf.getvalue())
            return
        raise InputError(f"body: expected BodyParams, a dict of arrays or a .npz path, "
                         f"got {type(body).__name__}")

    def add_sample(self, *, subject_id: str, garment_id: str, pose_id: str, category: str,
                   garment_type: str, split: str, garment: Any, body: Any = None,
                   scan: Any = None, texture: Any = None, sample_id: str | None = None,
                   overwrite: bool = False) -> dict[str, Any]:
        """Write one sample's files, then add its manifest row (atomically).

        Parameters
        ----------
        subject_id, garment_id, pose_id : ids (letters, digits, ``-``, ``_``).
        category : ``topwear``, ``bottomwear``, ``dress``, ...
        garment_type : finer type (``t-shirt``, ``trousers``, ...).
        split : ``train``, ``val`` or ``test``; all poses of a garment share one split.
        garment : GarmentMesh, trimesh, or tuple ``(V (n,3), F (m,3)[, uv (k,2), uv_faces (m,3)])``.
        body : BodyParams (anything with ``.save(path)``), a dict of arrays, a ``.npz`` path,
            or None.
        scan : the clothed person as a mesh or ``(V, F)``, or None.
        texture : PNG bytes, a PIL image, an ``(h, w, 3|4) uint8`` array, a file path, or None.
        sample_id : default ``<subject>-<garment>-<pose>``.
        overwrite : replace an existing sample with the same id instead of raising.

        Returns
        -------
        The manifest row (dict).
        """
        sid = sample_id if sample_id is not None else layout.make_sample_id(
            subject_id, garment_id, pose_id)
        row: dict[str, Any] = {
            "sample_id": sid, "subject_id": subject_id, "garment_id": garment_id,
            "pose_id": pose_id, "category": category, "garment_type": garment_type,
            "split": split, "topology_shared": False,
        }
        self._check_new_row(row, overwrite)
        V, F, uv, uvf = _mesh_arrays(garment, "garment")
        rel_dir = layout.sample_dir(subject_id, garment_id, pose_id)
        d = layout.resolve_inside(self.root, rel_dir, "sample folder")
        d.mkdir(parents=True, exist_ok=True)
        tex_arr = None if texture is None else self._texture_array(texture)
        save_mesh(d / layout.GARMENT_FILE, V, F, uv=uv, uv_faces=uvf, texture=tex_arr)
        if tex_arr is not None:
            row["texture_path"] = f"{rel_dir}/{layout.TEXTURE_FILE}"
            row["texture_sha256"] = sha256_file(d / layout.TEXTURE_FILE)
        row["garment_path"] = f"{rel_dir}/{layout.GARMENT_FILE}"
        row["garment_sha256"] = sha256_file(d / layout.GARMENT_FILE)
        row["garment_vertices"], row["garment_faces"] = len(V), len(F)
        if scan is not None:
            SV, SF, _, _ = _mesh_arrays(scan, "scan")
            save_mesh(d / layout.SCAN_FILE, SV, SF)
            row["scan_path"] = f"{rel_dir}/{layout.SCAN_FILE}"
            row["scan_sha256"] = sha256_file(d / layout.SCAN_FILE)
            row["scan_vertices"], row["scan_faces"] = len(SV), len(SF)
        if body is not None:
            self._write_body(d / layout.BODY_FILE, body)
            row["body_path"] = f"{rel_dir}/{layout.BODY_FILE}"
            row["body_sha256"] = sha256_file(d / layout.BODY_FILE)
        rows = [r for r in self._rows if r["sample_id"] != sid] + [row]
        self._update_topology(rows, {sid: F})
        write_manifest(self.root / layout.MANIFEST, rows)
        self._rows = rows
        self._ids.add(sid)
        return dict(row)

    def _check_new_row(self, row: dict[str, Any], overwrite: bool) -> None:
        """Refuse, before anything is written: bad ids or labels, a sample id already present
        (unless ``overwrite``), a garment's (subject, pose) twice, or a garment whose split,
        category or type differs from its other samples."""
        sid, garment_id = row["sample_id"], row["garment_id"]
        layout.check_id(sid, "sample_id")
        for n in ("subject_id", "garment_id", "pose_id"):
            layout.check_id(row[n], n)
        for n in ("category", "garment_type", "split"):
            v = row[n]
            if not isinstance(v, str) or not v:
                raise InputError(f"{n}: expected a non-empty string, got {v!r}")
        if sid in self._ids and not overwrite:
            raise InputError(f"sample {sid!r} is already in {self.root} (pass overwrite=True)")
        for r in self._rows:
            if r["sample_id"] == sid or r["garment_id"] != garment_id:
                continue
            # a garment may be worn by several subjects (generator 2.x): a (subject, pose) is
            # unique per garment
            if r["pose_id"] == row["pose_id"] and r["subject_id"] == row["subject_id"]:
                raise InputError(f"garment {garment_id!r} already has pose {row['pose_id']!r} "
                                 f"on subject {row['subject_id']!r} (sample {r['sample_id']!r})")
            for key in ("split", "category", "garment_type"):
                if r[key] != row[key]:
                    raise InputError(f"garment {garment_id!r}: {key} {row[key]!r} differs from "
                                     f"{r[key]!r} of sample {r['sample_id']!r}; a garment "
                                     f"has one {key}")

    @staticmethod
    def _texture_array(texture: Any) -> np.ndarray:
        """An (h, w, 3|4) uint8 image from bytes, a PIL image, an array or a path."""

        if isinstance(texture, (bytes, bytearray, str, os.PathLike)):
            return read_image(texture, "texture")
        if hasattr(texture, "convert"):
            return np.asarray(texture.convert("RGB"))
        arr = np.asarray(texture)
        if arr.dtype != np.uint8 or arr.ndim != 3 or arr.shape[2] not in (3, 4):
            raise InputError(f"texture: expected an (h, w, 3) uint8 image, PNG bytes or a path, "
                             f"got {arr.dtype} {arr.shape}")
        return arr

    def _faces_key_of(self, row: dict[str, Any]) -> str | None:
        sid = row["sample_id"]
        if sid not in self._faces_key:
            try:
                F = load_mesh(layout.resolve_inside(self.root, row["garment_path"])).faces
            except Exception:  # noqa: BLE001 - unreadable: topology unknown, not shared
                return None
            self._faces_key[sid] = hash_arrays(np.asarray(F, np.int64))
        return self._faces_key[sid]

    def _update_topology(self, rows: list[dict[str, Any]], known: dict[str, np.ndarray]) -> None:
        """Set ``topology_shared`` for the garments in ``known`` (all rows of those garments)."""
        for sid, F in known.items():
            self._faces_key[sid] = hash_arrays(np.asarray(F, np.int64))
        garments = {r["garment_id"] for r in rows if r["sample_id"] in known}
        for g in garments:
            grp = [r for r in rows if r["garment_id"] == g]
            keys = [self._faces_key_of(r) for r in grp]
            shared = all(k is not None for k in keys) and len(set(keys)) == 1 and all(
                r["garment_vertices"] == grp[0]["garment_vertices"] for r in grp)
            for r in grp:
                r["topology_shared"] = bool(shared)

    def update_info(self, **fields: Any) -> None:
        """Write ``fields`` into ``dataset.json`` now (atomically), the dataset still
        incomplete: what a build must not lose if it is killed before :meth:`finalize`
        (a resumed build reads it back from :attr:`previous_info`).

        Parameters
        ----------
        **fields : top-level ``dataset.json`` fields (JSON-able values); each replaces the
            field of that name.
        """
        info_path = self.root / layout.DATASET_JSON
        info = parse_json_file(info_path)
        info.update(_jsonable(fields))
        info["complete"] = False
        atomic_write_text(info_path, json.dumps(info, indent=2, sort_keys=True) + "\n")

    def finalize(self, row_order: Mapping[str, Any] | None = None, **extra_info: Any) -> Path:
        """Mark the dataset complete in ``dataset.json`` (with counts and splits).

        Parameters
        ----------
        row_order : sample id -> sort key: the manifest's rows in that order (a build whose
            samples arrive in completion order, or over several resumed runs, writes the
            same manifest as one serial run); None keeps the order samples were added in.
        **extra_info : more ``dataset.json`` fields (e.g. timings).

        Returns
        -------
        The dataset root.
        """
        info_path = self.root / layout.DATASET_JSON
        info = parse_json_file(info_path)
        if row_order is not None:
            missing = [r["sample_id"] for r in self._rows if r["sample_id"] not in row_order]
            if missing:
                raise ValueError(f"row_order: no key for samples {missing[:5]}")
            self._rows.sort(key=lambda r: row_order[r["sample_id"]])
        splits: dict[str, list[str]] = {}
        for r in self._rows:
            ids = splits.setdefault(r["split"], [])
            if r["garment_id"] not in ids:
                ids.append(r["garment_id"])
        info.update(_jsonable(extra_info))
        info.update({"complete": True, "n_samples": len(self._rows),
                     "n_garments": len({r["garment_id"] for r in self._rows}),
                     "n_subjects": len({r["subject_id"] for r in self._rows}),
                     "splits": {k: sorted(v) for k, v in sorted(splits.items())}})
        write_manifest(self.root / layout.MANIFEST, self._rows)
        atomic_write_text(info_path, json.dumps(info, indent=2, sort_keys=True) + "\n")
        for tmp in self.root.rglob(".*.tmp*"):
            tmp.unlink()
        self._lock.close()
        return self.root
