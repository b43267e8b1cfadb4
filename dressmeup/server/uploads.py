"""Uploads: streamed to disk under a size limit, unpacked safely, validated.

A submission arrives as one archive (``.zip`` or ``.tar.gz``) of a submission folder
(``submission.json`` and one file per item, at the top or in one top folder). The upload is
written in chunks and refused as soon as it passes the limit (``413``); the archive is
unpacked member by member into a new folder: only regular files, no path outside the
folder, no links or devices, at most ``max_members`` members and ``max_unpacked_mb`` in all
(counted while writing, so a member lying about its size is caught), then the toolkit's
validator (:func:`dressmeup.bench.scoring.validate.validate_submission`) lists every problem.
"""

from __future__ import annotations

import hashlib
import shutil
import tarfile
import zipfile
from collections.abc import AsyncIterator
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from dressmeup.errors import InputError

CHUNK = 1 << 20


class TooLarge(InputError):
    """An upload or an unpacked submission beyond the server's limits."""


@dataclass
class Upload:
    """A received archive: its path, size and sha256."""

    path: Path
    size: int
    sha256: str


async def receive(chunks: AsyncIterator[bytes], dest: Path, max_bytes: int) -> Upload:
    """Write the chunks of a request body to ``dest``, refusing beyond ``max_bytes``.

    Raises
    ------
    TooLarge
        The body passed the limit (the partial file is removed).
    """
    h = hashlib.sha256()
    size = 0
    dest.parent.mkdir(parents=True, exist_ok=True)
    try:
        with open(dest, "wb") as fh:
            async for chunk in chunks:
                size += len(chunk)
                if size > max_bytes:
                    raise TooLarge(f"the upload is larger than the server's limit of "
                                   f"{max_bytes >> 20} MB")
                h.update(chunk)
                fh.write(chunk)
    except BaseException:
        dest.unlink(missing_ok=True)
        raise
    if size == 0:
        dest.unlink(missing_ok=True)
        raise InputError("the upload is empty: send the submission archive as the body")
    return Upload(dest, size, h.hexdigest())


def _safe_name(name: str) -> PurePosixPath:
    p = PurePosixPath(name.replace("\\", "/"))
    if not name or p.is_absolute() or ".." in p.parts or name.startswith(("/", "\\")):
        raise InputError(f"archive member {name!r} would leave the submission folder; refused")
    return p


def _members(archive: Path) -> list[tuple[str, int, object]]:
    """``(name, declared size, handle)`` of every member (directories dropped), refusing
    links, devices and anything but regular files."""
    out = []
    if zipfile.is_zipfile(archive):
        zf = zipfile.ZipFile(archive)
        for info in zf.infolist():
            if info.is_dir():
                continue
            mode = (info.external_attr >> 16) & 0o170000
            if mode and mode != 0o100000:
                raise InputError(f"archive member {info.filename!r} is not a regular file "
                                 "(links and devices are refused)")
            out.append((info.filename, info.file_size, (zf, info)))
        return out
    try:
        tf = tarfile.open(archive, mode="r:*")
    except (tarfile.TarError, OSError) as exc:
        raise InputError("the upload is neither a zip nor a tar(.gz) archive: send the "
                         "submission folder packed as one") from exc
    for m in tf:
        if m.isdir():
            continue
        if not m.isreg():
            raise InputError(f"archive member {m.name!r} is not a regular file (links and "
                             "devices are refused)")
        out.append((m.name, m.size, (tf, m)))
    return out


def _open(handle: object):
    owner, member = handle
    if isinstance(owner, zipfile.ZipFile):
        return owner.open(member)
    return owner.extractfile(member)


def unpack(archive: Path, dest: Path, max_members: int, max_bytes: int) -> Path:
    """Unpack a submission archive into the new folder ``dest`` (a single top folder is
    stripped) and return it.

    Raises
    ------
    InputError
        An unsafe member, too many members, a total beyond ``max_bytes``, or a damaged
        archive; ``dest`` is removed then.
    """
    try:
        members = _members(archive)
        if len(members) > max_members:
            raise TooLarge(f"the archive has {len(members)} files; the server accepts at most "
                           f"{max_members}")
        if not members:
            raise InputError("the archive holds no files")
        names = [_safe_name(n) for n, _, _ in members]
        tops = {p.parts[0] for p in names}
        strip = len(tops) == 1 and all(len(p.parts) > 1 for p in names)
        if sum(size for _, size, _ in members) > max_bytes:
            raise TooLarge(f"the archive unpacks to more than {max_bytes >> 20} MB")
        dest.mkdir(parents=True)
        total = 0
        for (name, _size, handle), p in zip(members, names, strict=True):
            rel = PurePosixPath(*p.parts[1:]) if strip else p
            if any(part.startswith(".") for part in rel.parts) or len(rel.parts) > 8:
                raise InputError(f"archive member {name!r}: hidden or too deeply nested")
            target = dest.joinpath(*rel.parts)
            target.parent.mkdir(parents=True, exist_ok=True)
            with _open(handle) as src, open(target, "wb") as out:
                while block := src.read(CHUNK):
                    total += len(block)
                    if total > max_bytes:
                        raise TooLarge(f"the archive unpacks to more than {max_bytes >> 20} "
                                       "MB (a member is larger than it declares)")
                    out.write(block)
        return dest
    except (zipfile.BadZipFile, tarfile.TarError, EOFError, OSError, ValueError) as exc:
        shutil.rmtree(dest, ignore_errors=True)
        if isinstance(exc, InputError):
            raise
        raise InputError(f"the archive cannot be read ({type(exc).__name__}: {exc})") from exc
    except BaseException:
        shutil.rmtree(dest, ignore_errors=True)
        raise
