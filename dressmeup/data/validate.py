"""Check a dataset folder against the format (docs/spec.md section 3) and report every problem.

:func:`validate_dataset` never stops at the first problem: it collects them all (schema,
missing files, checksums, mesh sanity, body files, splits, paths outside ROOT, damaged
Parquet) so that one run tells the dataset builder everything to fix.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dressmeup.data import layout
from dressmeup.data.dataset import read_dataset_ply
from dressmeup.data.manifest import HASH_OF, PATH_COLUMNS, columns, read_manifest
from dressmeup.data.parts import part_record, withheld_fields
from dressmeup.errors import InputError
from dressmeup.io.hashing import sha256_file
from dressmeup.io.jsonio import parse_json_file, schema_problems
from dressmeup.io.mesh import load_mesh

KNOWN_SPLITS = ("train", "val", "test")
#: Largest plausible extent of a garment or scan in metres (a person is under 3 m; a
#: garment in centimetres already spans tens of units).
MAX_EXTENT_M = 10.0


@dataclass
class ValidationReport:
    """The outcome of :func:`validate_dataset`.

    Attributes
    ----------
    root : the dataset folder.
    problems : list of messages, each naming the sample/file/field at fault.
    warnings : things that do not make the dataset invalid (e.g. files not in the manifest).
    n_samples : manifest rows checked.
    """

    root: Path
    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    n_samples: int = 0

    @property
    def ok(self) -> bool:
        """True when no problem was found."""
        return not self.problems

    def format(self) -> str:
        """A human-readable report (one line per problem)."""
        lines = [f"dataset {self.root}: {self.n_samples} samples, "
                 f"{len(self.problems)} problem(s), {len(self.warnings)} warning(s)"]
        lines += [f"  ERROR   {p}" for p in self.problems]
        lines += [f"  warning {w}" for w in self.warnings]
        lines.append("  OK" if self.ok else "  INVALID")
        return "\n".join(lines)


def _check_body(path: Path, where: str, problems: list[str]) -> None:
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except Exception as exc:  # noqa: BLE001 - any unreadable file is a problem to report
        problems.append(f"{where}: body file {path.name} unreadable without pickle ({exc})")
        return
    for k in ("model", "shape", "pose"):
        if k not in arrays:
            problems.append(f"{where}: body file {path.name} lacks field {k!r}")
    if "pose" in arrays:
        pose = np.asarray(arrays["pose"])
        if pose.dtype.kind not in "fi" or not (pose.ndim == 2 and pose.shape[1] == 3):
            problems.append(f"{where}: body pose has shape {pose.shape}, expected (j, 3)")
    for k in ("shape", "pose", "transl", "scale"):
        if k in arrays and arrays[k].dtype.kind in "fi" and not np.isfinite(arrays[k]).all():
            problems.append(f"{where}: body field {k!r} has NaN or inf")
    if "scale" in arrays and arrays["scale"].dtype.kind in "fi" and np.any(arrays["scale"] <= 0):
        problems.append(f"{where}: body scale must be positive")


def _check_mesh(path: Path, where: str, what: str, n_v, n_f, problems: list[str]):
    try:
        m = read_dataset_ply(path) if path.suffix.lower() == ".ply" else None
        if m is None:  # other layouts, or a damaged file: the general reader names the fault
            m = load_mesh(path)
    except Exception as exc:  # noqa: BLE001
        problems.append(f"{where}: {what} mesh {path.name} is not a valid mesh ({exc})")
        return None
    extent = float(np.ptp(m.vertices, axis=0).max()) if len(m.vertices) else 0.0
    if extent > MAX_EXTENT_M:
        problems.append(f"{where}: {what} mesh {path.name} spans {extent:.4g} units, but dataset "
                        f"units are metres (at most {MAX_EXTENT_M:g} m): is it in millimetres "
                        "or centimetres? scale it when building the dataset")
    if n_v is not None and not _isnull(n_v) and int(n_v) != len(m.vertices):
        problems.append(f"{where}: {what} has {len(m.vertices)} vertices, manifest says {int(n_v)}")
    if n_f is not None and not _isnull(n_f) and int(n_f) != len(m.faces):
        problems.append(f"{where}: {what} has {len(m.faces)} faces, manifest says {int(n_f)}")
    return m


def _isnull(v) -> bool:
    return v is None or (isinstance(v, float) and np.isnan(v))


def validate_dataset(root: str | os.PathLike, check_meshes: bool = True,
                     check_hashes: bool = True) -> ValidationReport:
    """Validate the dataset at ``root``.

    Parameters
    ----------
    root : dataset folder.
    check_meshes : load every mesh and body file (sanity: finite, faces in range, non-empty,
        counts as in the manifest).
    check_hashes : recompute the sha256 of every file.

    Returns
    -------
    ValidationReport (``report.ok`` is False when any problem was found).
    """

    root = Path(root)
    rep = ValidationReport(root)
    P = rep.problems
    if not root.is_dir():
        P.append(f"{root}: not a folder")
        return rep
    info_path = root / layout.DATASET_JSON
    if not info_path.is_file():
        P.append(f"{layout.DATASET_JSON}: missing")
    else:
        try:
            info = parse_json_file(info_path)
        except InputError as exc:
            P.append(str(exc))
        else:
            P.extend(schema_problems(info, "dataset", layout.DATASET_JSON))
            if isinstance(info, dict) and info.get("complete") is False:
                rep.warnings.append(f"{layout.DATASET_JSON}: build not finalized "
                                    "(complete=false); re-run the build to finish it")
    mpath = root / layout.MANIFEST
    if not mpath.is_file():
        P.append(f"{layout.MANIFEST}: missing")
        return rep
    try:
        table = read_manifest(mpath)
    except InputError as exc:
        P.append(f"{layout.MANIFEST}: {exc}")
        return rep
    public = "withheld" in table.column_names
    for name, typ, nullable, _d in columns(public):
        if name in table.column_names:
            got = table.schema.field(name).type
            if got != typ:
                P.append(f"{layout.MANIFEST}: column {name!r} has type {got}, expected {typ}")
            elif not nullable and table.column(name).null_count:
                P.append(f"{layout.MANIFEST}: column {name!r} has {table.column(name).null_count} "
                         "null value(s)")
    rows = table.to_pylist()
    rep.n_samples = len(rows)
    part = part_record(root)
    carried = set(part.get("splits") or ()) if part.get("part") == "private" else None
    if carried is not None:
        skipped = sum(1 for r in rows if r.get("split") not in carried)
        if skipped:
            rep.warnings.append(f"private part: the files of {skipped} sample(s) of splits "
                                f"other than {sorted(carried)} are in the public part, not here")
    if not rows:
        P.append(f"{layout.MANIFEST}: no samples")
    seen: dict[str, int] = {}
    garment_pose: dict[tuple, str] = {}
    garment_fields: dict[str, dict] = {}
    faces_of: dict[str, list] = {}
    referenced: set[Path] = set()
    for i, r in enumerate(rows):
        sid = r.get("sample_id")
        where = f"sample {sid!r} (row {i})"
        for f in ("sample_id", "subject_id", "garment_id", "pose_id"):
            v = r.get(f)
            if v is None or not isinstance(v, str) or not layout.ID_PATTERN.match(v):
                P.append(f"{where}: {f} {v!r} is not a valid id (letters, digits, -, _)")
        if sid in seen:
            P.append(f"{where}: duplicate sample_id (also row {seen[sid]})")
        seen.setdefault(sid, i)
        key = (r.get("garment_id"), r.get("subject_id"), r.get("pose_id"))
        if key in garment_pose:
            P.append(f"{where}: garment {key[0]!r} on subject {key[1]!r} in pose {key[2]!r} "
                     f"also in {garment_pose[key]!r}")
        garment_pose.setdefault(key, sid)
        split = r.get("split")
        if split not in KNOWN_SPLITS:
            rep.warnings.append(f"{where}: split {split!r} is not one of {KNOWN_SPLITS}")
        g = r.get("garment_id")
        # a garment may be worn by several subjects (generator 2.x), but has one split,
        # category and type
        ref = garment_fields.setdefault(g, {k: r.get(k) for k in ("split", "category",
                                                                   "garment_type")})
        for k, v in ref.items():
            if r.get(k) != v:
                P.append(f"{where}: garment {g!r} has {k} {r.get(k)!r} here but {v!r} in "
                         "another sample (a garment has one split/category/type)")
        for col in PATH_COLUMNS:
            rel = r.get(col)
            if carried is not None and split not in carried:
                continue
            if rel is None:
                if col == "garment_path" and "garment" not in withheld_fields(r):
                    P.append(f"{where}: {col} is missing")
                continue
            try:
                full = layout.resolve_inside(root, rel, col)
            except InputError as exc:
                P.append(f"{where}: {exc}")
                continue
            referenced.add(full)
            if not full.is_file():
                P.append(f"{where}: {col} file {rel} does not exist")
                continue
            hcol = HASH_OF[col]
            want = r.get(hcol)
            if want is None:
                P.append(f"{where}: {hcol} missing for {rel}")
            elif check_hashes and sha256_file(full) != want:
                P.append(f"{where}: {rel} checksum differs from the manifest ({hcol}); "
                         "the file was modified or damaged")
            if not check_meshes:
                continue
            if col == "garment_path":
                m = _check_mesh(full, where, "garment", r.get("garment_vertices"),
                                r.get("garment_faces"), P)
                faces_of.setdefault(g, []).append(None if m is None else m.faces)
            elif col == "scan_path":
                _check_mesh(full, where, "scan", r.get("scan_vertices"), r.get("scan_faces"), P)
            elif col == "body_path":
                _check_body(full, where, P)
    if check_meshes:
        for g, faces in faces_of.items():
            claimed = {r.get("topology_shared") for r in rows if r.get("garment_id") == g}
            if any(f is None for f in faces):
                continue
            shared = all(f.shape == faces[0].shape and np.array_equal(f, faces[0]) for f in faces)
            if True in claimed and not shared:
                P.append(f"garment {g!r}: topology_shared is true but its poses have different "
                         "faces")
            if False in claimed and shared and len(faces) > 1:
                rep.warnings.append(f"garment {g!r}: poses share faces but topology_shared is false")
    samples = root / layout.SAMPLES_DIR
    if samples.is_dir():
        for p in sorted(samples.rglob("*")):
            if p.is_file() and p.resolve() not in referenced:
                kind = "temporary file of an interrupted write" if ".tmp" in p.name else \
                    "file not in the manifest"
                rep.warnings.append(f"{p.relative_to(root)}: {kind}")
    return rep
