"""The ``fusion`` task (SPEC.md section 4; docs/benchmark.md)."""

from __future__ import annotations

from types import SimpleNamespace

from dressmeup.bench.tasks.fusion import config, data, evaluate, render

TASK = SimpleNamespace(
    name="fusion",
    metrics=config.METRICS,
    default_options=config.DEFAULT_OPTIONS,
    extra_columns=config.EXTRA_COLUMNS,
    file_suffixes=data.FILE_SUFFIXES,
    dataset_problems=data.dataset_problems,
    items=data.items,
    check_file=data.check_file,
    jobs=evaluate.jobs,
    score_job=evaluate.score_job,
    metric_specs=render.metric_specs,
)

__all__ = ["TASK", "config", "data", "evaluate", "render"]
