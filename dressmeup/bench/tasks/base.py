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
from typing import Any

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


@dataclass(frozen=True)
class Task:
    """What the generic machinery (validation, scoring, results, leaderboards) knows of a task.

    Built by :func:`assemble_task` from the task package's four modules and checked there, so
    a task that lacks a piece fails when it is imported, not in the middle of a scoring run.

    Attributes
    ----------
    name : task name (``retarget``, ...).
    metrics : the task's metrics, in table order.
    default_options : edition options and their defaults.
    extra_columns : extra per-item result columns kept in the table (``ir_gt``, ...).
    unit_columns : result columns naming the factors the items share, which bootstrap
        intervals resample together (retarget: garment, target subject, target pose;
        registration: subject, pose; uvparam: the mesh; see
        :mod:`dressmeup.bench.scoring.intervals`).
    file_suffixes : accepted submission file suffixes.
    dataset_problems : ``(edition, data_root) -> (dataset info, problems)``; checks the pin.
    items : ``(edition, data_root) -> list[Item]``, in a stable order.
    check_file : ``(path, item, edition) -> list[str]`` problems of one submission file.
    jobs : ``(edition, data_root, files, items, show_progress=None) -> list[dict]``, one
        picklable scoring job per item (the main process prepares shared caches).
    score_job : ``job -> dict`` one result row (runs in a worker).
    metric_specs : ``(edition) -> list[MetricSpec]``, how the edition's metrics are shown.
    track_level : ``"item"`` (items carry a track: retargeting's re-pose/re-shape/cross,
        shown as columns) or ``"submission"`` (a whole submission declares its track:
        uvparam's per-mesh/pretrained; leaderboards rank within each track).
    show_median : leaderboards print ``mean / median`` (skewed metrics such as QCE).
    """

    name: str
    metrics: Sequence[MetricSpec]
    default_options: Mapping[str, Any]
    extra_columns: Sequence[str]
    unit_columns: tuple[str, ...]
    file_suffixes: Sequence[str]
    dataset_problems: Callable[..., tuple[dict[str, Any], list[str]]]
    items: Callable[..., list[Item]]
    check_file: Callable[..., list[str]]
    jobs: Callable[..., list[dict[str, Any]]]
    score_job: Callable[[dict[str, Any]], dict[str, Any]]
    metric_specs: Callable[..., Any]
    track_level: str = "item"
    show_median: bool = False

    @property
    def unit_column(self) -> str | None:
        """The first factor (the cluster of one-factor tasks), or None."""
        return self.unit_columns[0] if self.unit_columns else None

    def __post_init__(self) -> None:
        problems = []
        if not self.name:
            problems.append("name is empty")
        if not all(isinstance(m, MetricSpec) for m in self.metrics):
            problems.append("metrics must be MetricSpec objects")
        if not isinstance(self.unit_columns, tuple) or \
                not all(isinstance(c, str) and c for c in self.unit_columns):
            problems.append(f"unit_columns must be a tuple of column names, got "
                            f"{self.unit_columns!r}")
        if self.track_level not in ("item", "submission"):
            problems.append(f"track_level must be 'item' or 'submission', got "
                            f"{self.track_level!r}")
        for fn in ("dataset_problems", "items", "check_file", "jobs", "score_job", "metric_specs"):
            if not callable(getattr(self, fn)):
                problems.append(f"{fn} is not callable")
        if problems:
            raise TypeError(f"task {self.name!r}: " + "; ".join(problems))


def assemble_task(name: str, config: Any, data: Any, evaluate: Any, render: Any,
                  jobs: Any = None) -> Task:
    """Build a :class:`Task` from its four modules.

    Parameters
    ----------
    name : task name; config, data, evaluate, render : the task package's modules, providing
        ``METRICS``/``DEFAULT_OPTIONS``/``EXTRA_COLUMNS``/``UNIT_COLUMNS`` (the result
        columns naming the factors bootstrap intervals resample), ``FILE_SUFFIXES``/
        ``dataset_problems``/``items``/``check_file``, ``jobs``/``score_job`` and
        ``metric_specs``.
    jobs : the task's job builder when ``evaluate`` has none (tasks scored one item per job
        pass :func:`~dressmeup.bench.tasks.sampletask.simple_jobs`).

    Raises
    ------
    AttributeError when a module lacks one of them; TypeError when one has the wrong kind.
    """
    return Task(
        name=name,
        metrics=tuple(config.METRICS),
        default_options=config.DEFAULT_OPTIONS,
        extra_columns=tuple(config.EXTRA_COLUMNS),
        unit_columns=tuple(config.UNIT_COLUMNS),
        file_suffixes=tuple(data.FILE_SUFFIXES),
        dataset_problems=data.dataset_problems,
        items=data.items,
        check_file=data.check_file,
        jobs=jobs if jobs is not None else evaluate.jobs,
        score_job=evaluate.score_job,
        metric_specs=render.metric_specs,
        track_level=getattr(config, "TRACK_LEVEL", "item"),
        show_median=bool(getattr(config, "SHOW_MEDIAN", False)),
    )
