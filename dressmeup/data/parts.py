"""Public and private parts of a dataset: the same folder layout, split by what a participant
may see.

A benchmark's data exist in three forms, each a dataset folder (``dataset.json`` +
``manifest.parquet`` + files):

- **full**: everything (what a generator writes, what a maintainer keeps);
- **public**: what a method author receives. Its manifest (version 1.1) has every row, but
  the cells of withheld files are null and the column ``withheld`` names them
  (``"garment,scan"``); ``dataset.json`` has ``"part": {"part": "public", ...}``;
- **private**: what the scorer holds: the full manifest (byte for byte, so the edition's pin
  holds), ``"part": {"part": "private", "splits": [...]}`` and every file of those splits'
  samples (inputs too, so that scoring needs nothing else) plus the withheld files outside
  ``samples/`` (generator files).

Both parts leave out what only says how long a build took (``dataset.json``'s ``timings``,
the CPU seconds in ``dataset.json`` and ``generator/stats/*.json``), so two builds of the
same data export the same bytes.

Which files are withheld is the benchmark's decision (:mod:`dressmeup.bench.parts`); this
module only writes, recognises and reads the parts.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dressmeup.data import layout
from dressmeup.data.manifest import (
    HASH_OF,
    read_manifest,
    write_manifest,
)
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_dir, atomic_write_text
from dressmeup.io.jsonio import parse_json_file

PARTS = ("full", "public", "private")
#: manifest fields a part may withhold: the file columns without their ``_path``
FILE_FIELDS = ("garment", "texture", "scan", "body")
#: count columns that go with a withheld file
_COUNTS = {"garment": (), "scan": ("scan_vertices", "scan_faces")}


@dataclass
class Withheld:
    """What the public part leaves out.

    Attributes
    ----------
    fields : sample id -> the :data:`FILE_FIELDS` of that sample that are withheld.
    files : other withheld files, relative to the root (``generator/fitted/G07-S02.ply``).
    private_splits : the splits whose samples the private part carries in full.
    public_extra : optional ``f(public_root) -> [relative paths]`` writing files only the
        public part has (e.g. the captures a fusion benchmark gives instead of its scans).
    """

    fields: dict[str, tuple[str, ...]] = field(default_factory=dict)
    files: tuple[str, ...] = ()
    private_splits: tuple[str, ...] = ("test",)
    public_extra: Callable[[Path], list[str]] | None = None


@dataclass
class PartsReport:
    """What :func:`write_parts` wrote: folders, file counts and bytes, withheld paths."""

    public: Path
    private: Path
    public_files: int = 0
    private_files: int = 0
    public_bytes: int = 0
    private_bytes: int = 0
    withheld: list[str] = field(default_factory=list)


def read_info(root: str | os.PathLike) -> dict[str, Any]:
    """The ``dataset.json`` of ``root`` as a dict ({} when absent or unreadable)."""
    path = Path(root) / layout.DATASET_JSON
    try:
        data = parse_json_file(path)  # bounded; damage of any kind reads as "nothing said"
    except (OSError, InputError):
        return {}
    return data if isinstance(data, dict) else {}


def part_of(root: str | os.PathLike) -> str:
    """``"public"``, ``"private"`` or ``"full"`` (a folder that says nothing)."""
    part = read_info(root).get("part")
    if isinstance(part, dict) and part.get("part") in ("public", "private"):
        return str(part["part"])
    return "full"


def part_record(root: str | os.PathLike) -> dict[str, Any]:
    """The ``part`` record of ``dataset.json`` ({} for a full dataset)."""
    part = read_info(root).get("part")
    return dict(part) if isinstance(part, dict) else {}


def withheld_message(root: str | os.PathLike, what: str) -> str:
    """The one-line error for a file a public part does not carry."""
    rec = part_record(root)
    edition = f" of edition {rec['edition']}" if rec.get("edition") else ""
    return (f"{what} is withheld: {root} is the public part{edition}; scoring and ground "
            "truth need the private part (or the full data), e.g. 'dressmeup score ... "
            "--data PRIVATE'")


def _files(root: Path) -> list[str]:
    """Every regular file under ``root`` (relative POSIX paths, sorted; hidden names and
    links skipped)."""
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        for name in sorted(filenames):
            if name.startswith("."):
                continue
            p = Path(dirpath) / name
            if p.is_symlink() or not p.is_file():
                continue
            out.append(p.relative_to(root).as_posix())
    return sorted(out)


#: per-sample statistics files of a generator: their CPU-time entries are left out of the
#: parts (keys ending in these suffixes), so that two builds of the same data export the same
#: bytes
STATS_DIR = "generator/stats/"
VOLATILE_SUFFIXES = ("cpu_s", "wall_s", "seconds")


def _copy(src_root: Path, dst_root: Path, rels: Iterable[str]) -> tuple[int, int]:
    n = size = 0
    for rel in rels:
        src, dst = src_root / rel, dst_root / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        if rel.startswith(STATS_DIR) and rel.endswith(".json"):
            _copy_stats(src, dst)
        else:
            shutil.copyfile(src, dst)
        n += 1
        size += dst.stat().st_size
    return n, size


def _copy_stats(src: Path, dst: Path) -> None:
    """Copy a statistics JSON without its timing entries (:data:`VOLATILE_SUFFIXES`, at any
    depth)."""
    try:
        data = json.loads(src.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        shutil.copyfile(src, dst)
        return
    dst.write_text(json.dumps(_without_timings(data), indent=1, sort_keys=True) + "\n",
                   encoding="utf-8")


def _without_timings(data: Any) -> Any:
    """``data`` without the entries whose keys end in :data:`VOLATILE_SUFFIXES`, at any depth
    (generator 3.x records CPU seconds per stage)."""
    if isinstance(data, dict):
        return {k: _without_timings(v) for k, v in data.items()
                if not k.endswith(VOLATILE_SUFFIXES)}
    if isinstance(data, list):
        return [_without_timings(v) for v in data]
    return data


def _left_out(rows: list[dict[str, Any]], withheld: Withheld) -> set[str]:
    """The paths the public part leaves out: the withheld files and the files of every
    withheld field of a sample (a field not in :data:`FILE_FIELDS` is refused)."""
    gone = set(withheld.files)
    for r in rows:
        for f in withheld.fields.get(r["sample_id"], ()):
            if f not in FILE_FIELDS:
                raise InputError(f"withheld field {f!r} of {r['sample_id']}: expected one of "
                                 f"{FILE_FIELDS}")
            if r.get(f"{f}_path"):
                gone.add(r[f"{f}_path"])
    return gone


def write_parts(full_root: str | os.PathLike, withheld: Withheld,
                public_out: str | os.PathLike | None, private_out: str | os.PathLike | None,
                label: Mapping[str, Any] | None = None) -> PartsReport:
    """Write the public and/or private part of the full dataset at ``full_root``.

    Each part is built in a hidden sibling folder and renamed into place when complete
    (:func:`dressmeup.io.atomic.atomic_dir`), so an interrupted export leaves nothing
    half-written.

    Parameters
    ----------
    full_root : a full dataset folder (not itself a part).
    withheld : what the public part leaves out (:class:`Withheld`).
    public_out, private_out : the folders to write (None: skip that part); they must not
        exist or be empty.
    label : recorded in each part's ``dataset.json`` ``part`` record (e.g. the edition).

    Returns
    -------
    PartsReport

    Raises
    ------
    InputError
        ``full_root`` is a part already, has no manifest, a withheld sample is unknown, or an
        output folder is not empty.
    """
    root = Path(full_root)
    if part_of(root) != "full":
        raise InputError(f"{root} is the {part_of(root)} part of a dataset already; export "
                         "from the full data")
    if not (root / layout.MANIFEST).is_file():
        raise InputError(f"{root / layout.MANIFEST} not found: export needs a dataset root")
    rows = read_manifest(root / layout.MANIFEST).to_pylist()
    ids = {r["sample_id"] for r in rows}
    unknown = sorted(set(withheld.fields) - ids)
    if unknown:
        raise InputError(f"withheld samples not in {root}: {unknown[:5]}")
    for out in (public_out, private_out):
        if out is not None and Path(out).exists() and any(Path(out).iterdir()):
            raise InputError(f"{out} exists and is not empty: give a new folder for the part")
    gone = _left_out(rows, withheld)
    info = read_info(root)
    all_files = _files(root)
    missing = sorted(set(withheld.files) - set(all_files))
    if missing:
        raise InputError(f"withheld files not in {root}: {missing[:5]}")
    report = PartsReport(public=Path(public_out or ""), private=Path(private_out or ""),
                         withheld=sorted(gone))
    meta = {k: v for k, v in dict(label or {}).items() if v is not None}
    if public_out is not None:
        with atomic_dir(public_out) as tmp:
            keep = [f for f in all_files if f not in gone
                    and f not in (layout.MANIFEST, layout.DATASET_JSON)]
            report.public_files, report.public_bytes = _copy(root, tmp, keep)
            write_manifest(tmp / layout.MANIFEST, _public_rows(rows, withheld.fields),
                           public=True)
            extra = withheld.public_extra(tmp) if withheld.public_extra else []
            _write_info(tmp, info, {"part": "public", **meta, "extra_files": sorted(extra)})
            report.public_files += 2 + len(extra)
    if private_out is not None:
        splits = set(withheld.private_splits)
        carried = {r["sample_id"] for r in rows if r.get("split") in splits}
        keep = set(withheld.files)
        for r in rows:
            if r["sample_id"] in carried:
                keep |= {r[f"{f}_path"] for f in FILE_FIELDS if r.get(f"{f}_path")}
        with atomic_dir(private_out) as tmp:
            report.private_files, report.private_bytes = _copy(root, tmp, sorted(keep))
            shutil.copyfile(root / layout.MANIFEST, tmp / layout.MANIFEST)
            _write_info(tmp, info, {"part": "private", **meta,
                                    "splits": sorted(splits)})
            report.private_files += 2
    return report


#: ``dataset.json`` keys a part leaves out, with the entries ending in
#: :data:`VOLATILE_SUFFIXES` at any depth (generator 4's ``report.cpu_s``): how long the build
#: took is not part of the data (two builds of the same data export byte-identical parts)
VOLATILE_KEYS = ("timings",)


def _write_info(root: Path, info: dict[str, Any], part: dict[str, Any]) -> None:
    out = _without_timings({k: v for k, v in info.items() if k not in VOLATILE_KEYS})
    out["part"] = part
    atomic_write_text(root / layout.DATASET_JSON, json.dumps(out, indent=2) + "\n")


def _public_rows(rows: list[dict[str, Any]], fields: Mapping[str, tuple[str, ...]]
                 ) -> list[dict[str, Any]]:
    """Manifest rows with the withheld cells nulled and the ``withheld`` column filled."""
    out = []
    for r in rows:
        r = dict(r)
        gone = [f for f in FILE_FIELDS if f in fields.get(r["sample_id"], ())
                and r.get(f"{f}_path")]
        for f in gone:
            r[f"{f}_path"] = None
            r[HASH_OF[f"{f}_path"]] = None
            for c in _COUNTS.get(f, ()):
                r[c] = None
        r["withheld"] = ",".join(gone) or None
        out.append(r)
    return out


def withheld_fields(row: Mapping[str, Any]) -> tuple[str, ...]:
    """The withheld fields of a public manifest row (``()`` for a full one)."""
    w = row.get("withheld")
    if not isinstance(w, str) or not w:
        return ()
    return tuple(x for x in w.split(",") if x)
