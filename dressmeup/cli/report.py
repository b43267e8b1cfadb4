"""``dressmeup report``: the static report site of benchmark results (docs/benchmark.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dressmeup.cli.checks import integer, new_output
from dressmeup.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Register the ``report`` subcommand."""
    p = subparsers.add_parser(
        "report", help="write a static website of results: leaderboards, per-method pages "
                       "with pictures",
        description="Write a static, self-contained website (no network: inline CSS and "
                    "script, pictures beside the pages) of benchmark results: an index with "
                    "one sortable leaderboard per edition (intervals and tracks when the "
                    "results have them), one page per method with its numbers, per-category "
                    "bar charts with intervals, its best and worst items as pictures "
                    "(retarget: prediction beside ground truth, P2S heat map in mm, "
                    "penetrating faces red; uvparam: checkerboard renders; fusion: error "
                    "maps) and the sortable per-item table. Without the submission folder or "
                    "the dataset a page shows the numbers and says why there are no "
                    "pictures. Open OUT/index.html in a browser.")
    p.add_argument("results", nargs="+", help="result folders written by 'dressmeup score'")
    p.add_argument("--data", "-d", action="append", default=[],
                   help="dataset root the results were scored on (repeat for several "
                        "editions; matched by manifest sha256; default: the recorded root)")
    p.add_argument("--submissions", "-s", nargs="+", action="extend", default=[],
                   help="submission folders, or folders holding them (default: the paths "
                        "recorded in the results)")
    p.add_argument("--out", "-o", required=True, type=new_output,
                   help="site folder (index.html goes there)")
    p.add_argument("--images-per-side", type=integer(0), default=5,
                   help="best and worst items drawn per method (default 5)")
    p.add_argument("--max-images", type=integer(0), default=120,
                   help="pictures of the whole site at most (default 120)")
    p.set_defaults(func=_report, locks=("out",))


def _report(args: argparse.Namespace) -> int:
    # start-up: the stage loads when the command runs
    from dressmeup.viz.site import write_site

    for option, paths in (("--data", args.data), ("--submissions", args.submissions)):
        for p in paths:
            if not Path(p).is_dir():
                raise InputError(f"{option} {p}: not a folder")

    rep = write_site(args.results, args.out, data_roots=args.data,
                     submissions=args.submissions, images_per_side=args.images_per_side,
                     max_images=args.max_images,
                     log=lambda line: sys.stderr.write(line + "\n"))
    for note in rep.notes:
        sys.stdout.write(f"no pictures: {note}\n")
    sys.stdout.write(f"site written in {rep.seconds:.0f} s ({len(rep.method_pages)} method "
                     f"pages, {rep.images} pictures): {rep.index.resolve()}\n")
    return 0
