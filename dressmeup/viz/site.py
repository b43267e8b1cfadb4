"""The report site: a static, self-contained website of benchmark results.

``write_site(results, out, data_roots=..., submissions=...)`` writes::

    SITE/
      index.html                 every edition's leaderboard (the table of
                                 ``dressmeup leaderboard --format html``, sortable by click),
                                 each method linked to its page
      <edition>/index.html       one edition's leaderboard
      <edition>/<method>.html    the method's numbers with intervals, a per-category bar
                                 chart, its best and worst items as pictures, and the
                                 per-item table (sortable)
      <edition>/img/*.png        the pictures
      <edition>/img/*-3d.js      the meshes of a method page's 3D view
      _static/                   three.js (vendored, as one classic script) and the 3D
                                 view's script, shared by every page

Nothing is fetched from the network: CSS and the sorting script are inline, pictures are PNG
files beside the pages and the 3D views load with classic ``<script>`` tags (no module, no
``fetch``), so the folder works from ``file://`` and from any static server.

Pictures per task: retarget -- the prediction coloured by its per-vertex P2S (mm, colour bar)
front and back beside the ground truth, faces inside the target body in red; uvparam -- the
checkerboard render of the submitted UV map; fusion -- the reconstruction coloured by its
distance to the scan. They need the submission folder (recorded in the result, or found in
``submissions``) and the dataset (``data_roots`` or the recorded root, matched by manifest
sha256); when either is missing the page shows the numbers and says why there are no
pictures. A method's page: :mod:`dressmeup.viz.site_method`; finding what its pictures need:
:mod:`dressmeup.viz.site_inputs`; drawing items: :mod:`dressmeup.viz.site_items`.
"""

from __future__ import annotations

import datetime as _dt
import html
import os
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dressmeup.bench.boards.board_html import HTML_CSS, SORT_JS, html_meta, html_notes, html_table
from dressmeup.bench.boards.leaderboard import build_leaderboard
from dressmeup.bench.scoring.results import load_result
from dressmeup.bench.tasks import get_task
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
from dressmeup.viz.result_images import render_grouped_bars
from dressmeup.viz.site_method import MAX_IMAGES, method_page

__all__ = ["IMAGES_PER_SIDE", "SiteReport", "write_site"]

#: Best and worst items drawn per method (each side).
IMAGES_PER_SIDE = 5

_EXTRA_CSS = """
  nav { font-size: .85rem; margin-bottom: .8rem; }
  h2 { font-size: 1.2rem; margin-top: 2rem; }
  h3 { font-size: 1rem; margin-top: 1.4rem; }
  .why { background: #fff7e6; border-left: 3px solid #e0a030; padding: .5rem .8rem;
         font-size: .9rem; }
  .gallery { display: flex; flex-wrap: wrap; gap: .8rem; }
  figure { margin: 0; max-width: 100%; }
  figure img { max-width: 100%; height: auto; border: 1px solid #e3e6ec; }
  figcaption { font-size: .8rem; color: #5b6475; }
  table.items td { font-size: .85rem; }
  td.err { color: #a11; text-align: left; white-space: normal; max-width: 28rem; }
  img.chart { border: none; }
  .viewer3d { max-width: 760px; }
  .v3d-controls { display: flex; flex-wrap: wrap; gap: .4rem 1.2rem; font-size: .85rem;
                  margin-bottom: .4rem; }
  .v3d-canvas { width: 100%; height: auto; border: 1px solid #e3e6ec; cursor: grab;
                display: block; }
  .v3d-bar { display: flex; align-items: center; gap: .6rem; font-size: .8rem;
             color: #5b6475; margin-top: .3rem; }
  .v3d-cbar { width: 256px; height: 14px; border: 1px solid #c9ced8; }
  .v3d-scale { display: flex; flex-direction: column; width: 256px; }
  .v3d-ticks { display: flex; justify-content: space-between; }
"""


@dataclass
class SiteReport:
    """What :func:`write_site` wrote.

    Attributes
    ----------
    index : ``SITE/index.html``.
    edition_pages, method_pages : the other pages.
    images : pictures drawn.
    notes : one line per method without pictures (why).
    seconds : wall time.
    """

    index: Path
    edition_pages: list[Path] = field(default_factory=list)
    method_pages: list[Path] = field(default_factory=list)
    images: int = 0
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0


def _slug(text: str, taken: set[str]) -> str:
    """A file-name-safe, unique slug of ``text`` (letters, digits, ``-``, ``_``, ``.``)."""
    base = re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-.").lower()[:48] or "method"
    slug, i = base, 2
    while slug in taken:
        slug, i = f"{base}-{i}", i + 1
    taken.add(slug)
    return slug


def _page(title: str, body: str, nav: str = "") -> str:
    """A complete HTML page with the leaderboard stylesheet and the sorting script."""
    generated = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<link rel="icon" href="data:,">
<title>{html.escape(title)}</title>
<style>
{HTML_CSS}{_EXTRA_CSS}
</style>
</head>
<body>
{nav}
{body}
<footer>Generated by dressmeup on {generated}. Static page: no network access needed.</footer>
<script>
{SORT_JS}
</script>
</body>
</html>
"""


def _edition_charts(board: Any, ed_dir: Path, report: SiteReport, max_methods: int = 8
                    ) -> str:
    """HTML of the edition's grouped bar charts: the primary metric per category and per
    track, one bar per ranked method (the first ``max_methods``) with its interval."""

    e = html.escape
    metric = board.primary.split("#")[0]
    out = []
    for kind, attr in (("category", "category"), ("track", "track")):
        cols = [c for c in board.columns if c.spec.name == metric and getattr(c, attr)]
        if len(cols) < 2:
            continue
        rows = [r for r in board.rows if r.comparable][:max_methods]
        spec = cols[0].spec
        series = {r.method: [spec.display(r.mean(c.key)) if r.mean(c.key) is not None
                             else float("nan") for c in cols] for r in rows}
        ivs = {r.method: [tuple(sorted(spec.display(x) for x in r.ci[c.key]))
                          if c.key in r.ci else None for c in cols]
               for r in rows}
        png = ed_dir / "img" / f"_edition-per-{kind}.png"
        render_grouped_bars([getattr(c, attr) for c in cols], series, ivs, png,
                            ylabel=f"{spec.label} [{spec.unit}]" if spec.unit else spec.label,
                            title=f"{spec.label} per {kind} (bars: 95 % interval)")
        report.images += 1
        out.append(f'<img class="chart" src="img/{e(png.name)}" alt="{e(spec.label)} per '
                   f'{kind}, one bar per method">')
    return ("<h3>Per category and track</h3>" + "".join(out)) if out else ""


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, text)


def write_site(results: Sequence[str | os.PathLike], out: str | os.PathLike, *,
               data_roots: Sequence[str | os.PathLike] = (),
               submissions: Sequence[str | os.PathLike] = (),
               images_per_side: int = IMAGES_PER_SIDE, max_images: int = MAX_IMAGES,
               log: Callable[[str], Any] | None = None) -> SiteReport:
    """Write the report site of ``results`` into ``out`` (see the module docstring).

    Parameters
    ----------
    results : result folders, of one or several editions (one leaderboard per edition).
    out : the site folder (created; pages already there are replaced).
    data_roots : dataset roots to look in (matched to results by manifest sha256).
    submissions : submission folders, or folders holding them.
    images_per_side : best and worst items drawn per method.
    max_images : pictures of the whole site at most.
    log : called with one line per page.

    Returns
    -------
    SiteReport

    Raises
    ------
    InputError
        No results, unreadable results, or results of one edition on different datasets.
    """
    t0 = time.perf_counter()
    loaded = [load_result(r) for r in results]
    if not loaded:
        raise InputError("no results given: pass result folders written by 'dressmeup score'")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    groups: dict[str, list] = {}
    for r in loaded:
        groups.setdefault(r.edition_hash, []).append(r)
    site = _Site(SiteReport(index=out / "index.html"), data_roots, submissions,
                 budget=[max_images, len(loaded)], per_side=images_per_side,
                 log=log or (lambda line: None))
    taken_ed: set[str] = set()
    sections = []
    for group in groups.values():
        board = build_leaderboard(group)
        ed_slug = _slug(board.edition.name, taken_ed)
        sections.append(_write_edition(site, board, group, out / ed_slug, ed_slug))
    body = ("<h1>Benchmark results</h1>\n<p class=\"meta\">One leaderboard per edition; "
            "click a method for its per-item numbers and pictures, a column header to "
            "sort.</p>\n" + "\n".join(sections))
    report = site.report
    _write(report.index, _page("dressmeup benchmark results", body))
    report.seconds = time.perf_counter() - t0
    return report


@dataclass
class _Site:
    """What every page of one site shares: the report being filled, where pictures' inputs
    are looked for, the picture budget ``[item pictures left, method pages left]``, the
    pictures per side, the log."""

    report: SiteReport
    data_roots: Sequence
    submissions: Sequence
    budget: list[int]
    per_side: int
    log: Callable[[str], Any]


def _write_edition(site: _Site, board: Any, group: list, ed_dir: Path, ed_slug: str) -> str:
    """Write the method pages and the leaderboard page of one edition into ``ed_dir``;
    return its section of the site's index."""
    e = html.escape
    report = site.report
    task = get_task(board.edition.task)
    by_path = {str(r.path): r for r in group}
    taken: set[str] = {"index"}
    links: dict[str, str] = {}
    nav = '<nav><a href="index.html">&larr; leaderboard</a> · <a href="../index.html">all ' \
          "editions</a></nav>"
    for row in board.rows:
        slug = _slug(row.method, taken)
        site.log(f"report: {board.edition.name} / {row.method}")
        mp = method_page(by_path[row.result], row, board, task, ed_dir / "img", slug,
                         site.data_roots, site.submissions, site.budget, site.per_side)
        report.images += mp.images
        if mp.why:
            report.notes.append(f"{board.edition.name} / {row.method}: {mp.why}")
        page = ed_dir / f"{slug}.html"
        _write(page, _page(f"{row.method} on {board.edition.name}", mp.body, nav))
        site.budget[1] -= 1
        report.method_pages.append(page)
        links[row.method] = f"{slug}.html"
    head = (f"<h1>{e(board.edition.name)} <small>v{board.edition.version}</small></h1>\n"
            f"{html_meta(board)}")
    charts = _edition_charts(board, ed_dir, report)
    page_body = (f"{head}\n{html_table(board, links)}\n{html_notes(board)}\n"
                 + charts)
    ed_index = ed_dir / "index.html"
    _write(ed_index, _page(f"{board.edition.name} leaderboard", page_body,
                           '<nav><a href="../index.html">&larr; all editions</a></nav>'))
    report.edition_pages.append(ed_index)
    root_links = {m: f"{ed_slug}/{u}" for m, u in links.items()}
    return (f'<h2><a href="{e(ed_slug)}/index.html">{e(board.edition.name)}</a> '
            f"<small>v{board.edition.version}</small></h2>\n{html_meta(board)}\n"
            f"{html_table(board, root_links)}\n{html_notes(board)}\n"
            + charts.replace('src="img/', f'src="{e(ed_slug)}/img/'))
