"""A leaderboard as data: columns, typed rows, ranks, the best cells, and how each cell and
caption prints (the formats themselves: :mod:`~dressmeup.bench.board_text`,
:mod:`~dressmeup.bench.board_html`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from dressmeup.bench.board_html import html_table, to_html
from dressmeup.bench.board_text import to_csv, to_latex, to_markdown
from dressmeup.bench.edition import Edition
from dressmeup.bench.intervals import MIN_UNITS_SEPARATION, N_RESAMPLES, describe_resolution
from dressmeup.bench.tasks import MetricSpec
from dressmeup.errors import InputError

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
    separated : the rank is separated from the next by the paired bootstrap (None: unknown).
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
    separated: bool | None = None
    pareto: bool = False

    def mean(self, key: str) -> float | None:
        """The mean of column ``key`` (None when absent)."""
        return self.values.get(key, (None, None, 0))[0]


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
    unit: str | None = None
    n_units: int | None = None
    pareto: tuple[str, ...] = ()

    # ----------------------------------------------------------------- ranks and marks
    def rank(self, i: int) -> str:
        """Printed rank of row ``i`` (``–`` for a not-comparable result)."""
        if not self.rows[i].comparable:
            return "–"
        return str(1 + sum(1 for r in self.rows[:i] if r.comparable))

    def separated(self, i: int) -> str:
        """``yes`` / ``no``: row ``i`` is (not) separated from the next rank by the paired
        bootstrap on the primary column; ``–`` when unknown (last row, old results, no
        shared items)."""
        sep = self.rows[i].separated
        return "–" if sep is None else ("yes" if sep else "no")

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
        if (self.show_std if with_std is None else with_std) and std is not None:
            text += f" ± {col.spec.display(std):.{d}f}"
        if self.show_ci:
            text += " " + self.interval(row, col)
        return text

    def render(self, fmt: str) -> str:
        """The table as ``md``, ``csv``, ``latex`` or ``html`` text."""
        if fmt not in FORMATS:
            raise InputError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
        return {"md": to_markdown, "csv": to_csv, "latex": to_latex, "html": to_html}[fmt](self)

    def to_markdown(self) -> str:
        """GitHub-flavoured Markdown table with a caption line."""
        return to_markdown(self)

    def to_csv(self) -> str:
        """CSV in display units (see :func:`dressmeup.bench.board_text.to_csv`)."""
        return to_csv(self)

    def to_latex(self) -> str:
        """A ``booktabs`` LaTeX table."""
        return to_latex(self)

    def to_html(self) -> str:
        """One self-contained HTML page."""
        return to_html(self)

    def html_table(self, links: dict[str, str] | None = None) -> str:
        """The leaderboard ``<table>`` (see :func:`dressmeup.bench.board_html.html_table`)."""
        return html_table(self, links)

    def _runtime(self, row: BoardRow) -> str:
        rt = row.runtime
        return f"{rt:.2f}" if isinstance(rt, (int, float)) and math.isfinite(rt) else "–"

    def _caption(self, ascii_only: bool = False) -> str:
        ed = self.edition
        return (f"Edition {ed.name} v{ed.version} (task {ed.task}, split {ed.split}; "
                f"edition hash {ed.hash[:12]}, dataset manifest "
                f"{(self.manifest_sha256 or '?')[:12]}). Sorted by "
                f"{self._primary_label(ascii_only)}. Best per column in bold."
                + self._ci_note()
                + (f" Custom edition (not shipped with dressmeup; from {self.custom_edition})."
                   if self.custom_edition else ""))

    def _ci_note(self) -> str:
        """Caption sentences on intervals, separation and comparability."""

        out = ""
        if self.show_ci:
            out += (f" [lo, hi]: 95 % bootstrap interval over {self.unit or 'units'} "
                    f"({N_RESAMPLES} seeded resamples; "
                    f"{describe_resolution(self.n_units or 0)}); [–]: no interval (one unit "
                    "or an older result). "
                    "Sep.: paired bootstrap of the primary column says the rank is separated "
                    f"from the next (yes/no; – below {MIN_UNITS_SEPARATION} shared units).")
        if self.pareto:
            labels = {c.spec.name: c.spec.label for c in self.columns}
            pair = " and ".join(labels.get(m, m) for m in self.pareto)
            out += (f" ◆: on the Pareto front of {pair} (no other method is at least as good "
                    "on both and better on one).")
        if any(not r.comparable for r in self.rows):
            out += " Not comparable: scored on data other than the edition pins; unranked."
        return out

    def _primary_label(self, ascii_only: bool = False) -> str:
        for c in self.columns:
            if c.key == self.primary:
                return c.header(ascii_only=ascii_only)
        return self.primary

