"""What every benchmark task provides: metric specifications and the task protocol.

A task (``retarget``, ``uvparam``, ``fusion``, ``registration``, ``correspondence``) lives in
its own package ``dressmeup.bench.tasks.<task>`` split the way the nuScenes devkit splits
``eval/<task>/``: ``config`` (metrics and default options), ``data`` (the items a
submission must contain, how ground truth is found), ``evaluate`` (scoring one item) and
``render`` (how its numbers are shown in tables). The generic machinery (validation, scoring,
results, leaderboards) only talks to a task through :class:`Task`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

#: Statuses of a per-sample result row.
STATUS_OK = "ok"
STATUS_ERROR = "error"


@dataclass(frozen=True)
class MetricSpec:
    """How one metric is named, stored and shown.

    Values are stored in SI units (metres, ratios in [0, 1], seconds); ``scale`` converts the
    stored value into the display ``unit`` (1000 for metres -> mm, 100 for ratios -> %).

    Attributes
    ----------
    name : column name in result tables (``p2s``).
    label : short header label (``P2S``).
    unit : display unit (``mm``, ``%``, ``mm²``, ``s`` or ``""``).
    scale : factor from the stored value to the display unit.
    better : ``"lower"`` or ``"higher"``.
    digits : decimals shown in tables.
    description : one line for docs and HTML tooltips.
    """

    name: str
    label: str
    unit: str
    scale: float
    better: str
    digits: int
    description: str

    @property
    def arrow(self) -> str:
        """The direction of "better" as an arrow: ``↓`` (lower) or ``↑`` (higher)."""
        return "↓" if self.better == "lower" else "↑"

    def header(self, ascii_only: bool = False) -> str:
        """Column header with the arrow and unit, e.g. ``P2S ↓ [mm]``."""
        arrow = ("(lower)" if self.better == "lower" else "(higher)") if ascii_only else self.arrow
        unit = f" [{self.unit}]" if self.unit else ""
        return f"{self.label} {arrow}{unit}"

    def display(self, value: float) -> float:
        """Stored value -> display value (NaN stays NaN)."""
        return float(value) * self.scale if value is not None else math.nan

    def is_better(self, a: float, b: float) -> bool:
        """Whether stored value ``a`` is strictly better than ``b``."""
        return a < b if self.better == "lower" else a > b


@dataclass
class Item:
    """One entry a submission must contain (a retargeting pair, a mesh, a capture, ...).

    Attributes
    ----------
    item_id : the file stem in the submission (letters, digits, ``-``, ``_``; pairs use ``__``).
    category : category used for per-category means (``topwear``, ``sphere``, ...).
    expect : task-specific expectations used by validation (vertex count, faces, ...).
    meta : extra fields copied into the result row (source id, garment id, ...).
    """

    item_id: str
    category: str
    expect: dict[str, Any] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)


class Task(Protocol):
    """The protocol each task module object implements (see ``dressmeup.bench.tasks``)."""

    name: str
    metrics: Sequence[MetricSpec]
    default_options: Mapping[str, Any]
    file_suffixes: Sequence[str]

    def dataset_problems(self, edition: Any, data_root: Path) -> tuple[dict[str, Any], list[str]]:
        """Check the data root against the edition's pin; return (dataset info, problems)."""

    def items(self, edition: Any, data_root: Path) -> list[Item]:
        """The items a submission to ``edition`` must contain, in a stable order."""

    def check_file(self, path: Path, item: Item, edition: Any) -> list[str]:
        """Problems of one submission file (empty when valid)."""

    def jobs(self, edition: Any, data_root: Path, files: Mapping[str, Path],
             items: Sequence[Item]) -> list[dict[str, Any]]:
        """Picklable scoring jobs, one per item (main process: prepares shared caches)."""

    score_job: Callable[[dict[str, Any]], dict[str, Any]]


def assemble_task(name: str, config: Any, data: Any, evaluate: Any, render: Any) -> Any:
    """Build a task object (the :class:`Task` protocol) from its four modules.

    Parameters
    ----------
    name : task name; config, data, evaluate, render : the task package's modules, providing
        ``METRICS``/``DEFAULT_OPTIONS``/``EXTRA_COLUMNS``/``UNIT_COLUMN`` (the result
        column naming the independent unit of bootstrap intervals), ``FILE_SUFFIXES``/
        ``dataset_problems``/``items``/``check_file``, ``jobs``/``score_job`` and
        ``metric_specs``.
    """
    from types import SimpleNamespace

    return SimpleNamespace(
        name=name,
        metrics=config.METRICS,
        default_options=config.DEFAULT_OPTIONS,
        extra_columns=config.EXTRA_COLUMNS,
        unit_column=getattr(config, "UNIT_COLUMN", None),
        file_suffixes=data.FILE_SUFFIXES,
        dataset_problems=data.dataset_problems,
        items=data.items,
        check_file=data.check_file,
        jobs=evaluate.jobs,
        score_job=evaluate.score_job,
        metric_specs=render.metric_specs,
    )
