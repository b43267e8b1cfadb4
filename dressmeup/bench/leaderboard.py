"""Leaderboards: many results of one edition -> Markdown, CSV, LaTeX or HTML tables.

One row per method; one column per metric (overall mean, optionally ± std) and per category
for the edition's ``per_category`` metrics; units in the headers (distances in mm), an arrow
for the direction of better, the best value per column marked (bold; ties on the printed
value are all marked), rows sorted by the primary metric. Results of different editions (by
hash) or different datasets (by manifest hash) are refused, except results marked not
comparable (scored with ``--allow-other-data``), which are shown last, unranked and labelled
"not comparable" in every format.

Results of schema ``dressmeup-result/2`` carry 95 % bootstrap intervals over the task's
independent unit (see :mod:`dressmeup.bench.intervals`), shown as ``mean [lo, hi]``, and
per-track means when the items carry a ``track`` (columns like per-category ones). Between
consecutive ranks a paired bootstrap on the primary column says whether the two are separated
("Sep." column: ``yes`` / ``no``). Older results (``/1``) show "–" for what they lack.
"""

from __future__ import annotations

import csv
import datetime as _dt
import html
import importlib
import io
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dressmeup.bench.edition import Edition, edition_from_dict, load_edition
from dressmeup.bench.escape import csv_text, latex_text, md_text, safe_url
from dressmeup.bench.intervals import (
    MIN_UNITS_SEPARATION,
    N_RESAMPLES,
    describe_resolution,
    paired_difference,
)
from dressmeup.bench.results import EDITION_JSON, Result, load_result
from dressmeup.bench.tasks import MetricSpec, get_task
from dressmeup.bench.verify import verify_results
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text

FORMATS = ("md", "csv", "latex", "html")


#: Stylesheet of the HTML leaderboard (shared by the report site).
HTML_CSS = """  body { font-family: -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif;
         margin: 2rem auto; max-width: 1560px; padding: 0 1rem; color: #1d2330;
         background: #fff; line-height: 1.45; }
  h1 { font-size: 1.5rem; margin-bottom: .2rem; }
  .meta { color: #5b6475; font-size: .9rem; margin-bottom: 1.2rem; }
  .meta code { background: #f2f4f8; padding: 0 .3em; border-radius: 3px; }
  .wrap { overflow-x: auto; }
  table { border-collapse: collapse; font-size: .92rem; min-width: 60%; }
  th, td { padding: .45rem .7rem; border-bottom: 1px solid #e3e6ec; text-align: right;
           white-space: nowrap; }
  th { background: #f5f7fa; border-bottom: 2px solid #c9ced8; vertical-align: bottom;
        font-weight: 600; }
  th .unit, th .cat { display: block; font-weight: 400; color: #6b7385; font-size: .8rem; }
  th .arrow { color: #2f6fdb; }
  td.method, th.method { text-align: left; }
  td.rank, th.rank { text-align: center; color: #6b7385; }
  td.best { background: #e7f5ea; }
  td.best strong { color: #11632a; }
  tr:hover td { background: #f8fafc; }
  tr:hover td.best { background: #d9efde; }
  .authors { color: #6b7385; font-size: .8rem; }
  a { color: #2f6fdb; text-decoration: none; }
  ul.legend { font-size: .88rem; color: #3a4252; padding-left: 1.2rem; }
  footer { margin-top: 1.5rem; font-size: .8rem; color: #8a92a3; }
  td.sep-no { color: #a15c00; }
  td .ci { display: block; font-size: .75rem; color: #6b7385; font-weight: 400; }
  .nc { display: inline-block; margin-left: .4em; padding: 0 .35em; font-size: .75rem;
        color: #8a1c1c; background: #fde8e8; border-radius: 3px; }
  th[data-type] { cursor: pointer; user-select: none; }
  th.sorted-asc::after { content: " ▲"; color: #2f6fdb; font-size: .7rem; }
  th.sorted-desc::after { content: " ▼"; color: #2f6fdb; font-size: .7rem; }
"""

#: Inline script: a click on a header with ``data-type`` sorts the table's rows by that
#: column (numbers from ``data-v``; empty values last; a second click reverses).
SORT_JS = """
(function () {
  document.querySelectorAll("table.sortable").forEach(function (table) {
    var heads = table.querySelectorAll("thead th");
    heads.forEach(function (th, col) {
      if (!th.dataset.type) { return; }
      th.addEventListener("click", function () {
        var asc = !th.classList.contains("sorted-asc");
        heads.forEach(function (h) { h.classList.remove("sorted-asc", "sorted-desc"); });
        th.classList.add(asc ? "sorted-asc" : "sorted-desc");
        var body = table.tBodies[0];
        var rows = Array.prototype.slice.call(body.rows);
        rows.sort(function (a, b) {
          var x = a.cells[col].dataset.v, y = b.cells[col].dataset.v;
          if (x === undefined) { x = a.cells[col].textContent; }
          if (y === undefined) { y = b.cells[col].textContent; }
          if (x === "" || y === "") { return (x === "") - (y === ""); }
          var c = th.dataset.type === "num" ? parseFloat(x) - parseFloat(y)
                                            : x.localeCompare(y);
          return asc ? c : -c;
        });
        rows.forEach(function (r) { body.appendChild(r); });
      });
    });
  });
})();
"""


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


@dataclass
class Leaderboard:
    """A table ready to render.

    Attributes
    ----------
    edition : the edition all results share.
    manifest_sha256 : the dataset all results share.
    columns : numeric columns in order.
    rows : per method: ``{"method", "result", "values": {key: (mean, std, n)}, "failed",
        "items", "runtime"}`` sorted by the primary metric.
    best : column key -> set of row indices holding the best printed value.
    show_std : print ``mean ± std``.
    """

    edition: Edition
    manifest_sha256: str | None
    columns: list[Column]
    rows: list[dict[str, Any]]
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
        if not self.rows[i].get("comparable", True):
            return "–"
        return str(1 + sum(1 for r in self.rows[:i] if r.get("comparable", True)))

    def separated(self, i: int) -> str:
        """``yes`` / ``no``: row ``i`` is (not) separated from the next rank by the paired
        bootstrap on the primary column; ``–`` when unknown (last row, old results, no
        shared items)."""
        sep = self.rows[i].get("separated")
        return "–" if sep is None else ("yes" if sep else "no")

    def method_text(self, row: dict[str, Any]) -> str:
        """The method's name as plain text (escape it per format), with the
        "not comparable" mark."""
        return (row["method"] + (" ◆" if row.get("pareto") else "")
                + ("" if row.get("comparable", True) else " (not comparable)"))

    def interval(self, row: dict[str, Any], col: Column) -> str:
        """Printed 95 % interval ``[lo, hi]`` of a cell (display units), ``[–]`` when the
        result has none (older schema, single unit)."""
        ci = row.get("ci", {}).get(col.key)
        if not ci:
            return "[–]"
        d = col.spec.digits
        lo, hi = sorted((col.spec.display(ci[0]), col.spec.display(ci[1])))
        return f"[{lo:.{d}f}, {hi:.{d}f}]"

    # ----------------------------------------------------------------------- formatting
    def cell(self, row: dict[str, Any], col: Column, with_std: bool | None = None) -> str:
        """Printed value of a cell (display units, edition digits; ``–`` when missing)."""
        mean, std, _n = row["values"].get(col.key, (None, None, 0))
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
        return {"md": self.to_markdown, "csv": self.to_csv, "latex": self.to_latex,
                "html": self.to_html}[fmt]()

    def _runtime(self, row: dict[str, Any]) -> str:
        rt = row.get("runtime")
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
        if any(not r.get("comparable", True) for r in self.rows):
            out += " Not comparable: scored on data other than the edition pins; unranked."
        return out

    def _primary_label(self, ascii_only: bool = False) -> str:
        for c in self.columns:
            if c.key == self.primary:
                return c.header(ascii_only=ascii_only)
        return self.primary

    def to_markdown(self) -> str:
        """GitHub-flavoured Markdown table with a caption line."""
        head = ["#", "Method",
                *[c.spec.header() + (f" · {md_text(c.group)}" if c.group else "")
                  for c in self.columns], "Failed",
                "Runtime [s/sample]"] + (["Sep."] if self.show_ci else [])
        lines = ["| " + " | ".join(head) + " |",
                 "|" + "|".join([":-:", ":--"] + ["--:"] * (len(head) - 2)) + "|"]
        for i, row in enumerate(self.rows):
            cells = [self.rank(i), md_text(self.method_text(row))]
            for c in self.columns:
                t = self.cell(row, c)
                cells.append(f"**{t}**" if i in self.best.get(c.key, ()) else t)
            cells += [f"{row['failed']}/{row['items']}", self._runtime(row)]
            if self.show_ci:
                cells.append(self.separated(i))
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n\n" + html.escape(self._caption(), quote=False) + "\n"

    def to_csv(self) -> str:
        """CSV: numbers in display units (std columns when asked), ``best_in`` lists the
        columns where the row is best."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        head = ["rank", "method"]
        for c in self.columns:
            head.append(c.header())
            if self.show_std:
                head.append(c.header() + " std")
            if self.show_ci:
                head += [c.header() + " ci95 lo", c.header() + " ci95 hi"]
        head += ["failed", "items", "runtime_s_per_sample", "best_in", "comparable",
                 "separated_from_next", "schema_version", "pareto"]
        w.writerow([csv_text(h) for h in head])
        for i, row in enumerate(self.rows):
            rank = self.rank(i)
            vals: list[Any] = [rank if rank != "–" else "", csv_text(row["method"])]
            best_in = []
            for c in self.columns:
                mean, std, _ = row["values"].get(c.key, (None, None, 0))
                ok = mean is not None and math.isfinite(mean)
                fmt_ = f".{c.spec.digits + 2}f"
                vals.append(f"{c.spec.display(mean):{fmt_}}" if ok else "")
                if self.show_std:
                    vals.append(f"{c.spec.display(std):{fmt_}}"
                                if ok and std is not None else "")
                if self.show_ci:
                    ci = row.get("ci", {}).get(c.key)
                    vals += ([f"{v:{fmt_}}" for v in sorted(c.spec.display(x) for x in ci)]
                             if ci else ["", ""])
                if i in self.best.get(c.key, ()):
                    best_in.append(c.key)
            rt = row.get("runtime")
            sep = row.get("separated")
            vals += [row["failed"], row["items"],
                     "" if rt is None else f"{rt:.4f}", ";".join(best_in),
                     str(bool(row.get("comparable", True))).lower(),
                     "" if sep is None else str(bool(sep)).lower(),
                     row.get("schema_version", ""),
                     str(bool(row.get("pareto"))).lower() if self.pareto else ""]
            w.writerow(vals)
        return buf.getvalue()

    def to_latex(self) -> str:
        """A ``booktabs`` LaTeX table (``\\usepackage{booktabs}``)."""
        esc = latex_text

        def head(c: Column) -> str:
            arrow = r"$\downarrow$" if c.spec.better == "lower" else r"$\uparrow$"
            unit = {"mm²": r"mm$^2$"}.get(c.spec.unit, esc(c.spec.unit))
            h = f"{esc(c.spec.label)} {arrow}" + (f" [{unit}]" if unit else "")
            return h + (f" {esc(c.group)}" if c.group else "")

        cols = "l" + "r" * (len(self.columns) + 2 + int(self.show_ci))
        lines = [r"\begin{table}[t]", r"\centering", r"\small",
                 rf"\begin{{tabular}}{{{cols}}}", r"\toprule",
                 " & ".join(["Method", *[head(c) for c in self.columns], "Failed",
                             "Time [s]"] + (["Sep."] if self.show_ci else [])) + r" \\",
                 r"\midrule"]
        for i, row in enumerate(self.rows):
            cells = [esc(self.method_text(row)).replace("◆", r"$\diamond$")]
            for c in self.columns:
                t = self.cell(row, c).replace("±", r"$\pm$").replace("–", "--")
                cells.append(rf"\textbf{{{t}}}" if i in self.best.get(c.key, ()) else t)
            cells += [f"{row['failed']}/{row['items']}", self._runtime(row).replace("–", "--")]
            if self.show_ci:
                cells.append(self.separated(i).replace("–", "--"))
            lines.append(" & ".join(cells) + r" \\")
        lines += [r"\bottomrule", r"\end{tabular}",
                  rf"\caption{{{esc(self._caption(ascii_only=True))}}}".replace(
                      "◆", r"$\diamond$"),
                  rf"\label{{tab:{esc(self.edition.name)}}}", r"\end{table}"]
        return "\n".join(lines) + "\n"

    def html_table(self, links: dict[str, str] | None = None) -> str:
        """The leaderboard ``<table>`` (sortable by a click on a header with
        :data:`SORT_JS`; each numeric cell carries its value in ``data-v``).

        Parameters
        ----------
        links : method row key (``row["method"]``) -> relative URL of its page (the report
            site); otherwise the submission's http(s) URL is linked.
        """
        e = html.escape
        head_cells = ['<th class="rank" data-type="num">#</th>',
                      '<th class="method" data-type="text">Method</th>']
        for c in self.columns:
            g = c.group
            tip = e(c.spec.description + (f" ({'category ' + g if c.category else g})"
                                          if g else ""))
            sub = f'<span class="cat">{e(g)}</span>' if g else ""
            unit = f'<span class="unit">[{e(c.spec.unit)}]</span>' if c.spec.unit else ""
            ci = '<span class="unit">mean [95 % CI]</span>' if self.show_ci else ""
            head_cells.append(f'<th title="{tip}" data-type="num">{e(c.spec.label)} '
                              f'<span class="arrow">{c.spec.arrow}</span> {unit}{sub}{ci}</th>')
        head_cells += ['<th title="items that failed to score / items" data-type="num">'
                       'Failed</th>',
                       '<th title="mean runtime per sample reported by the submission" '
                       'data-type="num">Runtime <span class="unit">[s/sample]</span></th>']
        if self.show_ci:
            head_cells.append('<th title="paired bootstrap: is this rank separated from the '
                              'next one on the primary column (95 %)?" data-type="text">'
                              'Sep.</th>')
        body = []
        for i, row in enumerate(self.rows):
            m = row["method"]
            link = (links or {}).get(m) or safe_url(row.get("url"))
            if link:
                name = f'<a href="{e(link)}">{e(m)}</a>'
            else:
                name = e(m)
            if row.get("pareto"):
                name += (' <span class="pareto" title="on the Pareto front of '
                         f'{e(" and ".join(self.pareto))}">◆</span>')
            if not row.get("comparable", True):
                why = e(str(row.get("not_comparable_reason") or "scored on other data"))
                name += f' <span class="nc" title="{why}">not comparable</span>'
            authors = row.get("authors")
            if authors:
                name += f'<div class="authors">{e(str(authors))}</div>'
            rank = self.rank(i)
            cells = [f'<td class="rank" data-v="{e(rank) if rank != "–" else ""}">{rank}</td>',
                     f'<td class="method" data-v="{e(m)}">{name}</td>']
            for c in self.columns:
                mean = row["values"].get(c.key, (None,))[0]
                v = f"{mean:.9g}" if mean is not None and math.isfinite(mean) else ""
                t = e(self.cell(row, c))
                if self.show_ci and " [" in t:     # the interval on its own, smaller line
                    head_, _, tail_ = t.rpartition(" [")
                    t = f'{head_}<span class="ci">[{tail_}</span>'
                if i in self.best.get(c.key, ()):
                    cells.append(f'<td class="best" data-v="{v}"><strong>{t}</strong></td>')
                else:
                    cells.append(f'<td data-v="{v}">{t}</td>')
            rt = row.get("runtime")
            cells += [f'<td data-v="{row["failed"]}">{row["failed"]}/{row["items"]}</td>',
                      f'<td data-v="{rt if isinstance(rt, (int, float)) else ""}">'
                      f'{e(self._runtime(row))}</td>']
            if self.show_ci:
                sep = self.separated(i)
                cells.append(f'<td class="sep sep-{"na" if sep == "–" else sep}">{sep}</td>')
            body.append("<tr>" + "".join(cells) + "</tr>")
        return (f'<div class="wrap"><table class="leaderboard sortable">\n'
                f"<thead><tr>{''.join(head_cells)}</tr></thead>\n<tbody>\n"
                + "\n".join(body) + "\n</tbody>\n</table></div>")

    def html_notes(self) -> str:
        """The paragraph and legend under the HTML table."""
        e = html.escape
        legend = "".join(
            f"<li><b>{e(c.spec.label)}</b> {c.spec.arrow} "
            f"({'lower' if c.spec.better == 'lower' else 'higher'} is better"
            f"{', ' + e(c.spec.unit) if c.spec.unit else ''}): {e(c.spec.description)}</li>"
            for c in self.columns if c.group is None)
        return (f'<p class="meta">Sorted by {e(self._primary_label())}; best value per column '
                "highlighted; click a column header to sort by it. Means over successfully "
                f"scored items{'; mean ± std' if self.show_std else ''}."
                f"{e(self._ci_note())}</p>\n<ul class=\"legend\">{legend}</ul>")

    def html_meta(self) -> str:
        """The edition line above the HTML table."""
        ed = self.edition
        e = html.escape
        return (f'<div class="meta">Task <b>{e(ed.task)}</b> · split <b>{e(ed.split)}</b> ·\n'
                f"{self.rows[0]['items'] if self.rows else 0} items · edition hash "
                f"<code>{e(ed.hash[:16])}</code> ·\ndataset manifest "
                f"<code>{e((self.manifest_sha256 or '?')[:16])}</code><br>\n"
                f"{e(ed.description)}</div>")

    def to_html(self) -> str:
        """One self-contained HTML page (inline CSS and sorting script, no external
        resources)."""
        ed = self.edition
        e = html.escape
        generated = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{e(ed.name)} leaderboard</title>
<style>
{HTML_CSS}
</style>
</head>
<body>
<h1>{e(ed.name)} <small>v{ed.version}</small></h1>
{self.html_meta()}
{self.html_table()}
{self.html_notes()}
<footer>Generated by dressmeup on {generated}.</footer>
<script>
{SORT_JS}
</script>
</body>
</html>
"""


def _edition_of(result: Result) -> Edition:
    path = result.path / EDITION_JSON
    if path.is_file():
        return edition_from_dict(json.loads(path.read_text(encoding="utf-8")),
                                 source=str(path))

    return load_edition(result.summary["edition"]["name"])


def build_leaderboard(results: Sequence[str | os.PathLike | Result], *,
                      sort_by: str | None = None, show_std: bool = False,
                      per_category: Sequence[str] | None = None,
                      show_ci: bool | None = None) -> Leaderboard:
    """Build a leaderboard from result folders of ONE edition and dataset.

    Parameters
    ----------
    results : result folders (or loaded :class:`Result`).
    sort_by : metric to sort by (default: the edition's primary metric, on its primary
        track when the edition names one and the results have tracks).
    show_std : print ``mean ± std``.
    per_category : metrics to show per category and per track (default: the edition's
        ``per_category``; ``[]`` for none).
    show_ci : print 95 % intervals and the separation column (default: when any result
        has schema ``dressmeup-result/2``; a degenerate interval over one unit prints
        ``[–]`` and the caption says why).

    Raises
    ------
    InputError
        No results, results of different editions (hash) or different datasets (manifest
        hash; results marked not comparable may differ), or an unknown ``sort_by`` metric.
    """
    loaded = [r if isinstance(r, Result) else load_result(r, table=True) for r in results]
    if not loaded:
        raise InputError("no results given")
    hashes = {r.edition_hash for r in loaded}
    if len(hashes) > 1:
        lines = [f"  {r.path}: edition {r.summary['edition']['name']} "
                 f"v{r.summary['edition']['version']} hash {r.edition_hash[:12]}"
                 for r in loaded]
        raise InputError("results of different editions cannot share a leaderboard:\n"
                         + "\n".join(lines) + "\nmake one leaderboard per edition")
    comparable = [r for r in loaded if r.comparable]
    manifests = {r.manifest_hash for r in comparable}
    if len(manifests) > 1:
        lines = [f"  {r.path}: dataset manifest {str(r.manifest_hash)[:12]}"
                 for r in comparable]
        raise InputError("results scored on different datasets cannot share a leaderboard:\n"
                         + "\n".join(lines))

    edition_check = verify_results(loaded)  # means vs per_sample, edition hashes
    ed = _edition_of(loaded[0])
    task = get_task(ed.task)
    specs = task.metric_specs(ed)
    by_name = {s.name: s for s in specs}
    if sort_by is not None and sort_by not in by_name:
        raise InputError(f"cannot sort by {sort_by!r}: metrics of {ed.name} are "
                         f"{', '.join(by_name)}")
    columns = [Column(s.name, s) for s in specs]
    cat_metrics = list(ed.per_category if per_category is None else per_category)
    for m in cat_metrics:
        if m not in by_name:
            raise InputError(f"per-category metric {m!r} is not a metric of {ed.name}")
    tracks = _tracks(ed, loaded)
    prim = getattr(ed, "primary", None)
    prim_metric = prim.get("metric") if isinstance(prim, dict) else None
    # every track is shown separately for the primary metric, even without per_category
    track_metrics = list(dict.fromkeys(
        [*cat_metrics, *[m for m in (prim_metric, ed.primary_metric) if m in by_name][:1]]))
    for m in track_metrics:
        columns += [Column(f"{m}#{t}", by_name[m], track=t) for t in tracks]
    categories = sorted({c for r in loaded for c in r.summary.get("per_category", {})})
    if len(categories) > 1:
        for m in cat_metrics:
            columns += [Column(f"{m}@{cat}", by_name[m], cat) for cat in categories]
    primary = sort_by or ed.primary_metric
    if sort_by is None and isinstance(prim, dict) and prim.get("track") in tracks \
            and prim.get("metric", primary) in by_name:
        primary = f"{prim.get('metric', primary)}#{prim['track']}"
        if primary not in {c.key for c in columns}:
            columns.append(Column(primary, by_name[primary.split('#')[0]],
                                  track=prim["track"]))
    names = [r.method for r in loaded]
    rows = []
    for r in loaded:
        s = r.summary
        values, cis = {}, {}
        for c in columns:
            if c.track is not None:
                st = s.get("per_track", {}).get(c.track, {}).get("metrics", {}).get(
                    c.spec.name, {})
            elif c.category is None:
                st = s.get("metrics", {}).get(c.spec.name, {})
            else:
                st = s.get("per_category", {}).get(c.category, {}).get("metrics", {}).get(
                    c.spec.name, {})
            mean = st.get("mean")
            values[c.key] = (float(mean) if mean is not None else None, st.get("std"),
                             st.get("n", 0))
            ci = st.get("ci95")
            if isinstance(ci, list) and len(ci) == 2 and None not in ci \
                    and not st.get("degenerate", False):
                cis[c.key] = (float(ci[0]), float(ci[1]))
        method = r.method if names.count(r.method) == 1 else f"{r.method} ({r.path.name})"
        meta = s.get("method", {})
        rows.append({"method": method, "result": str(r.path), "values": values, "ci": cis,
                     "failed": s.get("counts", {}).get("failed", 0),
                     "items": s.get("counts", {}).get("items", 0),
                     "runtime": meta.get("runtime_per_sample_s"),
                     "url": meta.get("url"), "authors": _authors(meta.get("authors")),
                     "comparable": r.comparable,
                     "not_comparable_reason": s.get("not_comparable_reason"),
                     "schema_version": r.schema_version, "_result": r})
    spec = next(c.spec for c in columns if c.key == primary)

    def sort_key(row: dict[str, Any]) -> tuple:
        nc = 0 if row["comparable"] else 1
        # a row without the primary value (e.g. a per-mesh uvparam method when the primary
        # track is 'pretrained') follows the others, ordered by the metric overall
        for missing, key in enumerate((primary, primary.split("#")[0])):
            v = row["values"].get(key, (None,))[0]
            if v is not None and math.isfinite(v):
                return (nc, missing, v if spec.better == "lower" else -v, row["method"])
        return (nc, 2, 0.0, row["method"])

    rows.sort(key=sort_key)
    boot = next((r.summary.get("bootstrap") for r in loaded if r.summary.get("bootstrap")),
                None) or {}
    board = Leaderboard(edition=ed, manifest_sha256=(comparable or loaded)[0].manifest_hash,
                        columns=columns, rows=rows, show_std=show_std, primary=primary,
                        show_ci=any(row["schema_version"] >= 2 for row in rows)
                        if show_ci is None else show_ci,
                        unit=boot.get("unit") or task.unit_column,
                        n_units=boot.get("n_units"))
    board.custom_edition = edition_check.source if edition_check.custom else None
    _mark_separation(rows, primary, task.unit_column)
    board.pareto = _mark_pareto(ed, rows)
    for row in rows:
        row.pop("_result", None)
    for c in columns:
        printed = []
        for i, row in enumerate(rows):
            mean = row["values"][c.key][0]
            if row["comparable"] and mean is not None and math.isfinite(mean):
                printed.append((round(c.spec.display(mean), c.spec.digits), i))
        if not printed:
            continue
        best_val = (min if c.spec.better == "lower" else max)(v for v, _ in printed)
        board.best[c.key] = {i for v, i in printed if v == best_val}
    return board


def _mark_pareto(ed: Edition, rows: list[dict[str, Any]]) -> tuple[str, ...]:
    """Set ``row["pareto"]`` for tasks with a Pareto pair (uvparam: QCE vs seam length) when
    the edition lists both metrics; returns the metric names (empty: not marked)."""

    try:
        config = importlib.import_module(f"dressmeup.bench.tasks.{ed.task}.config")
        render = importlib.import_module(f"dressmeup.bench.tasks.{ed.task}.render")
    except ImportError:
        return ()
    names = tuple(getattr(config, "PARETO", ()))
    front_of = getattr(render, "pareto_front", None)
    if not names or front_of is None or not all(m in ed.metrics for m in names):
        return ()
    scores = {str(i): {m: row["values"][m][0] for m in names}
              for i, row in enumerate(rows) if row["comparable"]}
    front = front_of(scores, names)
    for i, row in enumerate(rows):
        row["pareto"] = str(i) in front
    return names


def _tracks(ed: Edition, loaded: Sequence[Result]) -> list[str]:
    """Track names present in the results, in the edition's order when it lists them."""
    present = {t for r in loaded for t in r.summary.get("per_track", {})}
    order = [t for t in (getattr(ed, "tracks", None) or ()) if t in present]
    return order + sorted(present - set(order))


def _mark_separation(rows: list[dict[str, Any]], primary: str, unit: str | None) -> None:
    """Set ``row["separated"]`` (True/False/None) between consecutive comparable ranks by
    a paired bootstrap over ``unit`` of the primary column (see
    :func:`dressmeup.bench.intervals.paired_difference`)."""

    metric, _, track = primary.partition("#")
    ranked = [r for r in rows if r["comparable"]]
    for row in rows:
        row["separated"] = None
    for a, b in zip(ranked, ranked[1:], strict=False):
        ta, tb = a["_result"].table, b["_result"].table
        if unit is None or ta is None or tb is None or a["schema_version"] < 2 \
                or b["schema_version"] < 2:
            continue
        if any(metric not in t or unit not in t for t in (ta, tb)):
            continue
        if track and not all("track" in t for t in (ta, tb)):
            continue

        def ok_rows(t):
            t = t[t["status"] == "ok"]
            if track:
                t = t[t["track"].astype(str) == track]
            return t.set_index("sample_id", drop=False)   # the unit may be sample_id

        xa, xb = ok_rows(ta), ok_rows(tb)
        shared = xa.index.intersection(xb.index)
        if not len(shared):
            continue
        d = paired_difference(xa.loc[shared, metric].to_numpy(),
                              xb.loc[shared, metric].to_numpy(),
                              xa.loc[shared, unit].to_numpy())
        if d is not None and d.n_units >= MIN_UNITS_SEPARATION:
            a["separated"] = d.separated


def _authors(a: Any) -> str:
    if isinstance(a, list):
        return ", ".join(map(str, a))
    return str(a) if a else ""


def write_leaderboard(results: Sequence[str | os.PathLike | Result], fmt: str,
                      out: str | os.PathLike | None = None, **kw: Any) -> str:
    """Build and render a leaderboard; write it to ``out`` (atomically) when given.

    Returns
    -------
    The rendered text.
    """
    text = build_leaderboard(results, **kw).render(fmt)
    if out is not None:
        atomic_write_text(Path(out), text)
    return text


def format_summary(summary: dict[str, Any]) -> str:
    """A short human-readable summary of one result (display units, arrows, failures)."""

    ed_info = summary["edition"]
    try:
        ed = load_edition(ed_info.get("source") or ed_info["name"])
        specs = {s.name: s for s in get_task(ed.task).metric_specs(ed)}
    except InputError:
        specs = {s.name: s for s in get_task(summary["task"]).metrics}
    counts = summary.get("counts", {})
    lines = [f"{summary.get('method', {}).get('method', '?')} on {ed_info['name']} "
             f"v{ed_info['version']}: {counts.get('ok', 0)}/{counts.get('items', 0)} items "
             f"scored, {counts.get('failed', 0)} failed"]
    for name, st in summary.get("metrics", {}).items():
        spec = specs.get(name)
        if spec is None:
            continue
        mean = st.get("mean")
        val = "–" if mean is None else f"{spec.display(mean):.{spec.digits}f}"
        std = st.get("std")
        extra = "" if std is None else f" ± {spec.display(std):.{spec.digits}f}"
        lines.append(f"  {spec.header():22s} {val}{extra}  (n={st.get('n', 0)})")
    return "\n".join(lines)
