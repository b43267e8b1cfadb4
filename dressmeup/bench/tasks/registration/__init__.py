"""The ``registration`` task (docs/spec.md section 4; docs/benchmark.md)."""

from __future__ import annotations

from dressmeup.bench.tasks.base import assemble_task
from dressmeup.bench.tasks.registration import config, data, evaluate, render
from dressmeup.bench.tasks.sampletask import simple_jobs

TASK = assemble_task("registration", config, data, evaluate, render,
                     jobs=simple_jobs)

__all__ = ["TASK", "config", "data", "evaluate", "render"]
