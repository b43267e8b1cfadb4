"""The page of one method on one edition of the report site (:mod:`dressmeup.viz.site`).

Its numbers with recomputed intervals and the levels they rest on, bar charts per category
and per track, the best and worst items as pictures (within the site's picture budget;
otherwise the sentence that says why there are none) and, for retargeting and fusion, the
same items in a 3D view (:mod:`dressmeup.viz.site_viewer`), and the sortable per-item table.
"""

from __future__ import annotations

import dataclasses
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.viz.result_images import render_category_bars
from dressmeup.viz.site_inputs import find_data_root, find_submission
from dressmeup.viz.site_items import draw_items, vmax_of
from dressmeup.viz.site_viewer import write_view

#: Upper bound on the item pictures of one site (keeps ``dressmeup demo`` in its time
#: budget); each method gets at most a fair share of what is left.
MAX_IMAGES = 120
#: Tasks with item pictures.
PICTURE_TASKS = ("retarget", "uvparam", "fusion")


@dataclass
class MethodPage:
    """The body of a method page and what drawing it took.

    Attributes
    ----------
    body : the page's HTML (without the surrounding document).
    images : pictures drawn (charts and items).
    why : why the page has no (or not all) item pictures; ``""`` when it has them.
    """

    body: str
    images: int
    why: str


def method_page(result: Any, row: Any, board: Any, task: Any, img_dir: Path, slug: str,
                data_roots: Sequence, submissions: Sequence, budget: list[int],
                per_side: int) -> MethodPage:
    """The page of ``row`` (a leaderboard row of ``board``) scored in ``result``.

    Pictures go to ``img_dir`` as ``<slug>-*.png``. ``budget`` is ``[item pictures left,
    method pages left]``; the pictures drawn are taken off its first entry.
    """
    e = html.escape
    specs = task.metric_specs(board.edition)
    pspec = next(x for x in specs if x.name == board.primary.split("#")[0])
    parts = [f"<h1>{e(row.method)}</h1>", _meta_line(result, board),
             "<h2>Numbers</h2>" + _overall_table(row, board)]
    if board.factors:
        parts.append('<p class="meta">Intervals: recomputed from the per-item results, '
                     f"resampling together {e(', '.join(board.factors))} (docs/benchmark.md, "
                     '"Confidence intervals"); "levels": how many of each the items '
                     "span.</p>")
    if result.schema_version < 2:
        parts.append('<p class="why">This result was scored by an older toolkit (schema 1): '
                     "it has no tracks.</p>")
    charts = []
    for kind in ("category", "track"):
        png = _category_chart(row, board, pspec, img_dir / f"{slug}-per_{kind}.png", kind)
        if png is not None:
            charts.append(f'<img class="chart" src="img/{e(png.name)}" alt="{e(pspec.label)} '
                          f'per {kind}">')
    if charts:
        parts.append("<h2>Per category" + (" and track" if len(charts) > 1 else "")
                     + "</h2>" + "".join(charts)
                     + '<p class="meta">Error bars: 95 % interval of the mean over the '
                     "factors the items share (none when a group has one level of every "
                     "factor).</p>")
    parts.append("<h2>Best and worst items</h2>")
    gallery, n_pics, why = _best_and_worst(result, task, pspec, img_dir, slug, data_roots,
                                           submissions, budget, per_side)
    parts += gallery
    if why:
        parts.append(f'<p class="why">{e(why)}</p>')
    table = result.table
    if table is not None:
        parts.append(f"<h2>Every item ({len(table)})</h2>"
                     '<p class="meta">Click a column header to sort.</p>'
                     + _item_table(table, specs, getattr(task, "unit_column", None),
                                   getattr(task, "extra_columns", ())))
    return MethodPage("\n".join(parts), len(charts) + n_pics, why)


def _meta_line(result: Any, board: Any) -> str:
    """Edition, items scored, authors, link, result schema, comparability (escaped)."""
    e = html.escape
    s = result.summary
    meta = s.get("method", {})
    bits = [f"edition <b>{e(board.edition.name)}</b> v{board.edition.version}",
            f"{s.get('counts', {}).get('ok', 0)}/{s.get('counts', {}).get('items', 0)} items "
            "scored"]
    if meta.get("authors"):
        a = meta["authors"]
        bits.append("by " + e(", ".join(map(str, a)) if isinstance(a, list) else str(a)))
    url = str(meta.get("url") or "")
    if url.startswith(("http://", "https://")):
        bits.append(f'<a href="{e(url)}">{e(url)}</a>')
    bits.append(f"result schema {result.schema_version}")
    if not result.comparable:
        bits.append('<span class="nc">not comparable</span> '
                    + e(str(s.get("not_comparable_reason") or "")))
    return f'<div class="meta">{" · ".join(bits)}</div>'


def _pictures_missing(result: Any, task: Any, data_roots: Sequence, submissions: Sequence,
                      budget: list[int]) -> tuple[Any, Any, str]:
    """``(submission, data root, "")`` when the items can be drawn, else ``(.., .., why)``."""
    sub = root = None
    why = ""
    if task.name not in PICTURE_TASKS:
        why = f"Pictures are drawn for {', '.join(PICTURE_TASKS)} results, not {task.name}."
    elif result.table is None:
        why = "The result folder has no per-item table, so there are no pictures."
    if not why:
        sub, why = find_submission(result, submissions)
    if not why:
        root, why = find_data_root(result, data_roots)
    if not why and budget[0] <= 0:
        why = (f"The site's picture budget ({MAX_IMAGES}) is used up by earlier methods; "
               "run 'dressmeup report' on fewer results to see this one's.")
    return sub, root, why


def _best_and_worst(result: Any, task: Any, pspec: Any, img_dir: Path, slug: str,
                    data_roots: Sequence, submissions: Sequence, budget: list[int],
                    per_side: int) -> tuple[list[str], int, str]:
    """Galleries of the best and worst items by the primary metric: ``(HTML parts, pictures
    drawn, why there are none or not all)``."""
    e = html.escape
    sub, root, why = _pictures_missing(result, task, data_roots, submissions, budget)
    parts: list[str] = []
    drawn = 0
    if why:
        return parts, drawn, why
    primary_name = pspec.name
    views: list = []
    table = result.table
    ok = table[(table["status"] == "ok")].copy()
    ok = ok[np.isfinite(ok[primary_name].astype(float))]
    lower = pspec.better == "lower"
    ok = ok.sort_values(primary_name, ascending=lower, kind="stable")
    # a fair share of what is left, so that later methods get pictures too
    k = min(per_side, max(budget[0] // (2 * max(budget[1], 1)), 1))
    best = ok.head(k)
    worst = ok.iloc[::-1].head(k)
    worst = worst[~worst["sample_id"].isin(best["sample_id"])]
    for label, sel in (("best", best), ("worst", worst)):
        rows = []
        for r in sel.to_dict("records"):
            track = r.get("track")
            group = r["category"] + (f", track {track}" if isinstance(track, str) else "")
            r["_caption"] = (f"{r['sample_id']} ({group}): {pspec.label} "
                             f"{_fmt(pspec, r[primary_name])} {pspec.unit}")
            rows.append(r)
        try:
            pics = draw_items(task.name, rows, sub, root, img_dir, f"{slug}-{label}",
                               pspec.label, views)
        except (OSError, ValueError, KeyError) as exc:
            why = f"Pictures could not be drawn: {exc}"
            break
        budget[0] -= len(pics)
        drawn += len(pics)
        if not pics:
            continue
        figs = "".join(f'<figure><img src="img/{e(p.name)}" alt="{e(c)}">'
                       f"<figcaption>{e(c)}</figcaption></figure>" for p, c in pics)
        parts.append(f"<h3>{label.capitalize()} {len(pics)} by {e(pspec.label)}</h3>"
                     f'<div class="gallery">{figs}</div>')
    if views and not why:
        fusion = task.name == "fusion"
        parts.append(write_view(views, vmax_of(views),
                                "distance to scan" if fusion else "P2S",
                                "scan" if fusion else "ground truth", img_dir, slug))
    return parts, drawn, why


def _fmt(spec: Any, value: Any) -> str:
    """``value`` in the spec's display unit and digits; ``–`` when missing or not finite."""
    if value is None or not isinstance(value, (int, float)) or not math.isfinite(value):
        return "–"
    return f"{spec.display(value):.{spec.digits}f}"


def _extra_specs(specs: list, extra: Sequence[str]) -> list:
    """Specs for task extra columns named ``<metric>_<what>`` (``ir_gt`` -> ``IR (gt)``,
    the same unit as IR); other extras are left out."""

    out = []
    for col in extra:
        base = next((sp for sp in specs if col.startswith(sp.name + "_")), None)
        if base is not None:
            what = col[len(base.name) + 1:]
            out.append(dataclasses.replace(base, name=col, label=f"{base.label} ({what})",
                                           description=f"{base.description} ({what})"))
    return out


def _item_table(table: Any, specs: list, unit: str | None, extra: Sequence[str] = ()) -> str:
    """The sortable per-item table: ids, every metric (and ``<metric>_<what>`` extra), status
    and note or error (every value escaped)."""
    e = html.escape
    ids = [c for c in ("sample_id", "category", "track", unit) if c and c in table]
    ids = list(dict.fromkeys(ids))
    metric_specs = [s for s in [*specs, *_extra_specs(specs, extra)] if s.name in table]
    head = "".join(f'<th data-type="text">{e(c)}</th>' for c in ids)
    head += "".join(f'<th data-type="num" title="{e(s.description)}">{e(s.header())}</th>'
                    for s in metric_specs)
    head += '<th data-type="text">status</th><th data-type="text">note / error</th>'
    body = []
    for row in table.to_dict("records"):
        cells = [f'<td class="method" data-v="{e(str(row[c]))}">{e(str(row[c]))}</td>'
                 for c in ids]
        for s in metric_specs:
            v = row.get(s.name)
            ok = isinstance(v, (int, float)) and math.isfinite(v)
            cells.append(f'<td data-v="{v:.9g}">{_fmt(s, v)}</td>' if ok
                         else '<td data-v="">–</td>')
        status = str(row.get("status", ""))
        msg = str(row.get("error") or row.get("note") or "")
        cells.append(f"<td>{e(status)}</td>")
        cells.append(f'<td class="err">{e(msg[:300])}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f'<div class="wrap"><table class="items sortable"><thead><tr>{head}</tr></thead>'
            "<tbody>\n" + "\n".join(body) + "\n</tbody></table></div>")


def _overall_table(row: Any, board: Any) -> str:
    """The method's overall figures: mean, median, the recomputed interval, item count and
    the levels of each factor the interval rests on (every value escaped)."""
    e = html.escape
    rows = []
    for c in board.columns:
        if c.group is not None:
            continue
        s_ = c.spec
        mean, _std, n = row.values.get(c.key, (None, None, 0))
        ci = row.ci.get(c.key)
        ci_txt = f"[{_fmt(s_, min(ci))}, {_fmt(s_, max(ci))}]" if ci else "–"
        levels = row.levels.get(c.key) or {}
        lv = " x ".join(f"{int(k)} {name}" for name, k in levels.items()) or "–"
        rows.append(f"<tr><td class=\"method\">{e(s_.header())}</td>"
                    f"<td>{e(_fmt(s_, mean))}</td><td>{e(_fmt(s_, row.medians.get(c.key)))}</td>"
                    f"<td>{e(ci_txt)}</td><td>{int(n or 0)}</td><td>{e(lv)}</td></tr>")
    return ('<div class="wrap"><table><thead><tr><th class="method">metric</th><th>mean</th>'
            "<th>median</th><th>95 % interval</th><th>items</th><th>levels</th></tr></thead>"
            "<tbody>" + "".join(rows) + "</tbody></table></div>")


def _category_chart(row: Any, board: Any, spec: Any, path: Path, kind: str) -> Path | None:
    """Bars of the primary metric per category (``kind="category"``) or per track, with
    the row's recomputed intervals."""
    cols = [c for c in board.columns if c.spec.name == spec.name
            and (c.category if kind == "category" else c.track) is not None]
    names, means, ivs = [], [], []
    for c in cols:
        mean = row.mean(c.key)
        if mean is None:
            continue
        names.append(c.category if kind == "category" else c.track)
        means.append(spec.display(mean))
        ci = row.ci.get(c.key)
        ivs.append(tuple(sorted(spec.display(x) for x in ci)) if ci else None)
    if not names:
        return None
    return render_category_bars(names, means, ivs, path,
                                ylabel=f"{spec.label} [{spec.unit}]" if spec.unit
                                else spec.label,
                                title=f"{spec.label} per {kind}")
