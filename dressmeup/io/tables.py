"""Bounded reading of Parquet tables (dataset manifests, per-item result tables).

A Parquet file's footer declares its row count and the uncompressed size of its row groups;
a 195 KB manifest of two million identical rows inflates to hundreds of megabytes of Python
objects in the readers that walk it. :func:`read_table` reads the footer first and refuses
more rows than the ``table_rows`` limit or more uncompressed data than ``array_bytes``
(:mod:`dressmeup.limits`); every kind of damage (random bytes, a truncated file, a folder)
is an :class:`~dressmeup.errors.InputError` naming the file.
"""

from __future__ import annotations

import os
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from dressmeup.errors import InputError
from dressmeup.limits import ARRAY_BYTES, TABLE_ROWS, bounded_file


def _damaged(path: Path, what: str, exc: Exception) -> InputError:
    return InputError(f"{what} {path}: not a readable Parquet table ({type(exc).__name__}: "
                      f"{exc}); the file is damaged or truncated: write it again")


def table_size(path: str | os.PathLike, what: str = "table") -> tuple[int, int]:
    """(rows, uncompressed bytes) that the file's footer declares, checked against the
    ``table_rows`` and ``array_bytes`` limits.

    Raises
    ------
    FileNotFoundError, InputError
    """
    path = bounded_file(path, what)
    try:
        meta = pq.ParquetFile(path).metadata
        rows = int(meta.num_rows)
        size = sum(int(meta.row_group(i).total_byte_size) for i in range(meta.num_row_groups))
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise _damaged(path, what, exc) from exc
    TABLE_ROWS.check(rows, f"{what} {path}", "rows")
    ARRAY_BYTES.check(size, f"{what} {path}", "declared table size (uncompressed)")
    return rows, size


def read_table(path: str | os.PathLike, what: str = "table",
               columns: list[str] | None = None) -> pa.Table:
    """Read a Parquet table after :func:`table_size`'s checks.

    Raises
    ------
    FileNotFoundError, InputError
    """
    path = Path(path)
    table_size(path, what)
    try:
        return pq.read_table(path, columns=columns)
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise _damaged(path, what, exc) from exc


def read_frame(path: str | os.PathLike, what: str = "table"):
    """:func:`read_table` as a pandas DataFrame.

    Raises
    ------
    FileNotFoundError, InputError
    """
    table = read_table(path, what)
    try:
        return table.to_pandas()
    except (pa.ArrowException, ValueError, TypeError) as exc:
        raise _damaged(Path(path), what, exc) from exc
