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
from dressmeup.io.images import image_header
from dressmeup.io.jsonio import parse_json_file, schema_problems
from dressmeup.io.mesh import load_mesh
from dressmeup.io.npz import load_npz

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
        arrays = load_npz(path, what="body file")  # bounded, pickle-free
    except (InputError, OSError) as exc:
        problems.append(f"{where}: body file {path.name} unreadable ({exc})")
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


def _files_under(folder: Path, problems: list[str]) -> list[Path]:
    """Regular files under ``folder`` (links to folders not followed; a link that cannot be
    resolved, e.g. a loop, is a problem)."""
    out = []
    for dirpath, dirnames, filenames in os.walk(folder):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            if p.is_symlink():
                try:
                    p.resolve(strict=True)
                except (OSError, RuntimeError) as exc:
                    problems.append(f"{p}: a symbolic link that cannot be resolved ({exc})")
                    continue
        out += [Path(dirpath) / n for n in filenames if (Path(dirpath) / n).is_file()]
    return out


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
    if not root.is_dir():
        rep.problems.append(f"{root}: not a folder")
        return rep
    _check_info(root, rep)
    rows = _read_rows(root, rep)
    if rows is None:
        return rep
    part = part_record(root)
    carried = set(part.get("splits") or ()) if part.get("part") == "private" else None
    if carried is not None:
        skipped = sum(1 for r in rows if r.get("split") not in carried)
        if skipped:
            rep.warnings.append(f"private part: the files of {skipped} sample(s) of splits "
                                f"other than {sorted(carried)} are in the public part, not here")
    if not rows:
        rep.problems.append(f"{layout.MANIFEST}: no samples")
    unique = _Uniqueness()
    files = _FileChecks(root, rep.problems, check_meshes, check_hashes)
    for i, r in enumerate(rows):
        where = f"sample {r.get('sample_id')!r} (row {i})"
        unique.check(i, r, where, rep)
        if carried is None or r.get("split") in carried:
            files.check_row(r, where)
    if check_meshes:
        _check_shared_topology(rows, files.faces_of, rep)
    _warn_unreferenced(root, files.referenced, rep)
    return rep


def _check_info(root: Path, rep: ValidationReport) -> None:
    """dataset.json: present, valid JSON, as its schema says; a build not finalized warns."""
    info_path = root / layout.DATASET_JSON
    if not info_path.is_file():
        rep.problems.append(f"{layout.DATASET_JSON}: missing")
        return
    try:
        info = parse_json_file(info_path)
    except InputError as exc:
        rep.problems.append(str(exc))
        return
    rep.problems.extend(schema_problems(info, "dataset", layout.DATASET_JSON))
    if isinstance(info, dict) and info.get("complete") is False:
        rep.warnings.append(f"{layout.DATASET_JSON}: build not finalized "
                            "(complete=false); re-run the build to finish it")


def _read_rows(root: Path, rep: ValidationReport) -> list[dict] | None:
    """The manifest's rows, its column types and nulls checked; None when it cannot be read."""
    P = rep.problems
    mpath = root / layout.MANIFEST
    if not mpath.is_file():
        P.append(f"{layout.MANIFEST}: missing")
        return None
    try:
        table = read_manifest(mpath)
    except InputError as exc:
        P.append(f"{layout.MANIFEST}: {exc}")
        return None
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
    return rows


@dataclass
class _Uniqueness:
    """What the rows seen so far claim: valid, unique sample ids; one sample per garment,
    subject and pose; one split, category and type per garment (a garment may be worn by
    several subjects, generator 2.x)."""

    seen: dict[str, int] = field(default_factory=dict)
    garment_pose: dict[tuple, str] = field(default_factory=dict)
    garment_fields: dict[str, dict] = field(default_factory=dict)

    def check(self, i: int, r: dict, where: str, rep: ValidationReport) -> None:
        """Check row ``i`` against the rows before it."""
        P = rep.problems
        sid = r.get("sample_id")
        for f in ("sample_id", "subject_id", "garment_id", "pose_id"):
            v = r.get(f)
            if v is None or not isinstance(v, str) or not layout.ID_PATTERN.match(v):
                P.append(f"{where}: {f} {v!r} is not a valid id (letters, digits, -, _)")
        if sid in self.seen:
            P.append(f"{where}: duplicate sample_id (also row {self.seen[sid]})")
        self.seen.setdefault(sid, i)
        key = (r.get("garment_id"), r.get("subject_id"), r.get("pose_id"))
        if key in self.garment_pose:
            P.append(f"{where}: garment {key[0]!r} on subject {key[1]!r} in pose {key[2]!r} "
                     f"also in {self.garment_pose[key]!r}")
        self.garment_pose.setdefault(key, sid)
        split = r.get("split")
        if split not in KNOWN_SPLITS:
            rep.warnings.append(f"{where}: split {split!r} is not one of {KNOWN_SPLITS}")
        g = r.get("garment_id")
        ref = self.garment_fields.setdefault(g, {k: r.get(k) for k in ("split", "category",
                                                                        "garment_type")})
        for k, v in ref.items():
            if r.get(k) != v:
                P.append(f"{where}: garment {g!r} has {k} {r.get(k)!r} here but {v!r} in "
                         "another sample (a garment has one split/category/type)")


@dataclass
class _FileChecks:
    """The files a row names: inside ROOT, present, checksums, then their content."""

    root: Path
    problems: list[str]
    check_meshes: bool
    check_hashes: bool
    referenced: set[Path] = field(default_factory=set)  # every file a row names
    faces_of: dict[str, list] = field(default_factory=dict)  # garment -> faces of each pose

    def check_row(self, r: dict, where: str) -> None:
        """Check every path column of row ``r``."""
        P = self.problems
        for col in PATH_COLUMNS:
            rel = r.get(col)
            if rel is None:
                if col == "garment_path" and "garment" not in withheld_fields(r):
                    P.append(f"{where}: {col} is missing")
                continue
            try:
                full = layout.resolve_inside(self.root, rel, col)
            except InputError as exc:
                P.append(f"{where}: {exc}")
                continue
            self.referenced.add(full)
            if not full.is_file():
                P.append(f"{where}: {col} file {rel} does not exist")
                continue
            hcol = HASH_OF[col]
            want = r.get(hcol)
            if want is None:
                P.append(f"{where}: {hcol} missing for {rel}")
            elif self.check_hashes and sha256_file(full) != want:
                P.append(f"{where}: {rel} checksum differs from the manifest ({hcol}); "
                         "the file was modified or damaged")
            if self.check_meshes:
                self._check_content(col, full, r, where)

    def _check_content(self, col: str, full: Path, r: dict, where: str) -> None:
        P = self.problems
        if col == "garment_path":
            m = _check_mesh(full, where, "garment", r.get("garment_vertices"),
                            r.get("garment_faces"), P)
            self.faces_of.setdefault(r.get("garment_id"), []).append(
                None if m is None else m.faces)
        elif col == "scan_path":
            _check_mesh(full, where, "scan", r.get("scan_vertices"), r.get("scan_faces"), P)
        elif col == "body_path":
            _check_body(full, where, P)
        elif col == "texture_path":
            try:  # size bounded from the header, structure verified, nothing decoded
                image_header(full, "texture", verify=True)
            except (InputError, OSError) as exc:
                P.append(f"{where}: {exc}")


def _check_shared_topology(rows: list[dict], faces_of: dict[str, list],
                           rep: ValidationReport) -> None:
    """``topology_shared`` of each garment agrees with the faces of its poses."""
    for g, faces in faces_of.items():
        claimed = {r.get("topology_shared") for r in rows if r.get("garment_id") == g}
        if any(f is None for f in faces):
            continue
        shared = all(f.shape == faces[0].shape and np.array_equal(f, faces[0]) for f in faces)
        if True in claimed and not shared:
            rep.problems.append(f"garment {g!r}: topology_shared is true but its poses have "
                                "different faces")
        if False in claimed and shared and len(faces) > 1:
            rep.warnings.append(f"garment {g!r}: poses share faces but topology_shared is false")


def _warn_unreferenced(root: Path, referenced: set[Path], rep: ValidationReport) -> None:
    """Files under samples/ that no row names (leftovers of interrupted writes among them)."""
    samples = root / layout.SAMPLES_DIR
    if samples.is_dir():
        for p in sorted(_files_under(samples, rep.problems)):
            if p.resolve() not in referenced:
                kind = "temporary file of an interrupted write" if ".tmp" in p.name else \
                    "file not in the manifest"
                rep.warnings.append(f"{p.relative_to(root)}: {kind}")
