"""Where the synthetic generators compute: canonical numerics and one job runner.

A generator hands :func:`run_jobs` a *job* (a picklable callable object, typically a frozen
dataclass holding the generator's settings) and the items to compute (one per garment);
the results come back in the order of the items (:func:`run_ready_jobs`: items handed out as
they become ready, results in completion order), computed in fresh worker processes whose
numeric libraries loaded with :data:`CANONICAL_ENV`, so the numbers do not depend on the
machine's thread count or vector extensions (docs/synthetic-data.md, "Reproducibility").
The calling process only writes.

Workers hold torch and numpy's BLAS at one thread. A job builds what it needs once per
process (body model, rest bodies, pose arrays) lazily on its first call, e.g. through a
``functools.lru_cache``'d builder keyed by the settings it depends on.
"""

from __future__ import annotations

import contextlib
import heapq
import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any, TypeVar

from dressmeup.executors import LocalExecutor, in_order
from dressmeup.executors.local import die_with_parent

T = TypeVar("T")
R = TypeVar("R")

#: Environment of the generators' worker processes, set before numpy, torch and their BLAS
#: load: one thread everywhere, and the portable kernels of every library (torch's scalar
#: "default" capability instead of AVX2/AVX-512, MKL's conditional numerical reproducibility,
#: OpenBLAS's generic core, numpy without its AVX2/AVX-512 loops). Float results then do not
#: depend on the CPU's vector extensions or the thread count (docs/synthetic-data.md,
#: "Reproducibility"): torch's AVX-512 and AVX2 kernels round sums differently, and the cloth
#: solvers turn such last-bit differences into centimetres.
CANONICAL_ENV = {
    "ATEN_CPU_CAPABILITY": "default", "MKL_CBWR": "COMPATIBLE",
    "OPENBLAS_CORETYPE": "Prescott", "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL "
    "AVX512_SPR", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
}


@contextlib.contextmanager
def canonical_numerics():
    """Set :data:`CANONICAL_ENV` in ``os.environ`` (inherited by processes started inside)."""
    old = {k: os.environ.get(k) for k in CANONICAL_ENV}
    os.environ.update(CANONICAL_ENV)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextlib.contextmanager
def single_threaded():
    """Hold torch (and numpy's BLAS when threadpoolctl is installed) at one thread."""
    # heavy: torch (~1.1 s to import)
    import torch

    try:
        # optional: threadpoolctl holds numpy's BLAS pool (gemm results do not depend on it)
        from threadpoolctl import threadpool_limits
    except ImportError:
        threadpool_limits = None
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with threadpool_limits(limits=1) if threadpool_limits else contextlib.nullcontext():
            yield
    finally:
        torch.set_num_threads(before)


def init_worker(parent_pid: int) -> None:
    """Initializer of a generator's worker process: die with the parent ``parent_pid`` (a
    killed generation leaves no worker behind), hold torch and numpy's BLAS at one thread."""
    # heavy: torch (~1.1 s to import)
    import torch

    die_with_parent(parent_pid)
    torch.set_num_threads(1)
    try:
        # optional: threadpoolctl holds numpy's BLAS pool at one thread
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=1)
    except ImportError:
        pass


class _OneThread:
    """``job`` run on an executor's worker with torch held at one thread (a Dask worker's
    BLAS threads are set by :data:`CANONICAL_ENV` at its start)."""

    def __init__(self, job: Callable[[Any], Any]) -> None:
        self.job = job
        self.__name__ = getattr(job, "__name__", type(job).__name__)

    def __call__(self, item: Any) -> Any:
        # heavy: torch (~1.1 s to import)
        import torch

        torch.set_num_threads(1)
        return self.job(item)


def run_jobs(job: Callable[[T], R], items: Sequence[T], workers: int = 1,
             executor: Any = None) -> Iterator[R]:
    """``job(item)`` for every item of ``items``, yielded in the order of ``items``.

    Parameters
    ----------
    job : a picklable callable (module-level function or an instance of a module-level
        class); it builds its per-process state itself, once a process.
    items : picklable items, one job each.
    workers : without ``executor``, the size of the pool of fresh worker processes spawned
        with :data:`CANONICAL_ENV` (at least one is always started: this process's libraries
        did not load with it); never more than there are items.
    executor : instead, a :mod:`dressmeup.executors` executor: a Dask one's workers get
        :data:`CANONICAL_ENV` (merged into its ``worker_env``, checked when it is already
        started); a ``LocalExecutor`` means the spawned pool above with its number of workers
        (its one-worker mode would compute in this process).

    Raises
    ------
    The first exception (in item order) raised by ``job``, in this process; the jobs not yet
    started are then dropped.
    """
    if not items:
        return
    if isinstance(executor, LocalExecutor):
        workers, executor = executor.workers, None
    if executor is not None:
        yield from _run_on(executor, job, items)
        return
    pool = ProcessPoolExecutor(max(1, min(int(workers), len(items))),
                               mp_context=multiprocessing.get_context("spawn"),
                               initializer=init_worker, initargs=(os.getpid(),))
    try:
        with canonical_numerics():  # the workers start (spawn) inside: they inherit it
            futures = [pool.submit(job, item) for item in items]
        for fut in futures:
            yield fut.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _run_on(executor: Any, job: Callable[[T], R], items: Sequence[T]) -> Iterator[R]:
    """:func:`run_jobs` on a :mod:`dressmeup.executors` executor."""
    if hasattr(executor, "worker_env"):  # Dask: the numerics are set at worker start
        executor.worker_env = {**CANONICAL_ENV, **executor.worker_env}
        if getattr(executor, "_client", None) is not None:
            executor.check_worker_env()
    with canonical_numerics():  # inherited by local pool workers started inside
        for _i, res in in_order(executor.run(_OneThread(job), items)):
            if isinstance(res, BaseException):
                raise res
            yield res


def run_ready_jobs(job: Callable[[T], R], ready: Callable[[], Sequence[tuple[Any, T]]],
                   workers: int = 1, executor: Any = None) -> Iterator[tuple[T, R]]:
    """``job(item)`` for items that become ready while others run; yields ``(item, result)``
    in completion order.

    Parameters
    ----------
    job : as in :func:`run_jobs`.
    ready : ``ready() -> [(priority, item), ...]``: the items that may run now and were not
        handed out before (each item once). Called first, then after each yielded result
        has been consumed (what the consumer wrote may make more items ready). Of the items
        waiting, the lowest priority (any orderable key, e.g. a tuple) starts first.
    workers : the size of the spawned pool (:func:`run_jobs`); at most ``workers + 1``
        jobs are handed to it at a time, so priorities decide until the last moment.
    executor : as in :func:`run_jobs`; a Dask (or other) executor runs the items in waves
        (each wave what is ready when the previous one ends).

    The run ends when nothing is waiting, running or ready.

    Raises
    ------
    The first exception raised by ``job`` (in completion order), in this process; the jobs
    not yet started are then dropped.
    """
    if isinstance(executor, LocalExecutor):
        workers, executor = executor.workers, None
    waiting: list[tuple[Any, int, T]] = []
    count = 0

    def take() -> None:
        nonlocal count
        for prio, item in ready():
            heapq.heappush(waiting, (prio, count, item))
            count += 1

    take()
    if executor is not None:
        while waiting:
            wave = [heapq.heappop(waiting)[2] for _ in range(len(waiting))]
            for item, res in zip(wave, _run_on(executor, job, wave), strict=True):
                yield item, res
            take()
        return
    if not waiting:
        return
    pool = ProcessPoolExecutor(max(1, int(workers)),
                               mp_context=multiprocessing.get_context("spawn"),
                               initializer=init_worker, initargs=(os.getpid(),))
    running: dict[Any, tuple[int, T]] = {}
    try:
        while waiting or running:
            while waiting and len(running) < max(1, int(workers)) + 1:
                _prio, seq, item = heapq.heappop(waiting)
                with canonical_numerics():  # the workers start (spawn) inside: they inherit it
                    running[pool.submit(job, item)] = (seq, item)
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for fut in sorted(done, key=lambda f: running[f][0]):
                item = running.pop(fut)[1]
                yield item, fut.result()
                take()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
