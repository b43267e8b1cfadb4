"""Leaderboards: many results of one edition -> Markdown, CSV, LaTeX or HTML tables.

One row per method; one column per metric (overall mean, optionally ± std) and per category
for the edition's ``per_category`` metrics; units in the headers (distances in mm), an arrow
for the direction of better, the best value per column marked (bold; ties on the printed
value are all marked), rows sorted by the primary metric. Results of different editions (by
hash) or different datasets (by manifest hash) are refused.
"""

from __future__ import annotations

import csv
import datetime as _dt
import html
import io
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dressmeup.bench.edition import Edition, edition_from_dict
from dressmeup.bench.results import EDITION_JSON, Result, load_result
from dressmeup.bench.tasks import MetricSpec, get_task
from dressmeup.errors import InputError

FORMATS = ("md", "csv", "latex", "html")


@dataclass
class Column:
    """One numeric column: a metric overall or within one category."""

    key: str
    spec: MetricSpec
    category: str | None = None

    def header(self, ascii_only: bool = False) -> str:
        """Header text, e.g. ``P2S ↓ [mm]`` or ``P2S ↓ [mm] · topwear``."""
        h = self.spec.header(ascii_only)
        return f"{h} · {self.category}" if self.category and not ascii_only else (
            f"{h} {self.category}" if self.category else h)


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
                f"{self._primary_label(ascii_only)}. Best per column in bold.")

    def _primary_label(self, ascii_only: bool = False) -> str:
        for c in self.columns:
            if c.key == self.primary:
                return c.header(ascii_only=ascii_only)
        return self.primary

    def to_markdown(self) -> str:
        """GitHub-flavoured Markdown table with a caption line."""
        head = ["#", "Method", *[c.header() for c in self.columns], "Failed",
                "Runtime [s/sample]"]
        lines = ["| " + " | ".join(head) + " |",
                 "|" + "|".join([":-:", ":--"] + ["--:"] * (len(head) - 2)) + "|"]
        for i, row in enumerate(self.rows):
            cells = [str(i + 1), row["method"].replace("|", "\\|")]
            for c in self.columns:
                t = self.cell(row, c)
                cells.append(f"**{t}**" if i in self.best.get(c.key, ()) else t)
            cells += [f"{row['failed']}/{row['items']}", self._runtime(row)]
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n\n" + self._caption() + "\n"

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
        head += ["failed", "items", "runtime_s_per_sample", "best_in"]
        w.writerow(head)
        for i, row in enumerate(self.rows):
            vals: list[Any] = [i + 1, row["method"]]
            best_in = []
            for c in self.columns:
                mean, std, _ = row["values"].get(c.key, (None, None, 0))
                ok = mean is not None and math.isfinite(mean)
                vals.append(f"{c.spec.display(mean):.{c.spec.digits + 2}f}" if ok else "")
                if self.show_std:
                    vals.append(f"{c.spec.display(std):.{c.spec.digits + 2}f}"
                                if ok and std is not None else "")
                if i in self.best.get(c.key, ()):
                    best_in.append(c.key)
            rt = row.get("runtime")
            vals += [row["failed"], row["items"],
                     "" if rt is None else f"{rt:.4f}", ";".join(best_in)]
            w.writerow(vals)
        return buf.getvalue()

    def to_latex(self) -> str:
        """A ``booktabs`` LaTeX table (``\\usepackage{booktabs}``)."""
        def esc(s: str) -> str:
            for a, b in (("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"),
                         ("_", r"\_"), ("#", r"\#"), ("$", r"\$"), ("{", r"\{"),
                         ("}", r"\}"), ("~", r"\textasciitilde{}"), ("^", r"\^{}")):
                s = s.replace(a, b)
            return s

        def head(c: Column) -> str:
            arrow = r"$\downarrow$" if c.spec.better == "lower" else r"$\uparrow$"
            unit = {"mm²": r"mm$^2$"}.get(c.spec.unit, esc(c.spec.unit))
            h = f"{esc(c.spec.label)} {arrow}" + (f" [{unit}]" if unit else "")
            return h + (f" {esc(c.category)}" if c.category else "")

        cols = "l" + "r" * (len(self.columns) + 2)
        lines = [r"\begin{table}[t]", r"\centering", r"\small",
                 rf"\begin{{tabular}}{{{cols}}}", r"\toprule",
                 " & ".join(["Method", *[head(c) for c in self.columns], "Failed",
                             "Time [s]"]) + r" \\", r"\midrule"]
        for i, row in enumerate(self.rows):
            cells = [esc(row["method"])]
            for c in self.columns:
                t = self.cell(row, c).replace("±", r"$\pm$").replace("–", "--")
                cells.append(rf"\textbf{{{t}}}" if i in self.best.get(c.key, ()) else t)
            cells += [f"{row['failed']}/{row['items']}", self._runtime(row).replace("–", "--")]
            lines.append(" & ".join(cells) + r" \\")
        lines += [r"\bottomrule", r"\end{tabular}",
                  rf"\caption{{{esc(self._caption(ascii_only=True))}}}",
                  rf"\label{{tab:{esc(self.edition.name)}}}", r"\end{table}"]
        return "\n".join(lines) + "\n"

    def to_html(self) -> str:
        """One self-contained HTML page (inline CSS, no scripts, no external resources)."""
        ed = self.edition
        e = html.escape
        head_cells = ['<th class="rank">#</th>', '<th class="method">Method</th>']
        for c in self.columns:
            tip = e(c.spec.description + (f" (category {c.category})" if c.category else ""))
            sub = f'<span class="cat">{e(c.category)}</span>' if c.category else ""
            unit = f'<span class="unit">[{e(c.spec.unit)}]</span>' if c.spec.unit else ""
            head_cells.append(f'<th title="{tip}">{e(c.spec.label)} '
                              f'<span class="arrow">{c.spec.arrow}</span> {unit}{sub}</th>')
        head_cells += ['<th title="items that failed to score / items">Failed</th>',
                       '<th title="mean runtime per sample reported by the submission">'
                       'Runtime <span class="unit">[s/sample]</span></th>']
        body = []
        for i, row in enumerate(self.rows):
            m = row["method"]
            link = row.get("url")
            name = (f'<a href="{e(link)}">{e(m)}</a>' if link and str(link).startswith(
                ("http://", "https://")) else e(m))
            authors = row.get("authors")
            if authors:
                name += f'<div class="authors">{e(str(authors))}</div>'
            cells = [f'<td class="rank">{i + 1}</td>', f'<td class="method">{name}</td>']
            for c in self.columns:
                t = e(self.cell(row, c))
                if i in self.best.get(c.key, ()):
                    cells.append(f'<td class="best"><strong>{t}</strong></td>')
                else:
                    cells.append(f"<td>{t}</td>")
            cells += [f"<td>{row['failed']}/{row['items']}</td>",
                      f"<td>{e(self._runtime(row))}</td>"]
            body.append("<tr>" + "".join(cells) + "</tr>")
        legend = "".join(
            f"<li><b>{e(c.spec.label)}</b> {c.spec.arrow} "
            f"({'lower' if c.spec.better == 'lower' else 'higher'} is better"
            f"{', ' + e(c.spec.unit) if c.spec.unit else ''}): {e(c.spec.description)}</li>"
            for c in self.columns if c.category is None)
        generated = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{e(ed.name)} leaderboard</title>
<style>
  body {{ font-family: -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif;
         margin: 2rem auto; max-width: 1200px; padding: 0 1rem; color: #1d2330;
         background: #fff; line-height: 1.45; }}
  h1 {{ font-size: 1.5rem; margin-bottom: .2rem; }}
  .meta {{ color: #5b6475; font-size: .9rem; margin-bottom: 1.2rem; }}
  .meta code {{ background: #f2f4f8; padding: 0 .3em; border-radius: 3px; }}
  .wrap {{ overflow-x: auto; }}
  table {{ border-collapse: collapse; font-size: .92rem; min-width: 60%; }}
  th, td {{ padding: .45rem .7rem; border-bottom: 1px solid #e3e6ec; text-align: right;
           white-space: nowrap; }}
  th {{ background: #f5f7fa; border-bottom: 2px solid #c9ced8; vertical-align: bottom;
        font-weight: 600; }}
  th .unit, th .cat {{ display: block; font-weight: 400; color: #6b7385; font-size: .8rem; }}
  th .arrow {{ color: #2f6fdb; }}
  td.method, th.method {{ text-align: left; }}
  td.rank, th.rank {{ text-align: center; color: #6b7385; }}
  td.best {{ background: #e7f5ea; }}
  td.best strong {{ color: #11632a; }}
  tr:hover td {{ background: #f8fafc; }}
  tr:hover td.best {{ background: #d9efde; }}
  .authors {{ color: #6b7385; font-size: .8rem; }}
  a {{ color: #2f6fdb; text-decoration: none; }}
  ul.legend {{ font-size: .88rem; color: #3a4252; padding-left: 1.2rem; }}
  footer {{ margin-top: 1.5rem; font-size: .8rem; color: #8a92a3; }}
</style>
</head>
<body>
<h1>{e(ed.name)} <small>v{ed.version}</small></h1>
<div class="meta">Task <b>{e(ed.task)}</b> · split <b>{e(ed.split)}</b> ·
{self.rows[0]['items'] if self.rows else 0} items · edition hash <code>{e(ed.hash[:16])}</code> ·
dataset manifest <code>{e((self.manifest_sha256 or '?')[:16])}</code><br>
{e(ed.description)}</div>
<div class="wrap"><table>
<thead><tr>{''.join(head_cells)}</tr></thead>
<tbody>
{chr(10).join(body)}
</tbody>
</table></div>
<p class="meta">Sorted by {e(self._primary_label())}; best value per column highlighted.
Means over successfully scored items{'; mean ± std' if self.show_std else ''}.</p>
<ul class="legend">{legend}</ul>
<footer>Generated by dressmeup on {generated}.</footer>
</body>
</html>
"""


def _edition_of(result: Result) -> Edition:
    path = result.path / EDITION_JSON
    if path.is_file():
        import json

        return edition_from_dict(json.loads(path.read_text(encoding="utf-8")),
                                 source=str(path))
    from dressmeup.bench.edition import load_edition

    return load_edition(result.summary["edition"]["name"])


def build_leaderboard(results: Sequence[str | os.PathLike | Result], *,
                      sort_by: str | None = None, show_std: bool = False,
                      per_category: Sequence[str] | None = None) -> Leaderboard:
    """Build a leaderboard from result folders of ONE edition and dataset.

    Parameters
    ----------
    results : result folders (or loaded :class:`Result`).
    sort_by : metric to sort by (default: the edition's primary metric).
    show_std : print ``mean ± std``.
    per_category : metrics to show per category (default: the edition's ``per_category``;
        ``[]`` for none).

    Raises
    ------
    InputError
        No results, results of different editions (hash) or different datasets (manifest
        hash), or an unknown ``sort_by`` metric.
    """
    loaded = [r if isinstance(r, Result) else load_result(r, table=False) for r in results]
    if not loaded:
        raise InputError("no results given")
    hashes = {r.edition_hash for r in loaded}
    if len(hashes) > 1:
        lines = [f"  {r.path}: edition {r.summary['edition']['name']} "
                 f"v{r.summary['edition']['version']} hash {r.edition_hash[:12]}"
                 for r in loaded]
        raise InputError("results of different editions cannot share a leaderboard:\n"
                         + "\n".join(lines) + "\nmake one leaderboard per edition")
    manifests = {r.manifest_hash for r in loaded}
    if len(manifests) > 1:
        lines = [f"  {r.path}: dataset manifest {str(r.manifest_hash)[:12]}" for r in loaded]
        raise InputError("results scored on different datasets cannot share a leaderboard:\n"
                         + "\n".join(lines))
    ed = _edition_of(loaded[0])
    task = get_task(ed.task)
    specs = task.metric_specs(ed)
    by_name = {s.name: s for s in specs}
    primary = sort_by or ed.primary_metric
    if primary not in by_name:
        raise InputError(f"cannot sort by {primary!r}: metrics of {ed.name} are "
                         f"{', '.join(by_name)}")
    columns = [Column(s.name, s) for s in specs]
    cat_metrics = list(ed.per_category if per_category is None else per_category)
    for m in cat_metrics:
        if m not in by_name:
            raise InputError(f"per-category metric {m!r} is not a metric of {ed.name}")
    categories = sorted({c for r in loaded for c in r.summary.get("per_category", {})})
    if len(categories) > 1:
        for m in cat_metrics:
            columns += [Column(f"{m}@{cat}", by_name[m], cat) for cat in categories]
    names = [r.method for r in loaded]
    rows = []
    for r in loaded:
        s = r.summary
        values = {}
        for c in columns:
            if c.category is None:
                st = s.get("metrics", {}).get(c.spec.name, {})
            else:
                st = s.get("per_category", {}).get(c.category, {}).get("metrics", {}).get(
                    c.spec.name, {})
            mean = st.get("mean")
            values[c.key] = (float(mean) if mean is not None else None, st.get("std"),
                             st.get("n", 0))
        method = r.method if names.count(r.method) == 1 else f"{r.method} ({r.path.name})"
        meta = s.get("method", {})
        rows.append({"method": method, "result": str(r.path), "values": values,
                     "failed": s.get("counts", {}).get("failed", 0),
                     "items": s.get("counts", {}).get("items", 0),
                     "runtime": meta.get("runtime_per_sample_s"),
                     "url": meta.get("url"), "authors": _authors(meta.get("authors"))})
    spec = by_name[primary]

    def sort_key(row: dict[str, Any]) -> tuple:
        v = row["values"][primary][0]
        if v is None or not math.isfinite(v):
            return (1, 0.0, row["method"])
        return (0, v if spec.better == "lower" else -v, row["method"])

    rows.sort(key=sort_key)
    board = Leaderboard(edition=ed, manifest_sha256=loaded[0].manifest_hash, columns=columns,
                        rows=rows, show_std=show_std, primary=primary)
    for c in columns:
        printed = []
        for i, row in enumerate(rows):
            mean = row["values"][c.key][0]
            if mean is not None and math.isfinite(mean):
                printed.append((round(c.spec.display(mean), c.spec.digits), i))
        if not printed:
            continue
        best_val = (min if c.spec.better == "lower" else max)(v for v, _ in printed)
        board.best[c.key] = {i for v, i in printed if v == best_val}
    return board


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
        from dressmeup.io.atomic import atomic_write_text

        atomic_write_text(Path(out), text)
    return text


def format_summary(summary: dict[str, Any]) -> str:
    """A short human-readable summary of one result (display units, arrows, failures)."""
    from dressmeup.bench.edition import load_edition

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
