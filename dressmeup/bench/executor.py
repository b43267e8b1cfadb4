"""Executors: where the per-item scoring jobs run.

The scorer hands an :class:`Executor` a top-level function and a list of picklable jobs and
consumes ``(index, result_or_exception)`` pairs as they finish. :class:`LocalExecutor` runs
them in a process pool on this machine (or in-process with one worker); a distributed
executor (a cluster queue, Ray, Dask, ...) only has to implement the same ``run`` method.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol


class Executor(Protocol):
    """Runs ``fn(job)`` for every job; yields ``(index, result)`` or ``(index, exception)``
    in completion order. Exceptions raised by ``fn`` are yielded, never raised, so one
    failing item cannot stop a run."""

    name: str
    workers: int

    def run(self, fn: Callable[[Any], Any], jobs: Sequence[Any]
            ) -> Iterator[tuple[int, Any | BaseException]]:
        """Run ``fn`` over ``jobs``."""


def _init_worker() -> None:
    """Keep each worker single-threaded: the pool already uses every core."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    try:  # torch may be imported by a task; keep it from oversubscribing
        import sys

        if "torch" in sys.modules:
            sys.modules["torch"].set_num_threads(1)
    except Exception:  # noqa: BLE001 - best effort only
        pass


class LocalExecutor:
    """A process pool on the local cores (``spawn`` start method: safe with torch/open3d).

    Parameters
    ----------
    workers : number of worker processes; default ``os.cpu_count()``. With 1 the jobs run
        in the calling process (no pool start-up; easiest to debug).
    max_pending : jobs in flight at once per worker (bounds memory of queued results).
    """

    name = "local"

    def __init__(self, workers: int | None = None, max_pending: int = 2) -> None:
        if workers is not None and (not isinstance(workers, int) or workers < 1):
            raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
        self.workers = workers or (os.cpu_count() or 1)
        self.max_pending = max(1, int(max_pending))

    def run(self, fn: Callable[[Any], Any], jobs: Sequence[Any]
            ) -> Iterator[tuple[int, Any | BaseException]]:
        """Run ``fn`` over ``jobs`` (see :class:`Executor`)."""
        n_workers = min(self.workers, max(1, len(jobs)))
        if n_workers == 1:
            for i, job in enumerate(jobs):
                try:
                    yield i, fn(job)
                except Exception as exc:  # noqa: BLE001 - recorded per item by the scorer
                    yield i, exc
            return
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=n_workers, mp_context=ctx,
                                 initializer=_init_worker) as pool:
            pending: dict[Future, int] = {}
            next_job = 0
            limit = n_workers * self.max_pending
            while next_job < len(jobs) or pending:
                while next_job < len(jobs) and len(pending) < limit:
                    try:
                        pending[pool.submit(fn, jobs[next_job])] = next_job
                    except BrokenProcessPool as exc:  # a worker died: fail what is left
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
                    yield (i, exc) if exc is not None else (i, fut.result())
