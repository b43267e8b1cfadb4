"""registration task: table columns (fixed units)."""

from __future__ import annotations

from dressmeup.bench.tasks.registration.config import METRICS
from dressmeup.bench.tasks.sampletask import metric_specs_from

metric_specs = metric_specs_from(METRICS)
