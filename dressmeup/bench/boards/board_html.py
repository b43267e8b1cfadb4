"""Leaderboards as HTML: the sortable table (shared by the report site), its notes and a
self-contained page."""

from __future__ import annotations

import datetime as _dt
import html
import math

from dressmeup.bench.boards.board import Leaderboard
from dressmeup.bench.boards.escape import safe_url

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


def html_table(board: Leaderboard, links: dict[str, str] | None = None) -> str:
    """The leaderboard ``<table>`` (sortable by a click on a header with
    :data:`SORT_JS`; each numeric cell carries its value in ``data-v``).

    Parameters
    ----------
    links : method row key (``row.method``) -> relative URL of its page (the report
        site); otherwise the submission's http(s) URL is linked.
    """
    e = html.escape
    head_cells = ['<th class="rank" data-type="num">#</th>',
                  '<th class="method" data-type="text">Method</th>']
    for c in board.columns:
        g = c.group
        tip = e(c.spec.description + (f" ({'category ' + g if c.category else g})"
                                      if g else ""))
        sub = f'<span class="cat">{e(g)}</span>' if g else ""
        unit = f'<span class="unit">[{e(c.spec.unit)}]</span>' if c.spec.unit else ""
        ci = '<span class="unit">mean [95 % CI]</span>' if board.show_ci else ""
        head_cells.append(f'<th title="{tip}" data-type="num">{e(c.spec.label)} '
                          f'<span class="arrow">{c.spec.arrow}</span> {unit}{sub}{ci}</th>')
    head_cells += ['<th title="items that failed to score / items" data-type="num">'
                   'Failed</th>',
                   '<th title="mean runtime per sample reported by the submission" '
                   'data-type="num">Runtime <span class="unit">[s/sample]</span></th>']
    if board.show_ci:
        head_cells.append('<th title="this row minus the first of its group on the primary '
                          'column, with the 95 % interval of the paired difference" '
                          'data-type="num">vs #1</th>')
        head_cells.append('<th title="paired bootstrap: is this rank separated from the '
                          'next one on the primary column (95 %)?" data-type="text">'
                          'Sep.</th>')
    body = []
    for i, row in enumerate(board.rows):
        m = row.method
        link = (links or {}).get(m) or safe_url(row.url)
        if link:
            name = f'<a href="{e(link)}">{e(m)}</a>'
        else:
            name = e(m)
        if row.pareto:
            name += (' <span class="pareto" title="on the Pareto front of '
                     f'{e(" and ".join(board.pareto))}">◆</span>')
        if not row.comparable:
            why = e(str(row.not_comparable_reason or "scored on other data"))
            name += f' <span class="nc" title="{why}">not comparable</span>'
        authors = row.authors
        if authors:
            name += f'<div class="authors">{e(str(authors))}</div>'
        rank = board.rank(i)
        cells = [f'<td class="rank" data-v="{e(rank) if rank != "–" else ""}">{rank}</td>',
                 f'<td class="method" data-v="{e(m)}">{name}</td>']
        for c in board.columns:
            mean = row.values.get(c.key, (None,))[0]
            v = f"{mean:.9g}" if mean is not None and math.isfinite(mean) else ""
            t = e(board.cell(row, c))
            if board.show_ci and " [" in t:     # the interval on its own, smaller line
                head_, _, tail_ = t.rpartition(" [")
                t = f'{head_}<span class="ci">[{tail_}</span>'
            if i in board.best.get(c.key, ()):
                cells.append(f'<td class="best" data-v="{v}"><strong>{t}</strong></td>')
            else:
                cells.append(f'<td data-v="{v}">{t}</td>')
        rt = row.runtime
        cells += [f'<td data-v="{row.failed}">{row.failed}/{row.items}</td>',
                  f'<td data-v="{rt if isinstance(rt, (int, float)) else ""}">'
                  f'{e(board.runtime(row))}</td>']
        if board.show_ci:
            lead = row.vs_leader
            vs = board.versus_leader(i)
            cells.append(f'<td class="vs" data-v="{"" if lead is None else f"{lead.diff:.9g}"}">'
                         f'{e(vs)}</td>')
            sep = board.separated(i)
            kind = {"–": "na", "yes": "yes"}.get(sep, "no")
            cells.append(f'<td class="sep sep-{kind}">{e(sep)}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f'<div class="wrap"><table class="leaderboard sortable">\n'
            f"<thead><tr>{''.join(head_cells)}</tr></thead>\n<tbody>\n"
            + "\n".join(body) + "\n</tbody>\n</table></div>")

def html_notes(board: Leaderboard) -> str:
    """The paragraph and legend under the HTML table."""
    e = html.escape
    legend = "".join(
        f"<li><b>{e(c.spec.label)}</b> {c.spec.arrow} "
        f"({'lower' if c.spec.better == 'lower' else 'higher'} is better"
        f"{', ' + e(c.spec.unit) if c.spec.unit else ''}): {e(c.spec.description)}</li>"
        for c in board.columns if c.group is None)
    return (f'<p class="meta">Sorted by {e(board.primary_label())}; best value per column '
            "highlighted; click a column header to sort by it. Means over successfully "
            f"scored items{'; mean ± std' if board.show_std else ''}."
            f"{e(board.ci_note())}</p>\n<ul class=\"legend\">{legend}</ul>")

def html_meta(board: Leaderboard) -> str:
    """The edition line above the HTML table."""
    ed = board.edition
    e = html.escape
    return (f'<div class="meta">Task <b>{e(ed.task)}</b> · split <b>{e(ed.split)}</b> ·\n'
            f"{board.rows[0].items if board.rows else 0} items · edition hash "
            f"<code>{e(ed.hash[:16])}</code> ·\ndataset manifest "
            f"<code>{e((board.manifest_sha256 or '?')[:16])}</code><br>\n"
            f"{e(ed.description)}</div>")

def to_html(board: Leaderboard) -> str:
    """One self-contained HTML page (inline CSS and sorting script, no external
    resources)."""
    ed = board.edition
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
{html_meta(board)}
{html_table(board)}
{html_notes(board)}
<footer>Generated by dressmeup on {generated}.</footer>
<script>
{SORT_JS}
</script>
</body>
</html>
"""
