"""Regenerate the reference leaderboards in benchmarks/results/.

For each edition: generate (or reuse) its pinned data and split it into its public and
private parts, run every available baseline on the public part into submissions, score them
against the private part into a NEW run folder, then rewrite on purpose
``benchmarks/results/<edition>/<method>/`` (each result's ``summary.json``,
``per_sample.parquet`` and ``edition.json``, so that anyone can recheck a figure:
``dressmeup leaderboard benchmarks/results/<edition>/*/`` recomputes the table and its
intervals from them) and ``benchmarks/results/<edition>/leaderboard.{md,csv,tex,html}`` (``dressmeup
score`` itself never overwrites anything; this script owns those files).

    python benchmarks/run_baselines.py                              # every reference edition
    python benchmarks/run_baselines.py --editions synth-uvparam-v1 --methods xatlas lscm
    python benchmarks/run_baselines.py --work /tmp/bench --workers 2
    python benchmarks/run_baselines.py --work /tmp/bench --executor dask --workers 2
    python benchmarks/run_baselines.py --work W --editions synth-retarget-v5 \
        --secret ../shared/secrets/synth-retarget-v5.secret --methods skinning
    python benchmarks/run_baselines.py --work W --editions E --methods isomap-refine \
        --keep-results W/runs/<earlier UTC time> ...  # re-run one method, keep the others

Data go to ``<work>/data/<edition>`` (reused across runs), submissions and results to
``<work>/runs/<UTC time>/``; ``<work>`` defaults to the toolkit cache
(``$DRESSMEUP_CACHE/bench``).
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as dt
import sys
import time
from pathlib import Path

REFERENCE_EDITIONS = ("synth-retarget-mini-v5", "synth-retarget-v4", "synth-retarget-mini-v4",
                      "synth-retarget-v3", "synth-retarget-thesis-v3", "synth-retarget-mini-v3",
                      "synth-uvparam-v2")
RESULTS = Path(__file__).resolve().parent / "results"


def main(argv: list[str] | None = None) -> int:
    from dressmeup.cli.executor_args import add_executor_args, executor_from_args

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--editions", nargs="+", default=list(REFERENCE_EDITIONS))
    ap.add_argument("--methods", nargs="+", default=None,
                    help="restrict to these baselines (default: every available one)")
    ap.add_argument("--work", default=None, help="work folder (default: the toolkit cache)")
    add_executor_args(ap, default_workers=None, what="scored item, and with --executor or "
                                                  "--scheduler also per baseline pair / mesh")
    ap.add_argument("--train-steps", type=int, default=300,
                    help="self-supervised training steps of trainable retargeting baselines")
    ap.add_argument("--results", default=str(RESULTS), help="where the tables are rewritten")
    ap.add_argument("--secret", default=None, metavar="FILE",
                    help="the test-split secret of an edition that publishes only its "
                         "commitment (synth-retarget-v5: the maintainers' file, read by path)")
    ap.add_argument("--allow-other-data", action="store_true",
                    help="score data this machine generated differently from the edition's pin "
                         "(every row is then marked not comparable)")
    ap.add_argument("--keep-results", nargs="+", default=None, metavar="RUN",
                    help="with --methods: the tables also show the other methods' results from "
                         "earlier run folders (RUN/results/<edition>/<method>; a later RUN wins), "
                         "unchanged")
    args = ap.parse_args(argv)

    executor = executor_from_args(args)
    # baselines: serial as before unless the switch is given; scoring: the executor
    baseline_executor = executor if (args.executor or args.scheduler) else None
    with contextlib.ExitStack() as stack:
        if executor.name == "dask":
            stack.enter_context(executor)  # one cluster for every run of this script
        return _run(args, executor, baseline_executor)


def _run(args: argparse.Namespace, executor, baseline_executor) -> int:
    """Every edition of ``args``: data, baselines (through ``baseline_executor``; None: in
    this process), scoring (through ``executor``), tables."""
    from dressmeup import runs
    from dressmeup.bench import load_edition
    from dressmeup.bench.boards.leaderboard import write_leaderboard
    from dressmeup.cache import cache_dir

    work = Path(args.work) if args.work else cache_dir("bench")
    stamp = dt.datetime.now(dt.timezone.utc).strftime("%Y%m%d-%H%M%S")
    run = work / "runs" / stamp
    log = print
    for name in args.editions:
        t0 = time.perf_counter()
        ed = load_edition(name)
        log(f"== {ed.name} ({ed.task}) ==")
        # only a sealed test split takes the file (a published secret is in the edition)
        secret = args.secret if ed.dataset is not None and ed.dataset.sealed else None
        parts = runs.build_parts(ed, work / "data" / ed.name, log=log,
                                 allow_other_data=args.allow_other_data, secret_file=secret)
        kw = {"train_steps": args.train_steps} if ed.task == "retarget" else {}
        subs = runs.run_baselines(ed, parts.public, run / "submissions" / ed.name,
                                  methods=args.methods, log=log, executor=baseline_executor,
                                  **kw)
        if not subs:
            log(f"no submissions for {ed.name}; tables left unchanged")
            continue
        results = runs.score_many(subs, ed, parts.private, run / "results" / ed.name,
                                  executor=executor, log=log,
                                  allow_other_data=args.allow_other_data)
        results += _kept_results(args.keep_results, ed.name, {r.name for r in results}, log)
        out = Path(args.results)
        out.mkdir(parents=True, exist_ok=True)
        results = _commit_results(results, out / ed.name)
        for fmt, ext in (("md", "md"), ("csv", "csv"), ("latex", "tex"), ("html", "html")):
            write_leaderboard(results, fmt, out / ed.name / f"leaderboard.{ext}")
        log(write_leaderboard(results, "md"))
        log(f"{ed.name}: rewrote {out}/{ed.name}/leaderboard.{{md,csv,tex,html}} "
            f"({time.perf_counter() - t0:.0f} s; run folder {run})")
    return 0


def _commit_results(results: list[Path], dest: Path) -> list[Path]:
    """Copy each result folder's summary, per-item table and edition to ``dest/<method>/``
    (replacing the edition's previously committed results; the edition folder's files stay)
    and return the copies."""
    import shutil

    for old in (dest.iterdir() if dest.is_dir() else ()):
        if old.is_dir():
            shutil.rmtree(old)
    out = []
    for res in results:
        target = dest / Path(res).name
        target.mkdir(parents=True)
        for name in ("summary.json", "per_sample.parquet", "edition.json"):
            if (Path(res) / name).is_file():
                shutil.copyfile(Path(res) / name, target / name)
        out.append(target)
    return out


def _kept_results(keep: list[str] | None, edition: str, fresh: set[str], log) -> list[Path]:
    """Result folders of methods not re-run, from earlier run folders (a later one wins)."""
    kept: dict[str, Path] = {}
    for run in keep or []:
        root = Path(run) / "results" / edition
        if not root.is_dir():
            raise SystemExit(f"--keep-results {run}: no folder {root}")
        kept.update({p.name: p for p in root.iterdir()
                     if (p / "summary.json").is_file() and p.name not in fresh})
    if kept:
        log(f"kept: {', '.join(f'{k} ({v.parents[2].name})' for k, v in sorted(kept.items()))}")
    return [kept[k] for k in sorted(kept)]


if __name__ == "__main__":
    sys.exit(main())
