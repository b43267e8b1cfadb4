"""UV parameterisation task: table columns (fixed units)."""

from __future__ import annotations

from typing import Any

from dressmeup.bench.tasks.base import MetricSpec
from dressmeup.bench.tasks.uvparam.config import METRICS


def metric_specs(edition: Any) -> list[MetricSpec]:
    """The edition's metrics in its order."""
    by_name = {m.name: m for m in METRICS}
    return [by_name[n] for n in edition.metrics]
