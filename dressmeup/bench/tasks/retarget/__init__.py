"""The ``retarget`` task: garment in a source pose + source body + target body -> garment on
the target body (docs/spec.md section 4)."""

from __future__ import annotations

from dressmeup.bench.tasks.base import assemble_task
from dressmeup.bench.tasks.retarget import config, data, evaluate, render

TASK = assemble_task("retarget", config, data, evaluate, render)

__all__ = ["TASK", "config", "data", "evaluate", "render"]
