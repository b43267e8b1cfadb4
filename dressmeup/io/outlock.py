"""One writer per output: an advisory lock beside the file or folder a command writes.

Two runs writing into one folder (two ``report --out site`` at once, two ``build-dataset``
resuming the same dataset, two ``edition create`` of one file) must not both succeed
silently with a mixed result. :func:`output_lock` takes an exclusive ``flock`` on a hidden
``.<name>.lock`` beside the output before anything is written and releases it at the end;
a second writer fails at once with an :class:`~dressmeup.errors.InputError` naming the
output and the process that holds it. The lock is re-entrant within one process (a command
and the library call it makes may both take it) and dies with its process: the kernel drops
the ``flock`` of a killed run, so its left-over lock file obstructs nobody; the next writer
of that output takes the file over (writing its own process id) and removes it at its end.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from collections.abc import Iterator
from pathlib import Path

from dressmeup.errors import InputError

_HELD: dict[str, int] = {}


def lock_path(path: str | os.PathLike) -> Path:
    """The lock file of output ``path``: ``.<name>.lock`` in the same folder."""
    path = Path(os.path.abspath(path))
    return path.parent / f".{path.name}.lock"


def _acquire(lock: Path, target: Path, what: str) -> int:
    for _ in range(5):
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?"
            os.close(fd)
            raise InputError(f"{what} {target} is being written by another dressmeup run "
                             f"(process {holder}); wait for it to finish or choose another "
                             "output") from None
        try:  # the file we locked is still the one at `lock` (a releasing writer unlinks it)
            same = os.fstat(fd).st_ino == os.stat(lock).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.pwrite(fd, str(os.getpid()).encode(), 0)
            return fd
        os.close(fd)
    raise InputError(f"{what} {target}: could not take its lock {lock}")


@contextlib.contextmanager
def output_lock(path: str | os.PathLike, what: str = "output") -> Iterator[Path]:
    """Hold the exclusive lock of output ``path`` (file or folder) while the block runs.

    Parameters
    ----------
    path : the output file or folder (it need not exist; its parent is created).
    what : how the message names it (``"--out"``).

    Yields
    ------
    ``path``.

    Raises
    ------
    InputError
        Another process holds the lock.
    """
    target = Path(path)
    key = os.path.abspath(target)
    if key in _HELD:
        _HELD[key] += 1
        try:
            yield target
        finally:  # the outer holder may have ended first (an abandoned inner one)
            if key in _HELD:
                _HELD[key] -= 1
        return
    lock = lock_path(target)
    lock.parent.mkdir(parents=True, exist_ok=True)
    fd = _acquire(lock, target, what)
    _HELD[key] = 1
    try:
        yield target
    finally:
        del _HELD[key]
        with contextlib.suppress(FileNotFoundError):
            if os.fstat(fd).st_ino == os.stat(lock).st_ino:
                lock.unlink()
        os.close(fd)
