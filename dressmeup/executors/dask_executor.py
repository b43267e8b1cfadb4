"""`DaskExecutor`: the jobs run on Dask distributed (a LocalCluster or an existing scheduler).

Install with ``pip install "dressmeup[distributed]"``. The client submits one task per job
(``fn`` wrapped so that an exception raised by ``fn`` comes back as a value and is not
retried: a deterministic failure fails once), keeps at most ``max_pending`` tasks per worker
thread in flight and yields ``(index, result_or_exception)`` as tasks finish
(``distributed.as_completed``). A worker that dies takes nothing with it: the scheduler
re-runs its tasks on the other workers, at most ``allowed_failures`` times per task (then
the item is yielded with ``distributed.KilledWorker``). Every index is yielded exactly once.

Distributed runs assume a shared filesystem: :meth:`DaskExecutor.require_shared` names the
folders the jobs read and write, and each run first checks, on every worker, that they are
there with the same content (:class:`~dressmeup.errors.InputError` naming the path and the
worker otherwise). What runs on the workers: :mod:`dressmeup.executors.dask_worker`.
"""

from __future__ import annotations

import importlib
import importlib.util
import logging
import os
import sys
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from dressmeup.errors import InputError
from dressmeup.executors.dask_worker import (
    call_job,
    existing_ancestor,
    see_paths,
    worker_environ,
    worker_plugin,
)
from dressmeup.io.jsonio import parse_json_file

LOOPBACK = "127.0.0.1"

Log = Callable[[str], Any]


def _stderr(line: str) -> None:
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


def _import_distributed() -> Any:
    try:
        # optional: distributed (ImportError handled)
        import distributed
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise InputError("--executor dask needs Dask distributed: pip install "
                         "'dressmeup[distributed]' (or: pip install distributed)") from exc
    return distributed


def dashboard_available() -> bool:
    """True when Dask's dashboard can run (it needs bokeh)."""
    return importlib.util.find_spec("bokeh") is not None


def dask_available() -> bool:
    """True when Dask distributed is installed."""
    return importlib.util.find_spec("distributed") is not None


def _scheduler_address(scheduler: str) -> str:
    """The address of ``--scheduler``: the text itself, or the ``address`` a scheduler file
    (the JSON ``dask scheduler --scheduler-file`` writes) holds.

    Raises
    ------
    InputError
        A file that is not a scheduler file (no ``address``, not JSON, too large).
    """
    if not Path(scheduler).is_file():
        return scheduler
    info = parse_json_file(scheduler)  # bounded (json_bytes), UTF-8 and JSON checked
    address = info.get("address") if isinstance(info, dict) else None
    if not isinstance(address, str) or "://" not in address:
        raise InputError(f"--scheduler {scheduler}: not a Dask scheduler file (no "
                         "'address' such as tcp://host:8786); give the file 'dask scheduler "
                         "--scheduler-file' wrote, or the scheduler's address")
    return address


class DaskExecutor:
    """Jobs as Dask futures on a LocalCluster (loopback only) or an existing scheduler.

    Parameters
    ----------
    workers : size of the LocalCluster started on 127.0.0.1 (processes, one thread each;
        default ``os.cpu_count()``). Not allowed with ``scheduler``.
    scheduler : address of an existing scheduler (``tcp://host:8786``) or a path to its
        scheduler file (JSON); its workers are used as they are.
    max_pending : tasks in flight per worker thread (bounds client memory and lets a slow
        worker not hoard the queue).
    allowed_failures : times a task may lose its worker before it is given up (a LocalCluster
        started here; an existing scheduler keeps its own ``allowed-failures`` setting).
    retries : Dask ``retries=`` of each task (infrastructure errors only: an exception raised
        by the job function is returned, never retried).
    memory_limit : per-worker memory limit of the LocalCluster (Dask syntax, e.g. ``"4GB"``;
        default: the machine's memory divided by ``workers``).
    worker_env : environment variables the jobs need in their worker processes from the
        start (e.g. the synthetic generator's canonical numerics): a LocalCluster starts (and
        restarts) its workers with them, setting them in this process too as Dask does for
        its pre-spawn environment; on an existing cluster every worker is checked to have
        them.
    log : one-line messages (cluster started, dashboard address); default stderr.

    Use as a context manager to keep one cluster over several ``run`` calls; otherwise each
    ``run`` starts and stops its own LocalCluster.
    """

    name = "dask"

    def __init__(self, workers: int | None = None, scheduler: str | None = None, *,
                 max_pending: int = 2, allowed_failures: int = 3, retries: int = 1,
                 memory_limit: str | None = None, worker_env: dict[str, str] | None = None,
                 log: Log | None = _stderr) -> None:
        if scheduler and workers is not None:
            raise InputError("--workers sets the size of a LocalCluster; with --scheduler the "
                             "existing cluster's workers are used (drop --workers)")
        if workers is not None and (not isinstance(workers, int) or workers < 1):
            raise InputError(f"--workers: expected an integer >= 1, got {workers!r}")
        self.scheduler = scheduler
        self.workers = workers or (os.cpu_count() or 1)
        self.max_pending = max(1, int(max_pending))
        self.allowed_failures = int(allowed_failures)
        self.retries = int(retries)
        self.memory_limit = memory_limit
        self.worker_env = dict(worker_env or {})
        self.log = log or (lambda _line: None)
        self.startup_s: float | None = None
        self._read: list[str] = []
        self._write: list[str] = []
        self._client: Any = None
        self._cluster: Any = None
        self._entered = False

    # -------------------------------------------------------------- lifecycle
    def __enter__(self) -> DaskExecutor:
        self._entered = True
        self._connect()
        return self

    def __exit__(self, *exc: Any) -> None:
        self._entered = False
        self.close()

    @property
    def client(self) -> Any:
        """The ``distributed.Client`` (connected on first use)."""
        return self._connect()

    def _connect(self) -> Any:
        if self._client is not None:
            return self._client
        distributed = _import_distributed()
        t0 = time.perf_counter()
        if self.scheduler:
            kw = {"address": _scheduler_address(self.scheduler)}
            try:
                self._client = distributed.Client(timeout="20s", **kw)
                self._client.wait_for_workers(1, timeout=120)
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(f"--scheduler {self.scheduler}: cannot use that Dask "
                                 f"scheduler ({type(exc).__name__}: {exc}); start one with "
                                 f"'dask scheduler' and 'dask worker', or drop --scheduler "
                                 f"for a LocalCluster") from exc
            where = f"scheduler {self._client.scheduler.address}"
            self.workers = len(self._client.scheduler_info()["workers"])
        else:
            # heavy: dask (optional)
            import dask

            # the scheduler's HTTP server (dashboard with bokeh, else health/metrics only)
            # always runs: keep it on loopback, on a free port
            # workers inherit this config; their statistical profiler (a stack sample every
            # 10 ms) only feeds the dashboard and costs CPU on every job
            # worker_env must be there before a worker imports numpy: Dask's pre-spawn
            # environment is set in this process (the nanny's) before each worker process is
            # (re)started, and values already in os.environ win over the config
            pre_spawn = {**dask.config.get("distributed.nanny.pre-spawn-environ", {}),
                         **self.worker_env}
            os.environ.update(self.worker_env)
            with dask.config.set({"distributed.scheduler.allowed-failures":
                                  self.allowed_failures,
                                  "distributed.worker.profile.enabled": False,
                                  "distributed.nanny.pre-spawn-environ": pre_spawn}):
                self._cluster = distributed.LocalCluster(
                    n_workers=self.workers, threads_per_worker=1, processes=True,
                    host=LOOPBACK, dashboard_address=f"{LOOPBACK}:0", silence_logs=logging.CRITICAL,
                    memory_limit=self.memory_limit or "auto", env=dict(self.worker_env))
            self._client = distributed.Client(self._cluster)
            where = f"LocalCluster of {self.workers} worker processes on {LOOPBACK}"
        self._client.register_plugin(worker_plugin())
        self.check_worker_env()
        self.startup_s = time.perf_counter() - t0
        dash_link = self._client.dashboard_link if dashboard_available() else None
        self.log(f"dask: {where} ({self.startup_s:.1f} s to start)"
                 + (f"; dashboard {dash_link}" if dash_link else "; no dashboard "
                    "(pip install bokeh for one)"))
        return self._client

    def close(self) -> None:
        """Close the client and the LocalCluster started here (an existing scheduler and its
        workers are left running)."""
        client, cluster = self._client, self._cluster
        self._client = self._cluster = None
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()

    def check_worker_env(self) -> None:
        """Check that every worker has :attr:`worker_env` in its environment.

        Raises
        ------
        InputError
            Naming the worker and the variables it lacks or has with another value.
        """
        if not self.worker_env or self._client is None:
            return
        seen = self._client.run(worker_environ, sorted(self.worker_env))
        for addr, env in sorted(seen.items()):
            bad = {k: v for k, v in self.worker_env.items() if env.get(k) != v}
            if bad:
                raise InputError(
                    f"Dask worker {addr} was not started with the environment these jobs need "
                    f"(it lacks or differs in {sorted(bad)}); start its 'dask worker' with "
                    + " ".join(f"{k}={v!r}" for k, v in sorted(self.worker_env.items())))

    # -------------------------------------------------------------- shared filesystem
    def require_shared(self, *paths: str | os.PathLike, writable: Sequence[Any] = ()) -> None:
        """Paths every worker must see as this process does (``paths``: read by the jobs;
        ``writable``: written by them). Checked at the start of each :meth:`run`."""
        self._read = sorted({str(Path(p).absolute()) for p in paths if p is not None})
        for p in self._read:
            if not Path(p).exists():
                raise InputError(f"{p}: no such file or folder")
        self._write = sorted({str(Path(p).absolute()) for p in writable if p is not None})

    def check_shared(self) -> None:
        """Run a tiny task on every worker that checks the :meth:`require_shared` paths.

        Raises
        ------
        InputError
            Naming the first path and worker that disagree with this process.
        """
        if not self._read and not self._write:
            return
        seen = self.client.run(see_paths, self._read, self._write)
        here = see_paths(self._read, self._write)
        for p in self._read:
            if here["read"][p] == "missing":
                raise InputError(f"{p}: no such file or folder")
        for addr, got in sorted(seen.items()):
            for p in self._read:
                if got["read"][p] != here["read"][p]:
                    what = ("does not exist" if got["read"][p] == "missing"
                            else "holds something else")
                    raise InputError(
                        f"{p}: on Dask worker {addr} (host {got['host']}) this path {what}; "
                        f"distributed runs need the data and output folders on a filesystem "
                        f"shared by every worker, at the same path")
            for p in self._write:
                fp, ok = got["write"][p]
                if fp != here["write"][p][0] or not ok:
                    raise InputError(
                        f"{p}: Dask worker {addr} (host {got['host']}) cannot write there "
                        f"(its nearest existing folder {existing_ancestor(p)} is "
                        f"{'different' if fp != here['write'][p][0] else 'read-only'} there); "
                        f"put the output on a filesystem shared by every worker")

    # -------------------------------------------------------------- running
    def run(self, fn: Callable[[Any], Any], jobs: Sequence[Any]
            ) -> Iterator[tuple[int, Any | BaseException]]:
        """Run ``fn`` over ``jobs`` (see :class:`dressmeup.executors.Executor`)."""
        if not jobs:
            return
        own = not self._entered and self._client is None
        try:
            yield from self._run(fn, jobs)
        finally:
            if own:
                self.close()

    def _run(self, fn: Callable[[Any], Any], jobs: Sequence[Any]
             ) -> Iterator[tuple[int, Any | BaseException]]:
        distributed = _import_distributed()
        client = self.client
        self.check_shared()
        threads = sum(w.get("nthreads", 1)
                      for w in client.scheduler_info()["workers"].values()) or 1
        limit = threads * self.max_pending
        tag = f"{getattr(fn, '__name__', 'job')}-{uuid.uuid4().hex[:8]}"
        index: dict[str, int] = {}
        done: set[int] = set()
        next_job = 0

        def submit(i: int) -> Any:
            fut = client.submit(call_job, fn, jobs[i], key=f"{tag}-{i}", pure=False,
                                retries=self.retries)
            index[fut.key] = i
            return fut

        first = []
        while next_job < len(jobs) and next_job < limit:
            first.append(submit(next_job))
            next_job += 1
        queue = distributed.as_completed(first)
        for fut in queue:
            i = index.pop(fut.key)
            if fut.status == "finished":
                _ok, out = fut.result()  # fn's exception comes back as a value
            else:
                try:
                    out = fut.exception()
                except BaseException as exc:  # noqa: BLE001 - cancelled / lost futures
                    out = exc
                if out is None:
                    out = RuntimeError(f"Dask task {fut.key} ended as {fut.status!r}")
            fut.release()
            if next_job < len(jobs):
                queue.add(submit(next_job))
                next_job += 1
            if i in done:  # cannot happen with unique keys; never yield an item twice
                continue
            done.add(i)
            yield i, out
