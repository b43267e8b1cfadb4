"""A leaderboard as data: columns, typed rows, ranks, the best cells, and how each cell and
caption prints (the formats themselves: :mod:`~dressmeup.bench.boards.board_text`,
:mod:`~dressmeup.bench.boards.board_html`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from dressmeup.bench.edition import Edition
from dressmeup.bench.scoring.intervals import N_RESAMPLES
from dressmeup.bench.tasks import MetricSpec

FORMATS = ("md", "csv", "latex", "html")


@dataclass
class Column:
    """One numeric column: a metric overall or within one category."""

    key: str
    spec: MetricSpec
    category: str | None = None
    track: str | None = None

    @property
    def group(self) -> str | None:
        """The category or ``track <name>`` the column is restricted to (None: overall)."""
        if self.track is not None:
            return f"track {self.track}"
        return self.category

    def header(self, ascii_only: bool = False) -> str:
        """Header text, e.g. ``P2S ↓ [mm]``, ``P2S ↓ [mm] · topwear``, ``... · track cross``."""
        h = self.spec.header(ascii_only)
        g = self.group
        return f"{h} · {g}" if g and not ascii_only else (f"{h} {g}" if g else h)


#: A cell's figures: mean, std and item count (display conversion happens when printed).
CellValue = tuple[float | None, float | None, int]


@dataclass(frozen=True)
class Separation:
    """A paired comparison on the primary column (SI units): ``diff`` = this row minus the
    other, its 95 % interval, and whether the interval excludes 0."""

    diff: float
    lo: float
    hi: float
    separated: bool


@dataclass
class BoardRow:
    """One result in a leaderboard.

    Attributes
    ----------
    method : the name shown (the result folder is appended when two share a method name).
    result : the result folder.
    values : column key -> (mean, std, n) in SI units.
    ci : column key -> 95 % interval (lo, hi) in SI units, where the result has one.
    failed, items : items that failed to score, items in all.
    runtime : mean seconds per sample the submission reports (None: not reported).
    url, authors : from the submission's metadata.
    comparable : scored on the data the edition pins (else unranked, shown last).
    not_comparable_reason : why not, in words.
    schema_version : the result schema's version (``dressmeup-result/<n>``).
    medians : column key -> median over the column's items (recomputed from the table).
    levels : column key -> the levels of each factor its interval rests on.
    group : the submission-level track the row is ranked in (uvparam: ``per-mesh``,
        ``pretrained``), or None: one ranking.
    vs_leader, vs_next : paired comparison with the first row of its group and with the next
        ranked row on the primary column (None: none, the leader itself, or no shared items).
    pareto : on the Pareto front of the task's metric pair.
    """

    method: str
    result: str
    values: dict[str, CellValue]
    ci: dict[str, tuple[float, float]]
    failed: int
    items: int
    runtime: float | None
    url: str | None
    authors: str
    comparable: bool
    not_comparable_reason: str | None
    schema_version: int
    medians: dict[str, float] = field(default_factory=dict)
    levels: dict[str, dict[str, int]] = field(default_factory=dict)
    group: str | None = None
    vs_leader: Separation | None = None
    vs_next: Separation | None = None
    pareto: bool = False

    def mean(self, key: str) -> float | None:
        """The mean of column ``key`` (None when absent)."""
        return self.values.get(key, (None, None, 0))[0]

    @property
    def separated(self) -> bool | None:
        """Whether the row is separated from the next ranked one (None: unknown)."""
        return None if self.vs_next is None else self.vs_next.separated


@dataclass
class Leaderboard:
    """A table ready to render.

    Attributes
    ----------
    edition : the edition all results share.
    manifest_sha256 : the dataset all results share.
    columns : numeric columns in order.
    rows : one :class:`BoardRow` per result, sorted by the primary figure.
    best : column key -> set of row indices holding the best printed value.
    show_std : print ``mean ± std``.
    primary : the key of the column rows are ranked by.
    show_ci : print intervals and the separation columns.
    custom_edition : where a custom (not shipped) edition came from.
    factors : the factors the intervals resample (task ``UNIT_COLUMNS`` present).
    few : caption lines for the columns whose factors allow few distinct resamples.
    show_median : print ``mean / median`` in each cell.
    sensitivity : the ground truth's measured sensitivity on the primary column (SI
        units); a smaller difference is never called separated.
    pareto : the metric pair of the Pareto marks (empty: none).
    """

    edition: Edition
    manifest_sha256: str | None
    columns: list[Column]
    rows: list[BoardRow]
    best: dict[str, set[int]] = field(default_factory=dict)
    show_std: bool = False
    primary: str = ""
    show_ci: bool = False
    custom_edition: str | None = None
    factors: tuple[str, ...] = ()
    few: list[str] = field(default_factory=list)
    show_median: bool = False
    sensitivity: float | None = None
    pareto: tuple[str, ...] = ()

    # ----------------------------------------------------------------- ranks and marks
    def rank(self, i: int) -> str:
        """Printed rank of row ``i`` within its group (``–`` for a not-comparable result)."""
        row = self.rows[i]
        if not row.comparable:
            return "–"
        return str(1 + sum(1 for r in self.rows[:i] if r.comparable and r.group == row.group))

    def separated(self, i: int) -> str:
        """``yes`` / ``not separated``: row ``i`` is (not) separated from the next ranked
        row by the paired bootstrap on the primary column (a difference smaller than the
        edition's stated sensitivity is never separated); ``–`` when unknown (last row,
        older results, no shared items)."""
        sep = self.rows[i].vs_next
        if sep is None:
            return "–"
        return "yes" if self.wins(sep) else "not separated"

    def wins(self, sep: Separation) -> bool:
        big = self.sensitivity is None or abs(sep.diff) > self.sensitivity
        return sep.separated and big

    def versus_leader(self, i: int) -> str:
        """Row ``i`` minus the first row of its group on the primary column, with the 95 %
        interval of the paired difference, in display units (``not separated`` in words
        when the interval includes 0); ``–`` for the leader and unknown cases."""
        sep = self.rows[i].vs_leader
        col = next((c for c in self.columns if c.key == self.primary), None)
        if sep is None or col is None:
            return "–"
        d = col.spec.digits
        diff, lo, hi = (col.spec.display(x) for x in (sep.diff, sep.lo, sep.hi))
        lo, hi = sorted((lo, hi))
        text = f"{diff:+.{d}f} [{lo:+.{d}f}, {hi:+.{d}f}]"
        return text if self.wins(sep) else text + " not separated"

    def method_text(self, row: BoardRow) -> str:
        """The method's name as plain text (escape it per format), with the
        "not comparable" mark."""
        return (row.method + (" ◆" if row.pareto else "")
                + ("" if row.comparable else " (not comparable)"))

    def interval(self, row: BoardRow, col: Column) -> str:
        """Printed 95 % interval ``[lo, hi]`` of a cell (display units), ``[–]`` when the
        result has none (older schema, single unit)."""
        ci = row.ci.get(col.key)
        if not ci:
            return "[–]"
        d = col.spec.digits
        lo, hi = sorted((col.spec.display(ci[0]), col.spec.display(ci[1])))
        return f"[{lo:.{d}f}, {hi:.{d}f}]"

    # ----------------------------------------------------------------------- formatting
    def cell(self, row: BoardRow, col: Column, with_std: bool | None = None) -> str:
        """Printed value of a cell (display units, edition digits; ``–`` when missing)."""
        mean, std, _n = row.values.get(col.key, (None, None, 0))
        if mean is None or not math.isfinite(mean):
            return "–"
        d = col.spec.digits
        text = f"{col.spec.display(mean):.{d}f}"
        med = row.medians.get(col.key)
        if self.show_median and med is not None:
            text += f" / {col.spec.display(med):.{d}f}"
        if (self.show_std if with_std is None else with_std) and std is not None:
            text += f" ± {col.spec.display(std):.{d}f}"
        if self.show_ci:
            text += " " + self.interval(row, col)
        return text

    def runtime(self, row: BoardRow) -> str:
        """The row's seconds per item as printed (``–`` when unknown)."""
        rt = row.runtime
        return f"{rt:.2f}" if isinstance(rt, (int, float)) and math.isfinite(rt) else "–"

    def caption(self, ascii_only: bool = False) -> str:
        """The caption under every format of the table."""
        ed = self.edition
        return (f"Edition {ed.name} v{ed.version} (task {ed.task}, split {ed.split}; "
                f"edition hash {ed.hash[:12]}, dataset manifest "
                f"{(self.manifest_sha256 or '?')[:12]}). Sorted by "
                f"{self.primary_label(ascii_only)}. Best per column in bold."
                + self.ci_note()
                + (f" Custom edition (not shipped with dressmeup; from {self.custom_edition})."
                   if self.custom_edition else ""))

    def ci_note(self) -> str:
        """Caption sentences on intervals, separation, groups and comparability."""

        out = ""
        if self.grouped:
            out += (" Ranked within each track (a method is ranked only against methods of "
                    "its own track).")
        if self.show_median:
            out += " Cells: mean / median over the items."
        if self.show_ci:
            out += (f" [lo, hi]: 95 % interval of the mean, resampling together every factor "
                    f"the items share ({', '.join(self.factors) or 'units'}; reweighting "
                    f"bootstrap over crossed factors, {N_RESAMPLES} seeded resamples, "
                    "widened for few levels; docs/benchmark.md); [–]: none (one level of "
                    "every factor). vs #1: paired difference to the first of the group on the "
                    "primary column with its 95 % interval. Sep.: separated from the next "
                    "row by the same paired test (\"not separated\": the interval includes 0")
            if self.sensitivity is not None:
                col = next((c for c in self.columns if c.key == self.primary), None)
                sens = (f"{col.spec.display(self.sensitivity):.{col.spec.digits}f} "
                        f"{col.spec.unit}") if col else f"{self.sensitivity:g}"
                out += (f", or the difference is within the ground truth's measured "
                        f"sensitivity, {sens}")
            out += ")."
            for line in self.few:
                out += f" {line}."
        if self.pareto:
            labels = {c.spec.name: c.spec.label for c in self.columns}
            pair = " and ".join(labels.get(m, m) for m in self.pareto)
            out += (f" ◆: on the Pareto front of {pair} (no other method is at least as good "
                    "on both and better on one).")
        if any(not r.comparable for r in self.rows):
            out += " Not comparable: scored on data other than the edition pins; unranked."
        return out

    @property
    def grouped(self) -> bool:
        """True when the rows are ranked within submission-level tracks."""
        return any(r.group is not None for r in self.rows)

    def primary_label(self, ascii_only: bool = False) -> str:
        """The header of the column the rows are sorted by."""
        for c in self.columns:
            if c.key == self.primary:
                return c.header(ascii_only=ascii_only)
        return self.primary

