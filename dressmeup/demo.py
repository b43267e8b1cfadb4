"""``dressmeup demo``: the whole journey on built-in synthetic data, in a few minutes.

1. generate a small synthetic DressMeUp-style dataset (the ``synth-retarget-mini-v5``
   edition's pinned parameters, its test split's secret published: three garments, one per
   category, each the end of generator 4's defined motion onto a source and three targets
   of six bodies; ``--quick``: ``synth-retarget-tiny-v5``), split into its public and
   private parts;
2. run every retargeting baseline the toolkit provides into submissions;
3. validate and score them, and print the leaderboard;
4. when the UV stage is installed: build the ``synth-uvparam-mini-v1`` mesh set, run the UV
   baselines (and the neural method with its shipped pretrained models), score them and
   print their leaderboard;
5. when the capture and fusion stages are installed: render one synthetic capture of a sample,
   fuse it and report its fusion quality against the scan.
6. write the report site of every result (``runs/<time>/site/index.html``: sortable
   leaderboards, a page per method with its best and worst items as pictures) and print
   the path of its index.

Everything is written under ``OUT`` (default ``./dressmeup-demo``): ``data/`` (reused by
later runs), and a new ``runs/<time>/`` folder per run with ``submissions/``, ``results/``
and the leaderboards (``leaderboard-*.md|html``), so nothing is ever overwritten.
"""

from __future__ import annotations

import datetime as _dt
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from dressmeup.bench.boards.leaderboard import write_leaderboard
from dressmeup.data.sample_capture import fuse_synthetic_sample
from dressmeup.errors import DressmeupError
from dressmeup.viz.site import write_site

DEMO_EDITION = "synth-retarget-mini-v5"
QUICK_EDITION = "synth-retarget-tiny-v5"
UV_EDITION = "synth-uvparam-mini-v1"
#: UV baselines run by the demo (the neural method runs as its own row, pretrained).
UV_DEMO_METHODS = ("xatlas", "lscm", "harmonic", "slim")
#: the neural UV row: the shipped pretrained models (the garment's category, else the
#: general one): inference only, about 2 s a mesh (training per mesh is too slow for a demo)
NEURAL_DEMO = {"pretrained": "category"}


def _run_folder(out: Path) -> Path:
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d-%H%M%S")
    run = out / "runs" / stamp
    i = 1
    while run.exists():
        i += 1
        run = out / "runs" / f"{stamp}-{i}"
    run.mkdir(parents=True)
    return run


def run_demo(out: str | os.PathLike | None = None, workers: int | None = None,
             quick: bool = False, log: Callable[[str], Any] = lambda s: None,
             retarget_methods: list[str] | None = None, with_uv: bool = True,
             with_fusion: bool = True, train_steps: int = 0,
             serve: bool = False) -> dict[str, Any]:
    """Run the demo journey; return a dict with the paths and leaderboards it made.

    Parameters
    ----------
    out : work folder (default ``./dressmeup-demo``).
    workers : data-generation and scoring worker processes (default: every core).
    quick : the tiny edition (procedural body; about a minute).
    log : called with each line of the report.
    retarget_methods : restrict the retargeting baselines (default: every available one).
    with_uv, with_fusion : include the UV and capture/fusion parts when installed.
    train_steps : self-supervised training steps for trainable baselines without shipped
        weights (0: such baselines are skipped with a line saying how to train them).
    serve : also start an evaluation server on 127.0.0.1 with the edition's private part,
        submit the baselines to it over HTTP and publish them; the running server is
        returned as ``report["server"]`` (a :class:`~dressmeup.server.local.LocalServer`:
        the caller stops it with ``report["server"].__exit__()``).

    Returns
    -------
    dict with ``run`` (folder), ``results`` (list of result folders), ``leaderboard`` (the
    retargeting table in Markdown), ``ok``.
    """
    # heavy: pandas
    from dressmeup import runs

    t0 = time.perf_counter()
    out = Path(out) if out is not None else Path.cwd() / "dressmeup-demo"
    run = _run_folder(out)
    report: dict[str, Any] = {"run": run, "results": [], "ok": True}
    edition = QUICK_EDITION if quick else DEMO_EDITION
    log(f"[1/4] synthetic dataset for edition {edition} -> {out / 'data' / edition}"
        + ("" if quick else " (the first run also builds the anny body model: a few "
           "minutes, with progress lines)"))
    parts = runs.build_parts(edition, out / "data" / edition, log=log,
                             allow_other_data=True, workers=workers)
    other = runs.data_differs(edition, parts.full) is not None

    log("[2/4] retargeting baselines on the public part -> submissions")
    kw = {"train_steps": train_steps}
    subs = runs.run_baselines(edition, parts.public, run / "submissions" / edition,
                              methods=retarget_methods, log=log, **kw)
    if not subs:
        log("no retargeting baseline produced a submission; nothing to score")
        report["ok"] = False
        return report

    log(f"[3/4] scoring {len(subs)} submissions against the private part (validated first)")
    # data this machine generated differently from the pin: the demo still ends in a
    # leaderboard, its rows marked not comparable (build_data has said why)
    results = runs.score_many(subs, edition, parts.private, run / "results" / edition,
                              workers=workers, log=log, allow_other_data=other)
    report["results"] += results
    md = write_leaderboard(results, "md", run / f"leaderboard-{edition}.md")
    write_leaderboard(results, "html", run / f"leaderboard-{edition}.html")
    report["leaderboard"] = md
    log("")
    log(f"Leaderboard {edition}:")
    log(md)
    if serve:
        _serve_part(edition, parts.private, list(subs.values()), run, log, report)

    log("[4/4] other stages")
    if with_uv:
        _uv_part(run, out, workers, quick, log, report)
    if with_fusion:
        _fusion_part(parts.private, run, quick, log, report)
    _site_part(run, log, report)
    log(f"done in {time.perf_counter() - t0:.0f} s; everything is under {run}")
    if report.get("site"):
        log(f"open the report site: {report['site']}")
    return report


def _uv_part(run: Path, out: Path, workers: int | None, quick: bool, log, report) -> None:
    # heavy: pandas
    from dressmeup import runs

    available = runs.uvparam_methods()
    if not available:
        log("UV parameterisation baselines not installed: UV part skipped")
        return
    methods = [m for m in UV_DEMO_METHODS if m in available]
    if quick:
        methods = methods[:2]
    data = runs.build_data(UV_EDITION, out / "data" / UV_EDITION, log=log)
    subs = runs.run_baselines(UV_EDITION, data, run / "submissions" / UV_EDITION,
                              methods=methods, log=log)
    if "neural" in available:
        try:
            subs["neural"] = runs.run_uvparam_baseline(
                "neural", UV_EDITION, data, run / "submissions" / UV_EDITION / "neural",
                log=log, **NEURAL_DEMO)
        except DressmeupError as exc:  # e.g. the shipped weights are not installed
            log(f"  neural: skipped ({exc})")
    if not subs:
        return
    results = runs.score_many(subs, UV_EDITION, data, run / "results" / UV_EDITION,
                              workers=workers, log=log,
                              allow_other_data=runs.data_differs(UV_EDITION, data) is not None)
    report["results"] += results
    md = write_leaderboard(results, "md", run / f"leaderboard-{UV_EDITION}.md")
    write_leaderboard(results, "html", run / f"leaderboard-{UV_EDITION}.html")
    report["uv_leaderboard"] = md
    log(f"Leaderboard {UV_EDITION}:")
    log(md)


def _serve_part(edition: str, private: Path, subs: list[Path], run: Path, log,
                report) -> None:
    """Start an evaluation server, submit the baselines over HTTP, publish them."""
    # heavy: fastapi
    from dressmeup.server.local import LocalServer, submit_all

    local = LocalServer(run / "server").__enter__()
    log(f"evaluation server on {local.url}: submitting {len(subs)} baselines as team 'demo'")
    submit_all(local, edition, private, subs, log)
    report["server"] = local
    log(f"public leaderboard: {local.url}/leaderboard/ (team page: {local.url}/team)")


def _site_part(run: Path, log, report) -> None:
    """Write the report site of every result of this run (``run/site/index.html``)."""

    if not report["results"]:
        return
    log("report site: leaderboards, a page per method with pictures of its best and worst "
        "items")
    site = write_site(report["results"], run / "site")
    report["site"] = site.index.resolve()
    log(f"report site written in {site.seconds:.0f} s ({len(site.method_pages)} method pages, "
        f"{site.images} pictures)")


def _fusion_part(data: Path, run: Path, quick: bool, log, report) -> None:
    """Render one synthetic capture of a test sample, fuse it, score it against the scan."""
    try:
        res = fuse_synthetic_sample(data, run / "fusion", n_samples=50_000 if quick else 100_000)
    except (ImportError, AttributeError) as exc:
        log(f"capture/fusion stage not available ({exc}): fusion part skipped")
        return
    report["fusion"] = res
    log(f"fused one synthetic 7-camera capture of {res['sample_id']} ({res['seconds']:.0f} s): "
        f"accuracy {res['accuracy'] * 1000:.2f} mm, completeness {res['completeness'] * 1000:.2f}"
        f" mm against the whole scan (surfaces no camera sees included), F-score@5mm "
        f"{res['fscore_5mm'] * 100:.1f} %; fused mesh {res['mesh']}")
