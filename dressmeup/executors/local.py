"""`LocalExecutor`: a process pool on this machine whose workers die with their parent.

Without care, ``kill -9`` of a command that runs a ``ProcessPoolExecutor`` leaves its worker
processes (and, through them, multiprocessing's resource tracker) running: nobody tells them
the parent is gone. Every worker therefore arms a parent-death watchdog when it starts
(:func:`die_with_parent`): on Linux the kernel sends it SIGKILL when the parent dies
(``prctl(PR_SET_PDEATHSIG)``); elsewhere a daemon thread polls the parent's pid. Once the
workers are gone the resource tracker sees its pipe close and exits by itself.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>


def die_with_parent(parent_pid: int, poll_s: float = 0.5) -> str:
    """Make this process exit as soon as ``parent_pid`` (its parent) dies.

    Parameters
    ----------
    parent_pid : pid of the process that started this one (passed from the parent, so that
        a parent which died before this call is noticed too).
    poll_s : polling period of the fallback watchdog thread, in seconds.

    Returns
    -------
    ``"prctl"`` (Linux: the kernel kills this process with SIGKILL when the parent thread
    exits), ``"thread"`` (elsewhere: a daemon thread checks ``os.getppid()``) or
    ``"orphan"`` (the parent was already gone: the process exits before returning).

    Notes
    -----
    ``PR_SET_PDEATHSIG`` fires when the *thread* that forked this process exits; the local
    pool starts its workers from the thread that calls ``run``, which outlives them.
    """
    how = "thread"
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0:
                how = "prctl"
        except (OSError, AttributeError):  # no libc prctl: fall back to the thread
            how = "thread"
    if os.getppid() != parent_pid:  # the parent died before the watchdog was armed
        os._exit(1)
    if how == "thread":
        def watch() -> None:
            while os.getppid() == parent_pid:
                time.sleep(poll_s)
            os._exit(1)

        threading.Thread(target=watch, name="dressmeup-parent-watchdog", daemon=True).start()
    return how


def single_threaded() -> None:
    """Keep this process's numeric libraries to one thread: the pool already uses every
    core (BLAS/OpenMP read the variables at import; torch, if already imported, is told)."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    try:
        if "torch" in sys.modules:
            sys.modules["torch"].set_num_threads(1)
    except Exception:  # noqa: BLE001 - best effort only
        pass


def _init_worker(parent_pid: int | None = None) -> None:
    """Pool worker initializer: die with the parent, stay single-threaded."""
    if parent_pid is not None:
        die_with_parent(parent_pid)
    single_threaded()


class LocalExecutor:
    """A process pool on the local cores (``spawn`` start method: safe with torch/open3d).

    Parameters
    ----------
    workers : number of worker processes; default ``os.cpu_count()``. With 1 the jobs run
        in the calling process (no pool start-up; easiest to debug).
    max_pending : jobs in flight at once per worker (bounds memory of queued results).
    keep_pool : keep the worker processes between :meth:`run` calls (many short runs, e.g.
        scoring one submission after another, start them once) until :meth:`close` or the
        end of a ``with`` block; a pool a dead worker broke is started again on the next
        run. False: each run starts its own pool and ends it.

    Workers die with the calling process (:func:`die_with_parent`), so a killed command
    leaves no orphans behind.
    """

    name = "local"

    def __init__(self, workers: int | None = None, max_pending: int = 2,
                 keep_pool: bool = False) -> None:
        if workers is not None and (not isinstance(workers, int) or workers < 1):
            raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
        self.workers = workers or (os.cpu_count() or 1)
        self.max_pending = max(1, int(max_pending))
        self.keep_pool = bool(keep_pool)
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> LocalExecutor:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        """End the kept worker processes (nothing to do without ``keep_pool``)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def require_shared(self, *paths: Any, writable: Sequence[Any] = ()) -> None:
        """Nothing to check: local workers share this machine's filesystem."""

    def _new_pool(self, n_workers: int) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(max_workers=n_workers,
                                   mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_init_worker, initargs=(os.getpid(),))

    def run(self, fn: Callable[[Any], Any], jobs: Sequence[Any]
            ) -> Iterator[tuple[int, Any | BaseException]]:
        """Run ``fn`` over ``jobs`` (see :class:`dressmeup.executors.Executor`)."""
        n_workers = min(self.workers, max(1, len(jobs)))
        if n_workers == 1:
            for i, job in enumerate(jobs):
                try:
                    yield i, fn(job)
                except Exception as exc:  # noqa: BLE001 - recorded per item by the caller
                    yield i, exc
            return
        if not self.keep_pool:
            with self._new_pool(n_workers) as pool:
                yield from self._run_on(pool, fn, jobs, n_workers)
            return
        if self._pool is None:
            self._pool = self._new_pool(self.workers)
        broken = yield from self._run_on(self._pool, fn, jobs, n_workers)
        if broken:
            self.close()

    def _run_on(self, pool: ProcessPoolExecutor, fn: Callable[[Any], Any],
                jobs: Sequence[Any], n_workers: int):
        """``run`` on ``pool``; returns whether the pool broke (a worker died)."""
        pending: dict[Future, int] = {}
        next_job = 0
        limit = n_workers * self.max_pending
        broken = False
        try:
            while next_job < len(jobs) or pending:
                while next_job < len(jobs) and len(pending) < limit:
                    try:
                        pending[pool.submit(fn, jobs[next_job])] = next_job
                    except BrokenProcessPool as exc:  # a worker died: fail what is left
                        broken = True
                        for i in range(next_job, len(jobs)):
                            yield i, exc
                        next_job = len(jobs)
                        break
                    next_job += 1
                if not pending:
                    break
                done, _ = wait(list(pending), return_when=FIRST_COMPLETED)
                for fut in done:
                    i = pending.pop(fut)
                    exc = fut.exception()
                    broken = broken or isinstance(exc, BrokenProcessPool)
                    yield (i, exc) if exc is not None else (i, fut.result())
        finally:
            for fut in pending:  # a consumer that stopped early: the rest is not needed
                fut.cancel()
        return broken
