"""Executors: where a command's many independent jobs run.

A caller hands an :class:`Executor` a top-level (picklable) function and a list of picklable
jobs and consumes ``(index, result_or_exception)`` pairs as they finish; exceptions raised by
the function are yielded, never raised, so one failing item cannot stop a run.

- :class:`~dressmeup.executors.local.LocalExecutor`: a process pool on this machine (or
  in-process with one worker); its workers die with the calling process.
- :class:`~dressmeup.executors.dask_executor.DaskExecutor`: Dask distributed, on a
  LocalCluster on 127.0.0.1 or an existing scheduler (``dressmeup[distributed]`` extra).

:func:`make_executor` turns the command-line switch (``--executor``, ``--workers``,
``--scheduler``) into one of them. ``score``, ``synth``, ``build-dataset`` and the baseline
runs all take it.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any, Protocol, TypeVar

from dressmeup.errors import InputError
from dressmeup.executors.dask_executor import DaskExecutor, dashboard_available, dask_available
from dressmeup.executors.local import LocalExecutor, die_with_parent

EXECUTORS = ("local", "dask")
T = TypeVar("T")


class Executor(Protocol):
    """Runs ``fn(job)`` for every job; yields ``(index, result)`` or ``(index, exception)``
    in completion order, each index exactly once. Exceptions raised by ``fn`` are yielded,
    never raised, so one failing item cannot stop a run."""

    name: str
    workers: int

    def run(self, fn: Callable[[Any], Any], jobs: Sequence[Any]
            ) -> Iterator[tuple[int, Any | BaseException]]:
        """Run ``fn`` over ``jobs``."""

    def require_shared(self, *paths: str | os.PathLike, writable: Sequence[Any] = ()) -> None:
        """Declare the folders the jobs read (``paths``) and write (``writable``); a
        distributed executor checks that every worker sees them."""


def require_shared(executor: Any, *paths: str | os.PathLike,
                   writable: Sequence[Any] = ()) -> None:
    """``executor.require_shared(...)`` when the executor has it (executors written against
    the older protocol only have ``run``)."""
    check = getattr(executor, "require_shared", None)
    if check is not None:
        check(*paths, writable=writable)


def in_order(results: Iterable[tuple[int, T]]) -> Iterator[tuple[int, T]]:
    """Re-order an executor's ``(index, result)`` pairs into index order.

    Results that arrive early are held until every earlier index has been yielded, so a
    consumer that writes as it goes (a dataset manifest) writes the same file as a serial run.
    """
    held: dict[int, T] = {}
    nxt = 0
    for i, res in results:
        held[i] = res
        while nxt in held:
            yield nxt, held.pop(nxt)
            nxt += 1
    for i in sorted(held):
        yield i, held.pop(i)


def make_executor(executor: str | None = None, workers: int | None = None,
                  scheduler: str | None = None, default_workers: int | None = None,
                  **kw: Any) -> Executor:
    """The executor the command-line switch asks for.

    Parameters
    ----------
    executor : ``"local"`` (default) or ``"dask"``; None means local unless ``scheduler``.
    workers : worker processes (local pool size, or LocalCluster size for dask).
    scheduler : address or scheduler-file of an existing Dask scheduler (implies dask).
    default_workers : ``workers`` when not given (None: every core; 1: in-process, serial).
    **kw : passed to :class:`~dressmeup.executors.dask_executor.DaskExecutor`.

    Raises
    ------
    InputError
        ``--scheduler`` with ``--executor local``, ``--workers`` below 1, or dask missing.
    """
    if executor not in (None, *EXECUTORS):
        raise InputError(f"--executor: expected one of {EXECUTORS}, got {executor!r}")
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise InputError(f"--workers: expected an integer >= 1, got {workers!r}")
    if scheduler and executor == "local":
        raise InputError("--scheduler names a Dask scheduler: use it with --executor dask "
                         "(or without --executor)")
    if scheduler or executor == "dask":
        if not dask_available():
            raise InputError("--executor dask needs Dask distributed: pip install "
                             "'dressmeup[distributed]' (or: pip install distributed)")
        return DaskExecutor(workers if scheduler else (workers or default_workers),
                            scheduler=scheduler or None, **kw)
    return LocalExecutor(workers or default_workers)


__all__ = ["EXECUTORS", "DaskExecutor", "Executor", "LocalExecutor", "dashboard_available",
           "dask_available", "die_with_parent", "in_order", "make_executor", "require_shared"]
