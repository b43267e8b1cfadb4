"""Benchmark tasks, one package each: ``retarget``, ``uvparam``, ``fusion``,
``registration``, ``correspondence`` (see :mod:`dressmeup.bench.tasks.base`)."""

from __future__ import annotations

import importlib

from dressmeup.bench.tasks.base import Item, MetricSpec, Task
from dressmeup.errors import InputError

TASK_NAMES = ("retarget", "uvparam", "fusion", "registration", "correspondence")


def get_task(name: str) -> Task:
    """Return the task object of ``name`` (one of :data:`TASK_NAMES`).

    Raises
    ------
    ValueError
        If ``name`` is not a known task.
    """
    if name not in TASK_NAMES:
        raise InputError(f"task must be one of {', '.join(TASK_NAMES)}, got {name!r}")
    return importlib.import_module(f"dressmeup.bench.tasks.{name}").TASK


__all__ = ["TASK_NAMES", "Item", "MetricSpec", "Task", "get_task"]
