"""The Parquet manifest: one row per sample, a versioned schema (docs/dataset-format.md).

The schema version is stored in the Parquet key-value metadata under
``dressmeup.manifest_version``; readers refuse newer major versions with a clear message.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_path

MANIFEST_VERSION = "1.0"
#: the manifest of a public part (:mod:`dressmeup.data.parts`): version 1.0 plus the column
#: ``withheld``; the garment's path and sha256 may then be null where it is withheld
PUBLIC_MANIFEST_VERSION = "1.1"
VERSION_KEY = b"dressmeup.manifest_version"

#: The columns of manifest version 1.0, in order: (name, arrow type, nullable, description).
COLUMNS: list[tuple[str, pa.DataType, bool, str]] = [
    ("sample_id", pa.string(), False, "unique id, letters/digits/-/_ (e.g. S01-G03-P2)"),
    ("subject_id", pa.string(), False, "the person wearing the garment"),
    ("garment_id", pa.string(), False, "the physical garment (unique in the dataset)"),
    ("pose_id", pa.string(), False, "the pose of this capture (unique per garment)"),
    ("category", pa.string(), False, "topwear, bottomwear, dress, ..."),
    ("garment_type", pa.string(), False, "t-shirt, long-sleeve, shorts, trousers, skirt, ..."),
    ("split", pa.string(), False, "train, val or test (split by garment)"),
    ("garment_path", pa.string(), False, "relative path of the garment mesh"),
    ("texture_path", pa.string(), True, "relative path of the garment texture (PNG) or null"),
    ("scan_path", pa.string(), True, "relative path of the clothed scan mesh or null"),
    ("body_path", pa.string(), True, "relative path of the body parameters (.npz) or null"),
    ("garment_vertices", pa.int64(), False, "vertex count of the garment mesh"),
    ("garment_faces", pa.int64(), False, "triangle count of the garment mesh"),
    ("scan_vertices", pa.int64(), True, "vertex count of the scan, null without scan"),
    ("scan_faces", pa.int64(), True, "triangle count of the scan, null without scan"),
    ("garment_sha256", pa.string(), False, "sha256 (hex) of the garment file"),
    ("texture_sha256", pa.string(), True, "sha256 of the texture file or null"),
    ("scan_sha256", pa.string(), True, "sha256 of the scan file or null"),
    ("body_sha256", pa.string(), True, "sha256 of the body file or null"),
    ("topology_shared", pa.bool_(), False,
     "true when all poses of this garment share vertex count and faces (ED is defined)"),
]

#: the extra column of a public part's manifest (version 1.1)
WITHHELD_COLUMN = ("withheld", pa.string(), True,
                   "comma-separated file fields withheld from this public part (garment, "
                   "texture, scan, body), or null")
PATH_COLUMNS = ("garment_path", "texture_path", "scan_path", "body_path")
HASH_OF = {"garment_path": "garment_sha256", "texture_path": "texture_sha256",
           "scan_path": "scan_sha256", "body_path": "body_sha256"}


def columns(public: bool = False) -> list[tuple[str, pa.DataType, bool, str]]:
    """The columns of a manifest: :data:`COLUMNS`, or those of a public part (the garment's
    path and sha256 nullable, plus :data:`WITHHELD_COLUMN`)."""
    if not public:
        return list(COLUMNS)
    loose = {"garment_path", "garment_sha256"}
    return [(n, t, nl or n in loose, d) for n, t, nl, d in COLUMNS] + [WITHHELD_COLUMN]


def schema(public: bool = False) -> pa.Schema:
    """The Arrow schema of the current manifest version (with the version in its metadata);
    ``public``: the schema of a public part's manifest (version 1.1)."""
    fields = [pa.field(n, t, nullable=nl, metadata={b"description": d.encode()})
              for n, t, nl, d in columns(public)]
    version = PUBLIC_MANIFEST_VERSION if public else MANIFEST_VERSION
    return pa.schema(fields, metadata={VERSION_KEY: version.encode()})


def rows_to_table(rows: list[dict[str, Any]], public: bool = False) -> pa.Table:
    """Build a manifest table from row dicts (missing nullable fields become null).

    Raises
    ------
    InputError
        When a non-nullable field is missing from a row (in a public part: unless the row's
        ``withheld`` names that file).
    """
    sch = schema(public)
    cols_ = columns(public)
    cols: dict[str, list] = {n: [] for n, *_ in cols_}
    for i, row in enumerate(rows):
        for n, _t, nullable, _d in cols_:
            v = row.get(n)
            if v is None and not nullable:
                raise InputError(f"manifest row {i} ({row.get('sample_id')!r}): field {n!r} is required")
            cols[n].append(v)
        if public and row.get("garment_path") is None \
                and "garment" not in str(row.get("withheld") or "").split(","):
            raise InputError(f"manifest row {i} ({row.get('sample_id')!r}): garment_path is "
                             "required unless the garment is withheld")
    return pa.table(cols, schema=sch)


def write_manifest(path: str | os.PathLike, rows: list[dict[str, Any]],
                   public: bool = False) -> None:
    """Write the manifest rows to ``path`` atomically (temp file + rename); ``public``: the
    manifest of a public part (:func:`schema`)."""
    table = rows_to_table(rows, public)
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)


def read_manifest(path: str | os.PathLike) -> pa.Table:
    """Read a manifest and check its schema version.

    Raises
    ------
    InputError
        When the file is unreadable (e.g. truncated), of a newer major version, or lacks
        required columns.
    """
    path = Path(path)
    try:
        table = pq.read_table(path)
    except FileNotFoundError:
        raise
    except Exception as exc:  # pyarrow raises ArrowInvalid / OSError on damaged files
        raise InputError(f"{path}: cannot read the Parquet manifest ({exc}); "
                         "the file is damaged or truncated: rebuild it") from exc
    meta = table.schema.metadata or {}
    version = meta.get(VERSION_KEY, b"").decode() or "unknown"
    if version != "unknown" and version.split(".")[0] != MANIFEST_VERSION.split(".")[0]:
        raise InputError(f"{path}: manifest version {version} is not supported by this toolkit "
                         f"(reads {MANIFEST_VERSION}); upgrade dressmeup")
    missing = [n for n, _t, nl, _d in COLUMNS if not nl and n not in table.column_names]
    if missing:
        raise InputError(f"{path}: manifest lacks required columns {missing}")
    for name, typ, _nl, _d in COLUMNS:
        if name in table.column_names:
            got = table.schema.field(name).type
            numeric = pa.types.is_integer(typ) or pa.types.is_floating(typ)
            if (numeric and not (pa.types.is_integer(got) or pa.types.is_floating(got))) or \
                    (pa.types.is_string(typ) and not (pa.types.is_string(got)
                                                      or pa.types.is_large_string(got)
                                                      or pa.types.is_null(got))):
                raise InputError(f"{path}: manifest column {name!r} has type {got}, "
                                 f"expected {typ}")
    return table
