"""Executors for scoring: kept as an import path; they live in :mod:`dressmeup.executors`
(below ``data`` in the layer table, so that ``synth`` and ``build-dataset`` use them too)."""

from __future__ import annotations

from typing import Any

from dressmeup.executors import Executor, LocalExecutor, make_executor
from dressmeup.executors.dask_executor import DaskExecutor


def __getattr__(name: str) -> Any:
    if name == "DaskExecutor":
        return DaskExecutor
    raise AttributeError(name)


__all__ = ["Executor", "LocalExecutor", "make_executor"]  # + DaskExecutor, lazily
