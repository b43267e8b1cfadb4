"""Leaderboards: many results of one edition -> Markdown, CSV, LaTeX or HTML tables.

One row per method; one column per metric (overall mean, optionally ± std) and per category
for the edition's ``per_category`` metrics; units in the headers (distances in mm), an arrow
for the direction of better, the best value per column marked (bold; ties on the printed
value are all marked), rows sorted by the primary figure. Results of different editions (by
hash) or different datasets (by manifest hash) are refused, except results marked not
comparable (scored with ``--allow-other-data``), which are shown last, unranked and labelled
"not comparable" in every format.

Results of schema ``dressmeup-result/2`` carry 95 % bootstrap intervals over the task's
independent unit (see :mod:`dressmeup.bench.scoring.intervals`), shown as ``mean [lo, hi]``, and
per-track means when the items carry a ``track`` (columns like per-category ones). Between
consecutive ranks a paired bootstrap on the primary column says whether the two are separated
("Sep." column: ``yes`` / ``no``). Older results (``/1``) show "–" for what they lack.
The table itself is :class:`~dressmeup.bench.boards.board.Leaderboard`.
"""

from __future__ import annotations

import importlib
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from dressmeup.bench.boards.board import FORMATS, BoardRow, Column, Leaderboard, Separation
from dressmeup.bench.boards.board_html import to_html
from dressmeup.bench.boards.board_stats import cell_stats, compare
from dressmeup.bench.boards.board_text import to_csv, to_latex, to_markdown
from dressmeup.bench.boards.verify import comparability, verify_results
from dressmeup.bench.edition import Edition, edition_from_dict, load_edition
from dressmeup.bench.scoring.intervals import FEW_RESAMPLES, describe_levels, resample_count
from dressmeup.bench.scoring.results import EDITION_JSON, Result, load_result
from dressmeup.bench.tasks import get_task
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.jsonio import parse_json_file

__all__ = ["build_leaderboard", "format_summary", "render", "write_leaderboard"]


def _edition_of(result: Result) -> Edition:
    path = result.path / EDITION_JSON
    if path.is_file():
        return edition_from_dict(parse_json_file(path), source=str(path))

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
    ed, edition_check, comp, comparable = _one_edition(loaded)
    task = get_task(ed.task)
    columns, primary = _columns(ed, task, loaded, sort_by, per_category)
    prim = ed.primary
    factors = tuple(c for c in task.unit_columns
                    if any(r.table is not None and c in r.table for r in loaded))
    submission_tracks = task.track_level == "submission"
    names = [r.method for r in loaded]
    rows = [_row(r, columns, factors, names, submission_tracks, comp[id(r)]) for r in loaded]
    results = {id(row): r for row, r in zip(rows, loaded, strict=True)}
    spec = next(c.spec for c in columns if c.key == primary)
    if submission_tracks and "#" in primary:
        primary = primary.split("#")[0]   # each group is ranked on the metric overall
    _sort_rows(rows, primary, spec, ed.tracks)
    board = Leaderboard(edition=ed, manifest_sha256=(comparable or loaded)[0].manifest_hash,
                        columns=columns, rows=rows, show_std=show_std, primary=primary,
                        show_ci=bool(factors) if show_ci is None else show_ci,
                        factors=factors, show_median=task.show_median,
                        sensitivity=ed.sensitivity.get(prim.metric) if ed.sensitivity
                        else None)
    board.custom_edition = edition_check.source if edition_check.custom else None
    board.few = _few_resamples(columns, rows)
    _mark_separation(rows, [results[id(r)] for r in rows], primary, factors)
    board.pareto = _mark_pareto(ed, rows)
    board.best = _best_cells(columns, rows)
    return board


def _one_edition(loaded: list[Result]) -> tuple[Edition, Any, dict, list[Result]]:
    """Refuse results of different editions, or comparable results of different datasets.

    Returns the edition, the check of the results
    (:func:`~dressmeup.bench.boards.verify.verify_results`), each result's comparability (by
    ``id``) and the comparable results.
    """
    hashes = {r.edition_hash for r in loaded}
    if len(hashes) > 1:
        lines = [f"  {r.path}: edition {r.summary['edition']['name']} "
                 f"v{r.summary['edition']['version']} hash {r.edition_hash[:12]}"
                 for r in loaded]
        raise InputError("results of different editions cannot share a leaderboard:\n"
                         + "\n".join(lines) + "\nmake one leaderboard per edition")
    edition_check = verify_results(loaded)  # means vs per_sample, edition hashes
    ed = _edition_of(loaded[0])
    comp = {id(r): comparability(r, ed) for r in loaded}
    comparable = [r for r in loaded if comp[id(r)][0]]
    manifests = {r.manifest_hash for r in comparable}
    if len(manifests) > 1:
        lines = [f"  {r.path}: dataset manifest {str(r.manifest_hash)[:12]}"
                 for r in comparable]
        raise InputError("results scored on different datasets cannot share a leaderboard:\n"
                         + "\n".join(lines))
    return ed, edition_check, comp, comparable


def _columns(ed: Edition, task: Any, loaded: list[Result], sort_by: str | None,
             per_category: Sequence[str] | None) -> tuple[list[Column], str]:
    """The columns (every metric overall, then per track and per category) and the key of
    the column rows are ranked by."""
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
    if len(tracks) == 1 and task.track_level == "item":
        tracks = []   # one track only: its columns would repeat the overall ones
    prim = ed.primary
    # every track is shown separately for the primary metric, even without per_category
    track_metrics = list(dict.fromkeys(
        [*cat_metrics, *([prim.metric] if prim.metric in by_name else [])]))
    for m in track_metrics:
        columns += [Column(f"{m}#{t}", by_name[m], track=t) for t in tracks]
    categories = sorted({c for r in loaded for c in r.summary.get("per_category", {})})
    if len(categories) > 1:
        for m in cat_metrics:
            columns += [Column(f"{m}@{cat}", by_name[m], cat) for cat in categories]
    primary = sort_by or prim.metric
    if sort_by is None and prim.track is not None and prim.track in tracks \
            and prim.metric in by_name:
        primary = prim.key
        if primary not in {c.key for c in columns}:
            columns.append(Column(primary, by_name[prim.metric], track=prim.track))
    return columns, primary


def _sort_rows(rows: list[BoardRow], primary: str, spec: Any,
               tracks: Sequence[str]) -> None:
    """Sort in place: comparable rows first, by group (in the edition's track order), then
    by the primary figure (a row without it follows, ordered by the metric overall)."""
    order = {t: i for i, t in enumerate(tracks)}

    def sort_key(row: BoardRow) -> tuple:
        nc = 0 if row.comparable else 1
        group = order.get(row.group, len(order)) if row.group is not None else 0
        for missing, key in enumerate((primary, primary.split("#")[0])):
            v = row.mean(key)
            if v is not None and math.isfinite(v):
                return (nc, group, missing, v if spec.better == "lower" else -v, row.method)
        return (nc, group, 2, 0.0, row.method)

    rows.sort(key=sort_key)


def _best_cells(columns: list[Column], rows: list[BoardRow]) -> dict[str, set[int]]:
    """Column key -> the rows whose printed value is the best among comparable rows (ties on
    the printed value all marked)."""
    best: dict[str, set[int]] = {}
    for c in columns:
        printed = []
        for i, row in enumerate(rows):
            mean = row.values[c.key][0]
            if row.comparable and mean is not None and math.isfinite(mean):
                printed.append((round(c.spec.display(mean), c.spec.digits), i))
        if not printed:
            continue
        best_val = (min if c.spec.better == "lower" else max)(v for v, _ in printed)
        best[c.key] = {i for v, i in printed if v == best_val}
    return best


def _row(r: Result, columns: list[Column], factors: tuple[str, ...], names: list[str],
         submission_tracks: bool, comp: tuple[bool, str | None]) -> BoardRow:
    """One row: means from the summary (checked against the table by
    :func:`~dressmeup.bench.boards.verify.verify_results`), intervals and medians recomputed from
    the table."""
    s = r.summary
    values, cis, medians, levels = {}, {}, {}, {}
    for c in columns:
        if c.track is not None:
            st = s.get("per_track", {}).get(c.track, {}).get("metrics", {}).get(c.spec.name, {})
        elif c.category is None:
            st = s.get("metrics", {}).get(c.spec.name, {})
        else:
            st = s.get("per_category", {}).get(c.category, {}).get("metrics", {}).get(
                c.spec.name, {})
        mean = st.get("mean")
        values[c.key] = (float(mean) if mean is not None else None, st.get("std"),
                         st.get("n", 0))
        if r.table is not None and mean is not None:
            cs = cell_stats(r.table, c.spec.name, c.track, c.category, factors)
            if cs.ci is not None:
                cis[c.key] = cs.ci
            if cs.median is not None:
                medians[c.key] = cs.median
            levels[c.key] = cs.levels
    method = r.method if names.count(r.method) == 1 else f"{r.method} ({r.path.name})"
    meta = s.get("method", {})
    tracks = list(s.get("per_track", {}))
    return BoardRow(
        method=method, result=str(r.path), values=values, ci=cis,
        failed=s.get("counts", {}).get("failed", 0), items=s.get("counts", {}).get("items", 0),
        runtime=meta.get("runtime_per_sample_s"), url=meta.get("url"),
        authors=_authors(meta.get("authors")), comparable=comp[0],
        not_comparable_reason=comp[1],
        schema_version=r.schema_version, medians=medians, levels=levels,
        group=tracks[0] if submission_tracks and len(tracks) == 1 else None)


def _few_resamples(columns: list[Column], rows: list[BoardRow]) -> list[str]:
    """Caption lines for the columns whose factors allow fewer than
    :data:`~dressmeup.bench.scoring.intervals.FEW_RESAMPLES` distinct resamples (columns resting on
    the same levels share one line)."""
    by_text: dict[str, list[str]] = {}
    for c in columns:
        levels = next((r.levels[c.key] for r in rows if r.levels.get(c.key)), None)
        if levels and resample_count(levels) < FEW_RESAMPLES:
            by_text.setdefault(describe_levels(levels), []).append(c.header(ascii_only=True))
    return [f"{', '.join(cols)}: {text}" for text, cols in by_text.items()]


def _mark_pareto(ed: Edition, rows: list[BoardRow]) -> tuple[str, ...]:
    """Set ``row.pareto`` for tasks with a Pareto pair (uvparam: QCE vs seam length) when
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
    scores = {str(i): {m: row.values[m][0] for m in names}
              for i, row in enumerate(rows) if row.comparable}
    front = front_of(scores, names)
    for i, row in enumerate(rows):
        row.pareto = str(i) in front
    return names


def _tracks(ed: Edition, loaded: Sequence[Result]) -> list[str]:
    """Track names present in the results, in the edition's order when it lists them."""
    present = {t for r in loaded for t in r.summary.get("per_track", {})}
    order = [t for t in (getattr(ed, "tracks", None) or ()) if t in present]
    return order + sorted(present - set(order))


def _mark_separation(rows: list[BoardRow], results: list[Result], primary: str,
                     factors: tuple[str, ...]) -> None:
    """Set ``vs_leader`` (paired comparison with the first comparable row of the group) and
    ``vs_next`` (with the next comparable row of the group) on the primary column, by the
    paired bootstrap over the items both scored
    (:func:`~dressmeup.bench.boards.board_stats.compare`)."""
    metric, _, track = primary.partition("#")
    track = track or None
    by_group: dict[str | None, list[tuple[BoardRow, Result]]] = {}
    for row, res in zip(rows, results, strict=True):
        row.vs_leader = row.vs_next = None
        if row.comparable and res.table is not None:
            by_group.setdefault(row.group, []).append((row, res))

    def sep(a: Result, b: Result) -> Separation | None:
        d = compare(a.table, b.table, metric, track, factors)
        return None if d is None else Separation(d.diff, d.lo, d.hi, d.separated)

    for ranked in by_group.values():
        (lead, lead_res), *rest = ranked
        for row, res in rest:
            row.vs_leader = sep(res, lead_res)
        for (a, ra), (_b, rb) in zip(ranked, ranked[1:], strict=False):
            a.vs_next = sep(ra, rb)


def _authors(a: Any) -> str:
    if isinstance(a, list):
        return ", ".join(map(str, a))
    return str(a) if a else ""


def render(board: Leaderboard, fmt: str) -> str:
    """The table as ``md``, ``csv``, ``latex`` or ``html`` text (:mod:`~dressmeup.bench.boards.board_text`,
    :mod:`~dressmeup.bench.boards.board_html`).

    Raises
    ------
    InputError
        An unknown format.
    """
    if fmt not in FORMATS:
        raise InputError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    return {"md": to_markdown, "csv": to_csv, "latex": to_latex, "html": to_html}[fmt](board)


def write_leaderboard(results: Sequence[str | os.PathLike | Result], fmt: str,
                      out: str | os.PathLike | None = None, **kw: Any) -> str:
    """Build and render a leaderboard; write it to ``out`` (atomically) when given.

    Returns
    -------
    The rendered text.
    """
    text = render(build_leaderboard(results, **kw), fmt)
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
