"""Subcommands of the bench stage: ``validate-submission``, ``score``, ``leaderboard``,
``editions``, ``demo`` (see docs/benchmark.md and docs/cli.md)."""

from __future__ import annotations

import argparse
import json
import sys

from dressmeup.cli.baseline_retarget import MAX_STEPS
from dressmeup.cli.checks import integer, new_output, output_file
from dressmeup.cli.executor_args import add_executor_args, executor_from_args
from dressmeup.limits import WORKERS


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register the bench subcommands."""
    _add_validate(subparsers)
    _add_score(subparsers)
    _add_leaderboard(subparsers)
    _add_editions(subparsers)
    _add_demo(subparsers)


def _add_validate(subparsers: argparse._SubParsersAction) -> None:
    """``validate-submission``: every problem of a submission at once."""
    p = subparsers.add_parser(
        "validate-submission", help="check a submission folder against an edition",
        description="Check a submission folder (submission.json + one file per item) against "
                    "a benchmark edition and its dataset. Every problem is listed at once "
                    "(missing/extra ids, unreadable files, wrong vertex counts, NaN/inf, "
                    "faces out of range, files over the size limit, submission.json fields). "
                    "Exit status 0 when valid, 1 when not.")
    p.add_argument("submission", help="submission folder")
    p.add_argument("--edition", "-e", required=True,
                   help="edition name (see 'dressmeup editions') or path to an edition JSON")
    p.add_argument("--data", "-d", required=True, help="dataset root the edition is scored on")
    p.add_argument("--max-per-kind", type=integer(0), default=50,
                   help="problems printed per kind (default 50; 0 = all)")
    p.set_defaults(func=_validate)


def _add_score(subparsers: argparse._SubParsersAction) -> None:
    """``score``: validate and score a submission into a new results folder."""
    p = subparsers.add_parser(
        "score", help="validate and score a submission into a new results folder",
        description="Validate a submission (scoring never starts on an invalid one), score "
                    "every item in parallel (local cores, or Dask with --executor dask) and write RESULTS/ "
                    "(per_sample.parquet, summary.json with provenance, edition.json). "
                    "RESULTS must not exist or be empty: results are never overwritten.")
    p.add_argument("submission", help="submission folder")
    p.add_argument("--edition", "-e", required=True, help="edition name or JSON path")
    p.add_argument("--data", "-d", required=True, help="dataset root the edition is scored on")
    p.add_argument("--out", "-o", required=True, type=new_output, help="new results folder")
    p.add_argument("--allow-other-data", action="store_true",
                   help="score data whose manifest differs from the edition's expected one "
                        "(the result is marked 'not comparable' in every leaderboard)")
    add_executor_args(p, default_workers=None, what="scored item")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.set_defaults(func=_score, locks=("out",))


def _add_leaderboard(subparsers: argparse._SubParsersAction) -> None:
    """``leaderboard``: results of one edition as a table."""
    p = subparsers.add_parser(
        "leaderboard", help="turn results of one edition into a table (md, csv, latex, html)",
        description="Build a leaderboard from result folders of ONE edition and dataset: one "
                    "row per method, a column per metric (and per category), units and "
                    "direction arrows in the headers, best values marked, sorted by the "
                    "primary metric. Results of schema dressmeup-result/2 show 95 % bootstrap "
                    "intervals over the task's independent unit as 'mean [lo, hi]', a 'Sep.' "
                    "column (paired bootstrap: is the rank separated from the next?) and one "
                    "column per track; older results show '–'. Mixing editions or datasets "
                    "is refused, except results marked not comparable (--allow-other-data), "
                    "which are listed last, unranked. For a website with pictures see "
                    "'dressmeup report'.")
    p.add_argument("results", nargs="+", help="result folders written by 'dressmeup score'")
    p.add_argument("--format", "-f", choices=("md", "csv", "latex", "html"), default="md")
    p.add_argument("--out", "-o", default=None, type=output_file,
                   help="output file (default: print)")
    p.add_argument("--sort-by", default=None, help="metric to sort by (default: primary)")
    p.add_argument("--std", action="store_true", help="show mean ± std")
    p.add_argument("--per-category", default=None,
                   help="comma-separated metrics shown per category ('none' for none; "
                        "default: the edition's)")
    p.set_defaults(func=_leaderboard, locks=("out",))


def _add_editions(subparsers: argparse._SubParsersAction) -> None:
    """``editions``: list the shipped editions, or show one."""
    p = subparsers.add_parser(
        "editions", help="list the shipped benchmark editions (or show one)",
        description="List the benchmark editions shipped with the toolkit, or print one "
                    "edition's JSON with its hash.")
    p.add_argument("name", nargs="?", default=None, help="edition name or path to show")
    p.set_defaults(func=_editions)


def _add_demo(subparsers: argparse._SubParsersAction) -> None:
    """``demo``: the whole journey on a small synthetic dataset."""
    p = subparsers.add_parser(
        "demo", help="the whole journey on a small synthetic dataset (a few minutes)",
        description="Generate a small synthetic dataset, run every available retargeting "
                    "baseline (and UV baselines / one fused synthetic capture when those "
                    "stages are installed), score them and print a leaderboard.")
    p.add_argument("--out", "-o", default=None, type=new_output,
                   help="work folder (default: a new folder under ./dressmeup-demo)")
    p.add_argument("--workers", "-j", type=integer(1, WORKERS), default=None,
                   help="data-generation and scoring workers (default: every core)")
    p.add_argument("--quick", action="store_true",
                   help="the tiny edition (procedural body, 2 pairs): a few minutes")
    p.add_argument("--serve", action="store_true",
                   help="also run an evaluation server on 127.0.0.1, submit the baselines to "
                        "it over HTTP, publish them, and keep serving until Ctrl-C")
    p.add_argument("--train-steps", type=integer(0, MAX_STEPS), default=0,
                   help="train trainable baselines without shipped weights for this many "
                        "self-supervised steps (default 0: skip them)")
    p.set_defaults(func=_demo, locks=("out",))


def _validate(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.scoring.validate import validate_submission

    report = validate_submission(args.submission, args.edition, args.data)
    n = args.max_per_kind or None
    stream = sys.stdout if report.ok else sys.stderr
    stream.write(report.summary(max_per_kind=n) + "\n")
    return 0 if report.ok else 1


def _score(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.boards.leaderboard import format_summary
    from dressmeup.bench.scoring.score import InvalidSubmissionError, score_submission

    executor = executor_from_args(args)
    try:
        res = score_submission(args.submission, args.edition, args.data, args.out,
                               executor=executor,
                               show_progress=False if args.no_progress else None,
                               allow_other_data=args.allow_other_data)
    except InvalidSubmissionError as exc:
        sys.stderr.write(f"dressmeup score: not scored, the submission is invalid:\n"
                         f"{exc.report.summary(max_per_kind=20)}\n")
        return 1
    sys.stdout.write(format_summary(res.summary) + f"\nresults written to {res.path}\n")
    return 0


def _leaderboard(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.boards.leaderboard import write_leaderboard

    per_cat = None
    if args.per_category is not None:
        per_cat = [] if args.per_category.strip().lower() in ("", "none") else [
            m.strip() for m in args.per_category.split(",") if m.strip()]
    text = write_leaderboard(args.results, args.format, args.out, sort_by=args.sort_by,
                             show_std=args.std, per_category=per_cat)
    if args.out:
        sys.stdout.write(f"leaderboard written to {args.out}\n")
    else:
        sys.stdout.write(text)
    return 0


def _editions(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.bench.edition import list_editions, load_edition

    if args.name:
        ed = load_edition(args.name)
        sys.stdout.write(json.dumps(ed.to_dict(), indent=2) + f"\n# hash {ed.hash}\n")
        return 0
    for name in list_editions():
        ed = load_edition(name)
        sys.stdout.write(f"{name:28s} task={ed.task:14s} split={ed.split:6s} "
                         f"hash={ed.hash[:12]}  {(ed.description[:60] + '...') if len(ed.description) > 60 else ed.description}\n")
    return 0



def _demo(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.demo import run_demo

    res = run_demo(out=args.out, workers=args.workers, quick=args.quick,
                   train_steps=args.train_steps, serve=args.serve,
                   log=lambda line: sys.stdout.write(line + "\n") or sys.stdout.flush())
    server = res.get("server")
    if server is not None:
        sys.stdout.write(f"serving {server.url}/leaderboard/ until Ctrl-C\n")
        sys.stdout.flush()
        try:
            server.wait_forever()
        finally:
            server.__exit__(None, None, None)
    return 0 if res.get("ok", True) else 1
