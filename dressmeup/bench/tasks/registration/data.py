"""Registration task: one item per sample with a body; the submission holds the fitted body
parameters ``<sample_id>.npz`` in the body-parameter file format (docs/spec.md section 2)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from dressmeup.bench.tasks.base import Item
from dressmeup.bench.tasks.common import check_pin
from dressmeup.bench.tasks.sampletask import sample_items
from dressmeup.body import BodyParams, available_body_models

FILE_SUFFIXES = (".npz",)


def dataset_problems(edition: Any, data_root: Path):
    """Check the dataset against the edition pin."""
    return check_pin(edition, data_root)


def items(edition: Any, data_root: Path) -> list[Item]:
    """One item per sample of the split that has body parameters."""
    return sample_items(edition, data_root, need="body_path")


def check_file(path: Path, item: Item, edition: Any) -> list[str]:
    """Problems of one body-parameter file (readable, finite, a known body model)."""

    try:
        params = BodyParams.load(path)
    except Exception as exc:  # noqa: BLE001 - any failure to read is reported, not raised
        return [f"unreadable: {exc}"]
    known = available_body_models()
    if params.model not in known:
        return [f"body model {params.model!r} is not one of {', '.join(known)}"]
    return []
