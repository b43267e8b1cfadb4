"""The ``uvparam`` task: mesh -> per-vertex or per-corner UV map (docs/spec.md section 4)."""

from __future__ import annotations

from dressmeup.bench.tasks.base import assemble_task
from dressmeup.bench.tasks.uvparam import config, data, evaluate, render

TASK = assemble_task("uvparam", config, data, evaluate, render)

__all__ = ["TASK", "config", "data", "evaluate", "render"]
