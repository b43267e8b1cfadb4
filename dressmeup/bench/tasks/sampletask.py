"""Shared plumbing of the per-sample tasks (``fusion``, ``registration``,
``correspondence``): one item per dataset sample of the edition's split."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from dressmeup.bench.tasks.base import Item
from dressmeup.bench.tasks.common import open_dataset
from dressmeup.errors import InputError


def sample_items(edition: Any, data_root: Path, need: str | None = None,
                 expect: Callable[[Any], dict] | None = None) -> list[Item]:
    """Items for the samples of ``edition.split`` (only those with a ``need`` file, e.g.
    ``"scan_path"``), sorted by sample id."""

    root = str(Path(data_root).resolve())
    ds = open_dataset(root)
    df = ds.manifest
    df = df[df["split"] == edition.split]
    if need is not None:
        df = df[df[need].notna()]
    if not len(df):
        raise InputError(f"dataset {data_root} has no samples in split {edition.split!r}"
                         + (f" with {need.replace('_path', '')} files" if need else ""))
    items = []
    for row in df.sort_values("sample_id").itertuples():
        items.append(Item(row.sample_id, str(row.category),
                          expect=expect(row) if expect else {},
                          meta={"data_root": root, "sample_id": row.sample_id,
                                "subject_id": str(row.subject_id),
                                "garment_id": str(row.garment_id),
                                "pose_id": str(row.pose_id),
                                "session_id": f"{row.subject_id}-{row.pose_id}"}))
    return items


def simple_jobs(edition: Any, data_root: Path, files: dict, items: list[Item],
                show_progress: bool | None = None) -> list[dict[str, Any]]:
    """One job per item: ids, prediction path, metrics and options."""
    return [{"item_id": it.item_id, "category": it.category, "meta": dict(it.meta),
             "pred_path": str(files[it.item_id]), "metrics": list(edition.metrics),
             "options": dict(edition.options)} for it in items]


def metric_specs_from(metrics) -> Callable[[Any], list]:
    """A ``metric_specs(edition)`` function over a fixed metric table."""
    def metric_specs(edition: Any) -> list:
        by_name = {m.name: m for m in metrics}
        return [by_name[n] for n in edition.metrics]
    return metric_specs
