"""Moving bytes for the archives of :mod:`dressmeup.bench.archives.archive`: a small file read from a
URL or a path within the ``json_bytes`` bound, and a large one downloaded (HTTP range
requests, retries) or copied, resuming what an earlier run left.
"""

from __future__ import annotations

import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from dressmeup.errors import InputError
from dressmeup.limits import JSON_BYTES
from dressmeup.progress import progress

__all__ = ["CHUNK", "blocks", "copy_resumable", "download", "is_url", "join_source",
           "read_small"]

#: Bytes read and written at a time.
CHUNK = 1 << 20


def is_url(source: str) -> bool:
    """Whether ``source`` is an http(s) URL (else a path)."""
    return urllib.parse.urlparse(source).scheme in ("http", "https")


def join_source(source: str, name: str) -> str:
    """``name`` inside ``source`` (a base URL or a folder)."""
    return source.rstrip("/") + "/" + name if is_url(source) else str(Path(source) / name)


def read_small(source: str) -> bytes:
    """The bytes of a small file at a URL or path (refused beyond the ``json_bytes``
    limit)."""
    max_bytes = JSON_BYTES.value()
    if is_url(source):
        try:
            with urllib.request.urlopen(source, timeout=60) as r:
                data = r.read(max_bytes + 1)
        except (urllib.error.URLError, OSError) as exc:
            raise InputError(f"cannot read {source}: {exc}") from exc
    else:
        p = Path(source)
        if not p.is_file():
            raise InputError(f"{p} not found")
        with open(p, "rb") as fh:
            data = fh.read(max_bytes + 1)
    JSON_BYTES.check(len(data), source, "index size (read so far)")
    return data


def download(url: str, dest: Path, size: int, retries: int = 3) -> None:
    """Download ``url`` to ``dest``, resuming what ``dest`` holds with a range request."""
    for attempt in range(retries + 1):
        have = dest.stat().st_size if dest.exists() else 0
        if have >= size:
            return
        req = urllib.request.Request(url, headers={"Range": f"bytes={have}-"} if have else {})
        try:
            with urllib.request.urlopen(req, timeout=60) as r:
                mode = "ab" if have and r.status == 206 else "wb"
                done = have if mode == "ab" else 0
                with open(dest, mode) as fh:
                    for block in progress(blocks(r), desc=f"downloading {dest.name[:-5]}",
                                          total=max(1, (size - done) // CHUNK)):
                        fh.write(block)
            if dest.stat().st_size < size:  # the server closed the connection early
                raise ConnectionError(f"{dest.stat().st_size} of {size} bytes received")
            return
        except (urllib.error.URLError, OSError, ConnectionError) as exc:
            if attempt == retries:
                raise InputError(f"download of {url} failed after {retries + 1} tries "
                                 f"({exc}); run the same command again to resume") from exc
            time.sleep(min(2.0 ** attempt, 10.0))


def blocks(stream: Any) -> Iterator[bytes]:
    """The bytes of a binary stream in blocks of :data:`CHUNK`."""
    while block := stream.read(CHUNK):
        yield block


def copy_resumable(src: Path, dest: Path) -> None:
    """Copy ``src`` to ``dest``, appending to what ``dest`` already holds."""
    if not src.is_file():
        raise InputError(f"{src} not found")
    have = dest.stat().st_size if dest.exists() else 0
    with open(src, "rb") as fin, open(dest, "ab" if have else "wb") as fout:
        fin.seek(have)
        total = max(1, (src.stat().st_size - have) // CHUNK)
        for block in progress(blocks(fin), desc=f"copying {src.name}", total=total):
            fout.write(block)
