"""Bounded, pickle-free reading of ``.npz`` files (submissions, body parameters, keypoints).

``numpy.load`` decompresses an array before anyone can look at its shape: a 2 MB ``.npz``
of zeros can declare a 2.4 GB array. :func:`npz_arrays_info` reads only the zip directory
and the few header bytes of each member (the ``.npy`` header declares shape and dtype), so
:func:`load_npz` refuses too-large, object or unexpected arrays *before* decompressing
them, and turns every kind of damage (truncated zip, bad CRC, a ``.npy`` renamed ``.npz``)
into an :class:`~dressmeup.errors.InputError` naming the file and the member.
"""

from __future__ import annotations

import math
import os
import zipfile
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dressmeup.errors import InputError

#: Default bound on the total declared (uncompressed) size of all arrays of one file.
DEFAULT_MAX_BYTES = 1 << 30

_DAMAGE = (zipfile.BadZipFile, zlib.error, EOFError, ValueError, OSError, KeyError,
           NotImplementedError, RuntimeError)


@dataclass(frozen=True)
class ArrayInfo:
    """What a member's ``.npy`` header declares: ``shape``, ``dtype`` and ``nbytes``."""

    shape: tuple[int, ...]
    dtype: np.dtype

    @property
    def nbytes(self) -> int:
        """Declared uncompressed size in bytes."""
        return int(math.prod(self.shape)) * int(self.dtype.itemsize)


def npz_arrays_info(path: str | os.PathLike, what: str = "file") -> dict[str, ArrayInfo]:
    """Declared shape and dtype of every array in an ``.npz``, without decompressing data.

    Raises
    ------
    InputError
        Not a zip archive, a damaged one, or a member that is not a ``.npy`` array.
    """
    path = Path(path)
    out: dict[str, ArrayInfo] = {}
    try:
        with zipfile.ZipFile(path) as zf:
            for member in zf.infolist():
                name = member.filename
                if not name.endswith(".npy"):
                    raise InputError(f"{what} {path}: member {name!r} is not a .npy array")
                with zf.open(member) as fh:
                    version = np.lib.format.read_magic(fh)
                    if version == (1, 0):
                        shape, _fortran, dtype = np.lib.format.read_array_header_1_0(fh)
                    elif version in ((2, 0), (3, 0)):
                        shape, _fortran, dtype = np.lib.format.read_array_header_2_0(fh)
                    else:  # pragma: no cover - numpy refuses unknown versions itself
                        raise ValueError(f"unsupported .npy version {version}")
                out[name[:-4]] = ArrayInfo(tuple(int(s) for s in shape), np.dtype(dtype))
    except InputError:
        raise
    except FileNotFoundError:
        raise
    except _DAMAGE as exc:
        kind = ("not a .npz (zip) archive" if isinstance(exc, zipfile.BadZipFile)
                else "damaged")
        raise InputError(f"{what} {path}: {kind} ({type(exc).__name__}: {exc}); "
                         "re-write it with numpy.savez") from exc
    return out


def load_npz(path: str | os.PathLike, what: str = "file",
             max_bytes: int = DEFAULT_MAX_BYTES,
             expect: Mapping[str, tuple[str, ...]] | None = None) -> dict[str, np.ndarray]:
    """Load every array of an ``.npz`` without pickle, after checking its declared sizes.

    Parameters
    ----------
    path : the file.
    what : how messages name it (e.g. ``"body file"``, ``"prediction"``).
    max_bytes : refuse when the arrays together declare more than this (uncompressed).
    expect : optional ``name -> allowed dtype kinds`` (e.g. ``{"vertices": ("f",)}``): a
        listed array with another dtype kind is refused before it is read.

    Returns
    -------
    dict name -> ndarray.

    Raises
    ------
    InputError
        Damaged file, object arrays, a declared size over ``max_bytes``, or a dtype outside
        ``expect``.
    """
    path = Path(path)
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(2, "No such file or directory", str(path))
        raise InputError(f"{what} {path}: not a regular file")
    info = npz_arrays_info(path, what)
    for name, a in info.items():
        if a.dtype.hasobject:
            raise InputError(f"{what} {path}: array {name!r} holds Python objects (pickle), "
                             "which is never loaded; store numeric arrays")
        if expect and name in expect and a.dtype.kind not in expect[name]:
            raise InputError(f"{what} {path}: array {name!r} has dtype {a.dtype}, expected "
                             f"kind {'/'.join(expect[name])}")
    total = sum(a.nbytes for a in info.values())
    if total > max_bytes:
        raise InputError(f"{what} {path}: arrays declare {total / 1e6:.1f} MB uncompressed, "
                         f"over the limit of {max_bytes / 1e6:.1f} MB")
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except _DAMAGE as exc:
        raise InputError(f"{what} {path}: damaged ({type(exc).__name__}: {exc}); "
                         "re-write it with numpy.savez") from exc
