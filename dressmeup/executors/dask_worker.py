"""What :class:`~dressmeup.executors.dask_executor.DaskExecutor` runs on its workers: each job
wrapped so that its exception comes back as a value, what a worker sees at the shared paths,
its environment variables, and the imports done in its main thread before any task.

Importable without Dask (only :func:`worker_plugin` needs it).
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import pickle
import socket
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["MAIN_THREAD_IMPORTS", "call_job", "existing_ancestor", "fingerprint", "see_paths",
           "worker_environ", "worker_plugin"]


def call_job(fn: Callable[[Any], Any], job: Any) -> tuple[bool, Any]:
    """Run ``fn(job)`` on a worker; return ``(True, result)`` or ``(False, exception)``.

    An exception that cannot be pickled is replaced by a ``RuntimeError`` carrying its type
    and message, so that it always reaches the client.
    """
    try:
        return True, fn(job)
    except Exception as exc:  # noqa: BLE001 - one failing item must not stop a run
        try:
            pickle.dumps(exc)
        except Exception:  # noqa: BLE001
            exc = RuntimeError(f"{type(exc).__name__}: {exc}")
        return False, exc


def fingerprint(path: str) -> str:
    """What a worker sees at ``path``: ``missing``, ``file:<size>`` or ``dir:<hash of the
    sorted names directly inside>`` (enough to tell two different folders apart cheaply)."""
    p = Path(path)
    if p.is_file():
        return f"file:{p.stat().st_size}"
    if p.is_dir():
        try:
            names = sorted(os.listdir(p))
        except OSError as exc:
            return f"unreadable:{exc.strerror}"
        return "dir:" + hashlib.sha256("\n".join(names).encode()).hexdigest()[:16]
    return "missing"


def worker_environ(names: Sequence[str]) -> dict[str, str | None]:
    """Run on every worker: the values of the environment variables ``names``."""
    return {k: os.environ.get(k) for k in names}


def existing_ancestor(path: str) -> str:
    """The nearest folder or file at or above ``path`` that exists (absolute)."""
    p = Path(path).absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return str(p)


def see_paths(read: Sequence[str], write: Sequence[str]) -> dict[str, Any]:
    """Run on every worker: the fingerprints of ``read`` paths and of the nearest existing
    ancestor of each ``write`` path, with whether that ancestor is writable."""
    return {"host": socket.gethostname(),
            "read": {p: fingerprint(p) for p in read},
            "write": {p: (fingerprint(existing_ancestor(p)),
                          os.access(existing_ancestor(p), os.W_OK)) for p in write}}


#: Imported in each worker's main thread before any task runs. Dask runs tasks in a thread
#: pool; pymeshlab imported first in such a thread after open3d has run there corrupts the
#: heap ("malloc_consolidate(): unaligned fastbin chunk detected", measured on the
#: fusion clean-up of build-dataset), while an import in the main thread first is safe.
MAIN_THREAD_IMPORTS = ("pymeshlab",)


def _main_thread_imports(modules: Sequence[str] = MAIN_THREAD_IMPORTS) -> list[str]:
    """Import ``modules`` (those installed) in the calling thread; return the imported ones."""
    done = []
    for name in modules:
        if importlib.util.find_spec(name) is not None:
            importlib.import_module(name)
            done.append(name)
    return done


def worker_plugin() -> Any:
    """A WorkerPlugin whose ``setup`` (run in the worker's main thread, also for workers
    that join or restart later) performs :data:`MAIN_THREAD_IMPORTS`."""
    # heavy: distributed (optional)
    from distributed import WorkerPlugin

    class MainThreadImports(WorkerPlugin):
        name = "dressmeup-main-thread-imports"

        def setup(self, worker: Any) -> None:
            _main_thread_imports()

    return MainThreadImports()
