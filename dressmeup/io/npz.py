"""Bounded, pickle-free reading of ``.npz`` and ``.npy`` files (submissions, body
parameters, keypoints, point scans).

``numpy.load`` decompresses an array before anyone can look at its shape: a 2 MB ``.npz``
of zeros can declare a 2.4 GB array. :func:`npz_arrays_info` reads only the zip directory
and the few header bytes of each member (the ``.npy`` header declares shape and dtype), so
:func:`load_npz` refuses too-large, object or unexpected arrays *before* decompressing
them, and a member whose stored size is not exactly its header plus the declared data (a
(3, 3) array followed by a gigabyte of zeros) or an archive of too many members
(``npz_members``) before anything is inflated. :func:`load_npy` does the same for one
``.npy``. Every kind of damage (truncated zip, bad CRC, a ``.npy`` renamed ``.npz``) is an
:class:`~dressmeup.errors.InputError` naming the file and the member; the bounds are
``array_bytes`` and ``npz_members`` of :mod:`dressmeup.limits`.
"""

from __future__ import annotations

import math
import os
import tokenize
import zipfile
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dressmeup.errors import InputError
from dressmeup.limits import ARRAY_BYTES, NPZ_MEMBERS, Limit, bounded_file

#: what numpy and zipfile raise on damaged files (numpy parses a header with the
#: tokenizer: SyntaxError, TokenError)
_DAMAGE = (zipfile.BadZipFile, zlib.error, EOFError, ValueError, OSError, KeyError,
           NotImplementedError, RuntimeError, SyntaxError, tokenize.TokenError)


@dataclass(frozen=True)
class ArrayInfo:
    """What a member's ``.npy`` header declares: ``shape``, ``dtype`` and ``nbytes``; and
    ``header_bytes``, the size of the header itself (magic included)."""

    shape: tuple[int, ...]
    dtype: np.dtype
    header_bytes: int = 0

    @property
    def nbytes(self) -> int:
        """Declared uncompressed size in bytes."""
        return int(math.prod(self.shape)) * int(self.dtype.itemsize)


def _read_header(fh) -> ArrayInfo:
    """The header of a ``.npy`` stream (``fh`` positioned at its start)."""
    version = np.lib.format.read_magic(fh)
    if version == (1, 0):
        shape, _fortran, dtype = np.lib.format.read_array_header_1_0(fh)
    elif version in ((2, 0), (3, 0)):
        shape, _fortran, dtype = np.lib.format.read_array_header_2_0(fh)
    else:  # pragma: no cover - numpy refuses unknown versions itself
        raise ValueError(f"unsupported .npy version {version}")
    return ArrayInfo(tuple(int(s) for s in shape), np.dtype(dtype), fh.tell())


def _damaged(path: Path, what: str, exc: BaseException, fix: str) -> InputError:
    kind = ("not a .npz (zip) archive" if isinstance(exc, zipfile.BadZipFile)
            else "damaged")
    return InputError(f"{what} {path}: {kind} ({type(exc).__name__}: {exc}); {fix}")


def npz_arrays_info(path: str | os.PathLike, what: str = "file") -> dict[str, ArrayInfo]:
    """Declared shape and dtype of every array in an ``.npz``, without decompressing data.

    Raises
    ------
    InputError
        Not a zip archive, a damaged one, more members than the ``npz_members`` limit, a
        member that is not a ``.npy`` array or whose stored size differs from its header
        plus the data it declares.
    """
    path = Path(path)
    out: dict[str, ArrayInfo] = {}
    try:
        with zipfile.ZipFile(path) as zf:
            members = zf.infolist()
            NPZ_MEMBERS.check(len(members), f"{what} {path}")
            for member in members:
                name = member.filename
                if not name.endswith(".npy"):
                    raise InputError(f"{what} {path}: member {name!r} is not a .npy array")
                with zf.open(member) as fh:
                    info = _read_header(fh)
                if not info.dtype.hasobject and \
                        member.file_size != info.header_bytes + info.nbytes:
                    raise InputError(
                        f"{what} {path}: member {name!r} stores {member.file_size} bytes but "
                        f"its header declares {info.header_bytes + info.nbytes} (shape "
                        f"{info.shape}, {info.dtype}): damaged or padded; re-write it with "
                        "numpy.savez")
                out[name[:-4]] = info
    except InputError:
        raise
    except FileNotFoundError:
        raise
    except _DAMAGE as exc:
        raise _damaged(path, what, exc, "re-write it with numpy.savez") from exc
    return out


def load_npy(path: str | os.PathLike, what: str = "file",
             max_bytes: int | None = None) -> np.ndarray:
    """Load one ``.npy`` array without pickle, after checking what its header declares.

    Parameters
    ----------
    path : the file.
    what : how messages name it (e.g. ``"scan"``).
    max_bytes : refuse a larger declared array (default: the ``array_bytes`` limit).

    Raises
    ------
    InputError
        Not a ``.npy`` file, damaged or truncated (its size differs from the header plus the
        declared data), an object array, or a declared size over the limit.
    """
    path = bounded_file(path, what)
    try:
        with open(path, "rb") as fh:
            info = _read_header(fh)
            if info.dtype.hasobject:
                raise InputError(f"{what} {path}: holds Python objects (pickle), which is "
                                 "never loaded; store a numeric array")
            ARRAY_BYTES.check(info.nbytes, f"{what} {path}", "declared array size",
                              limit=max_bytes)
            size = path.stat().st_size
            if size != info.header_bytes + info.nbytes:
                raise InputError(f"{what} {path}: {size} bytes, but its header declares "
                                 f"{info.header_bytes + info.nbytes} (shape {info.shape}, "
                                 f"{info.dtype}): truncated or damaged")
            fh.seek(0)
            return np.load(fh, allow_pickle=False)
    except InputError:
        raise
    except _DAMAGE as exc:
        raise InputError(f"{what} {path}: not a readable .npy array ({type(exc).__name__}: "
                         f"{exc}); write it with numpy.save") from exc


def load_npz(path: str | os.PathLike, what: str = "file",
             max_bytes: int | None = None,
             expect: Mapping[str, tuple[str, ...]] | None = None,
             limit: Limit = ARRAY_BYTES) -> dict[str, np.ndarray]:
    """Load every array of an ``.npz`` without pickle, after checking its declared sizes.

    Parameters
    ----------
    path : the file.
    what : how messages name it (e.g. ``"body file"``, ``"prediction"``).
    max_bytes : refuse when the arrays together declare more than this (uncompressed;
        default: the ``array_bytes`` limit).
    expect : optional ``name -> allowed dtype kinds`` (e.g. ``{"vertices": ("f",)}``): a
        listed array with another dtype kind is refused before it is read.
    limit : the limit of :mod:`dressmeup.limits` that bounds the declared size (named in
        the error; ``prediction_bytes`` for submissions).

    Returns
    -------
    dict name -> ndarray.

    Raises
    ------
    InputError
        Damaged file, object arrays, a declared size over the limit, too many members, or a
        dtype outside ``expect``.
    """
    path = bounded_file(path, what)
    info = npz_arrays_info(path, what)
    for name, a in info.items():
        if a.dtype.hasobject:
            raise InputError(f"{what} {path}: array {name!r} holds Python objects (pickle), "
                             "which is never loaded; store numeric arrays")
        if expect and name in expect and a.dtype.kind not in expect[name]:
            raise InputError(f"{what} {path}: array {name!r} has dtype {a.dtype}, expected "
                             f"kind {'/'.join(expect[name])}")
    limit.check(sum(a.nbytes for a in info.values()), f"{what} {path}",
                "declared array size", limit=max_bytes)
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except _DAMAGE as exc:
        raise _damaged(path, what, exc, "re-write it with numpy.savez") from exc
