"""Atomic file writes: write to a temporary file beside the target, then rename.

A reader never sees a half-written file, and an interrupted job leaves the old file (or no
file) in place, never a truncated one. Files end up with the mode an ordinary ``open`` would
give them (``0o666`` minus the umask: 0644 under umask 022), not mkstemp's owner-only 0600.
Whole folders (submissions, results) are built in a hidden sibling by :func:`atomic_dir` and
renamed into place at the end, so a killed run leaves no half-written folder.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    The temporary file keeps the target's suffix (or ``suffix``) so that writers that pick a
    format from the extension (trimesh, PIL, pyarrow) still work. On error the temporary file
    is removed and ``path`` is left untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    sfx = suffix if suffix is not None else "".join(path.suffixes)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{sfx}", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~current_umask())
    finally:
        os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        with open(tmp_path, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp_path, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise


def current_umask() -> int:
    """The process umask, read without changing it where the OS allows (Linux ``/proc``)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # elsewhere: set and restore (not thread-safe, but brief)
    os.umask(mask)
    return mask


_TEMP_RE = re.compile(r"^\..+\.tmp(\.[^/]*)?$")


def is_temp_file(path: str | os.PathLike) -> bool:
    """True for the hidden temporary file of an atomic write (``.<stem>.<random>.tmp<ext>``),
    e.g. one left by a killed process."""
    path = Path(path)
    return bool(_TEMP_RE.match(path.name)) and path.is_file()


def only_temp_files(folder: str | os.PathLike) -> bool:
    """True when ``folder`` holds nothing but leftover temporary files (or nothing)."""
    return all(is_temp_file(p) for p in Path(folder).iterdir())


_PARTIAL_RE = re.compile(r"^\.(?P<name>.+)\.partial-(?P<pid>\d+)-[A-Za-z0-9_]+$")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_partials(path: str | os.PathLike) -> list[Path]:
    """Remove hidden ``.<name>.partial-<pid>-*`` siblings of ``path`` whose writer is dead.

    Returns the folders removed. Partial folders of live processes are left alone.
    """
    path = Path(path)
    removed: list[Path] = []
    if not path.parent.is_dir():
        return removed
    for entry in path.parent.iterdir():
        m = _PARTIAL_RE.match(entry.name)
        if m and m["name"] == path.name and not _pid_alive(int(m["pid"])):
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


@contextlib.contextmanager
def atomic_dir(path: str | os.PathLike, merge: bool = False) -> Iterator[Path]:
    """Yield a hidden sibling folder to fill; on success move it into place as ``path``.

    Parameters
    ----------
    path : the folder to create. Unless ``merge``, it must not exist or be empty (the caller
        checks with its own message); an empty folder is replaced.
    merge : when ``path`` already holds files, move the new files into it one by one
        (each an atomic rename; files of the same name are replaced) instead of renaming the
        whole folder.

    On error (or a kill) ``path`` is untouched: the sibling is removed on errors, and a sibling
    left by a killed process is removed by the next :func:`atomic_dir` on the same path.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_partials(path)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.partial-{os.getpid()}-",
                                dir=path.parent))
    os.chmod(tmp, 0o777 & ~current_umask())
    try:
        yield tmp
        if path.is_dir() and not only_temp_files(path):
            if not merge:
                raise FileExistsError(f"{path} is not empty")
            names = sorted(p.name for p in tmp.iterdir())
            # metadata files (*.json) last, so that a reader sees them only when all is there
            for name in sorted(names, key=lambda n: n.endswith(".json")):
                dest = path / name
                if dest.is_dir() and not dest.is_symlink():
                    shutil.rmtree(dest)
                os.replace(tmp / name, dest)
            tmp.rmdir()
        else:
            if path.is_dir():  # empty, or only temporary files of an interrupted write
                for p in path.iterdir():
                    p.unlink()
                path.rmdir()
            os.replace(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))
