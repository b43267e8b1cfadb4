"""Reference results of synth-uvparam-v2: baselines and the shipped pretrained neural models on
the unseen test garments (and the shape group), scored with seams, per track.

    python benchmarks/uvparam_v2.py --data DATA --runs lscm lscm-70 xatlas neural-pretrained
    python benchmarks/uvparam_v2.py --data DATA --tables-only      # re-score / re-tabulate

``--allow-other-data`` scores data this machine generated differently from the edition's pin
(rows marked not comparable).

Submissions and results go to ``<work>/subs/<run>`` and ``<work>/results/<run>``
(``--work``, default ``$DRESSMEUP_CACHE/bench/uvparam-v2``); each result's summary, per-item
table and edition are copied to ``benchmarks/results/synth-uvparam-v2/<run>/`` (so that
``dressmeup leaderboard benchmarks/results/synth-uvparam-v2/*/`` rebuilds the table), tables
to ``benchmarks/results/synth-uvparam-v2/leaderboard.{md,csv,tex,html}`` plus
``benchmarks/results/synth-uvparam-v2/groups.md`` (garments vs shapes, Pareto front marked).
Each run prints the load average beside its time: the machine is shared.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

EDITION = "synth-uvparam-v2"
RESULTS = Path(__file__).resolve().parent / "results"
#: run name -> (method, hyperparameters, display name)
RUNS = {
    "lscm": ("lscm", {}, "lscm"),
    "lscm-70": ("lscm", {"cone_angle": 70.0}, "lscm (70° cones)"),
    "lscm-90": ("lscm", {"cone_angle": 90.0}, "lscm (90° cones)"),
    "harmonic": ("harmonic", {}, "harmonic"),
    "slim": ("slim", {}, "slim"),
    "xatlas": ("xatlas", {}, "xatlas"),
    "neural-pretrained": ("neural", {"pretrained": "category"}, "neural (pretrained)"),
    "neural-general": ("neural", {"pretrained": "general"}, "neural (pretrained, general)"),
    "lscm-on-charts": ("lscm-on-charts", {"pretrained": "category"},
                       "lscm on the neural charts"),
}


def run(name: str, data: Path, work: Path, allow_other_data: bool = False) -> Path:
    from dressmeup import runs
    from dressmeup.bench.scoring.score import score_submission

    method, params, display = RUNS[name]
    sub, res = work / "subs" / name, work / "results" / name
    for p in (sub, res):
        if p.exists():
            shutil.rmtree(p)
    t0, load0 = time.time(), os.getloadavg()[0]
    runs.run_uvparam_baseline(method, EDITION, data, sub, **params)
    meta = json.loads((sub / "submission.json").read_text())
    meta["method"] = display
    (sub / "submission.json").write_text(json.dumps(meta, indent=2) + "\n")
    print(f"{name}: {time.time() - t0:.0f} s wall (load {load0:.1f} -> {os.getloadavg()[0]:.1f}), "
          f"track {meta.get('track')}", flush=True)
    score_submission(sub, EDITION, data, res, workers=1, show_progress=False,
                     allow_other_data=allow_other_data)
    return res


def group_table(results: list[Path]) -> str:
    """Per group (garments by category, shapes) means of the key metrics, Pareto front marked."""
    import pandas as pd

    from dressmeup.bench.tasks.uvparam.render import pareto_front

    rows = []
    for r in results:
        summ = json.loads((r / "summary.json").read_text())
        t = pd.read_parquet(r / "per_sample.parquet")
        t = t[t["status"] == "ok"]
        name = summ["method"]["method"]
        track = t["track"].iloc[0] if "track" in t and len(t) else ""
        for group, sel in (("garments (test)", t["category"] != "shapes"),
                           ("shapes", t["category"] == "shapes")):
            g = t[sel]
            if len(g):
                rows.append({"group": group, "method": name, "track": track, "n": len(g),
                             **{m: float(g[m].mean()) for m in
                                ("qce", "seam_length", "charts", "packing", "flip", "overlap",
                                 "time")}})
    df = pd.DataFrame(rows)
    out = []
    for group, g in df.groupby("group", sort=False):
        front = pareto_front({r.method: {"qce": r.qce, "seam_length": r.seam_length}
                              for r in g.itertuples()})
        out.append(f"### {group}\n\n| method | track | meshes | QCE ↓ | seam length ↓ | charts | "
                   "packing ↑ | flipped ↓ | overlap ↓ | time [s] | Pareto (QCE, seams) |\n"
                   "|---|---|--:|--:|--:|--:|--:|--:|--:|--:|:-:|")
        for r in g.sort_values("qce").itertuples():
            out.append(f"| {r.method} | {r.track} | {r.n} | {r.qce:.3f} | {r.seam_length:.2f} | "
                       f"{r.charts:.1f} | {100 * r.packing:.1f} % | {100 * r.flip:.2f} % | "
                       f"{100 * r.overlap:.2f} % | {r.time:.2f} | {'◆' if r.method in front else ''} |")
        out.append("")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, type=Path, help="the synth-uvparam-v2 mesh set")
    ap.add_argument("--runs", nargs="+", default=list(RUNS), choices=list(RUNS))
    ap.add_argument("--work", type=Path, default=None)
    ap.add_argument("--tables-only", action="store_true")
    ap.add_argument("--rescore", action="store_true",
                    help="score the existing submissions of --runs again (e.g. after an edition change)")
    ap.add_argument("--allow-other-data", action="store_true",
                    help="score data this machine generated differently from the edition's "
                         "pin (every row is then marked not comparable)")
    args = ap.parse_args(argv)
    from dressmeup.cache import cache_dir

    work = args.work or cache_dir("bench") / "uvparam-v2"
    if args.rescore:
        from dressmeup.bench.scoring.score import score_submission

        for name in args.runs:
            sub, res = work / "subs" / name, work / "results" / name
            if sub.is_dir():
                if res.exists():
                    shutil.rmtree(res)
                score_submission(sub, EDITION, args.data, res, workers=1, show_progress=False,
                                 allow_other_data=args.allow_other_data)
    elif not args.tables_only:
        for name in args.runs:
            run(name, args.data, work, args.allow_other_data)
    results = sorted(p for p in (work / "results").iterdir() if (p / "summary.json").is_file())
    from dressmeup.bench.boards.leaderboard import write_leaderboard

    RESULTS.mkdir(parents=True, exist_ok=True)
    committed = RESULTS / EDITION
    for old in (committed.iterdir() if committed.is_dir() else ()):
        if old.is_dir():  # the results of an earlier run; the tables are rewritten below
            shutil.rmtree(old)
    copies = []
    for r in results:
        (committed / r.name).mkdir(parents=True)
        for f in ("summary.json", "per_sample.parquet", "edition.json"):
            shutil.copyfile(r / f, committed / r.name / f)
        copies.append(committed / r.name)
    results = copies
    for fmt, ext in (("md", "md"), ("csv", "csv"), ("latex", "tex"), ("html", "html")):
        write_leaderboard(results, fmt, committed / f"leaderboard.{ext}")
    text = (f"# {EDITION}: garments vs shapes\n\nMeans over the test garments (unseen by the "
            "pretrained models) and over the shape group; ◆ = on the Pareto front of QCE and "
            "seam length within the group.\n\n" + group_table(results))
    (committed / "groups.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
