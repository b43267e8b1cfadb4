"""UV parameterisation task: table columns (fixed units) and the QCE-vs-seams Pareto front."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from dressmeup.bench.tasks.base import MetricSpec
from dressmeup.bench.tasks.uvparam.config import METRICS, PARETO


def metric_specs(edition: Any) -> list[MetricSpec]:
    """The edition's metrics in its order."""
    by_name = {m.name: m for m in METRICS}
    return [by_name[n] for n in edition.metrics]


def pareto_front(scores: Mapping[str, Mapping[str, float]],
                 metrics: Sequence[str] | None = None) -> set[str]:
    """Methods on the Pareto front of two (or more) metrics, lower being better for each.

    A method is on the front when no other method is at least as good on every metric and
    strictly better on one. With ``PARETO = ("qce", "seam_length")`` this shows whether a
    low distortion was bought by cutting the mesh into many charts.

    Parameters
    ----------
    scores : ``{method: {metric: value}}`` (e.g. the summary means of each result).
    metrics : metric names (default :data:`~dressmeup.bench.tasks.uvparam.config.PARETO`).

    Returns
    -------
    set of str
        Names of the methods on the front; methods with a missing or non-finite value are
        never on it.
    """

    names = tuple(metrics or PARETO)
    pts = {}
    for method, vals in scores.items():
        v = [vals.get(m) for m in names]
        if all(x is not None and math.isfinite(float(x)) for x in v):
            pts[method] = tuple(float(x) for x in v)
    front = set()
    for a, pa in pts.items():
        dominated = any(all(q <= p for q, p in zip(pb, pa, strict=True)) and pb != pa
                        for b, pb in pts.items() if b != a)
        if not dominated:
            front.add(a)
    return front
