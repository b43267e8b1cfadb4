"""Retargeting task: how its metrics appear in tables (units depend on edition options)."""

from __future__ import annotations

import dataclasses
from typing import Any

from dressmeup.bench.tasks.base import MetricSpec
from dressmeup.bench.tasks.retarget.config import METRICS


def metric_specs(edition: Any) -> list[MetricSpec]:
    """The edition's metrics, in its order, with display units for its options.

    ``chamfer`` shows in mm² when squared (the default) and in mm when ``chamfer_squared``
    is false.
    """
    by_name = {m.name: m for m in METRICS}
    out = []
    for name in edition.metrics:
        spec = by_name[name]
        if name == "chamfer" and not edition.options.get("chamfer_squared", True):
            spec = dataclasses.replace(spec, unit="mm", scale=1000.0,
                                       description="Chamfer distance (plain distances, sum "
                                                   "of the two means)")
        out.append(spec)
    return out
