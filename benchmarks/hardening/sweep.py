"""The hardening sweep: bad input on every command of the command line, counted.

Runs every case of ``cases_options`` (each numeric option negative, zero, huge, of the
wrong type or unit), ``cases_files`` (each input file missing, empty, truncated, random, of
the wrong kind, bombed) and ``cases_known`` (known bad inputs, one command line each;
output folders: an existing file as --out, two writers into one folder, resumed builds),
each in a forked child with a memory and a time limit (``runner``), and prints the counts
per outcome (clear error / correct / traceback / crash / accepted / damaged / refused
valid) with one line per case that is not a clear error or correct.

    python benchmarks/hardening/sweep.py                     # every case (about 20 min)
    python benchmarks/hardening/sweep.py --only register      # cases whose name has it
    python benchmarks/hardening/sweep.py --json out.json      # also every case's outcome

Heavy (minutes of CPU): run it alone on the machine.
The regression tests in tests/ are the CI guarantee; this script is the wide net.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import cases_files  # noqa: E402 - after the environment above
import cases_known  # noqa: E402
import cases_options  # noqa: E402
import fixtures  # noqa: E402
from runner import OUTCOMES, classify, run_case  # noqa: E402


def _preload() -> None:
    """Import what the commands use once, so that each forked case starts in milliseconds."""
    import open3d  # noqa: F401
    import pandas  # noqa: F401
    import pyarrow.parquet  # noqa: F401
    import scipy.spatial  # noqa: F401
    import torch  # noqa: F401
    import trimesh  # noqa: F401

    import dressmeup.bench  # noqa: F401
    import dressmeup.cli  # noqa: F401
    import dressmeup.data  # noqa: F401
    import dressmeup.runs  # noqa: F401
    import dressmeup.viz.site  # noqa: F401


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=None,
                    help="work folder (fixtures are kept there between runs)")
    ap.add_argument("--only", default=None, help="run the cases whose name contains this")
    ap.add_argument("--group", default=None, help="options, files, known or outputs")
    ap.add_argument("--mem-gb", type=float, default=4.0,
                    help="address space a case may add to the sweep's (default 4 GiB)")
    ap.add_argument("--json", type=Path, default=None, help="write every outcome here")
    ap.add_argument("--list", action="store_true", help="list the cases and stop")
    args = ap.parse_args()
    cases = cases_options.cases() + cases_files.cases() + cases_known.cases()
    if args.only:
        cases = [c for c in cases if args.only in c.name]
    if args.group:
        cases = [c for c in cases if c.group == args.group]
    if args.list:
        for c in cases:
            print(f"{c.group:8s} {c.name}")
        print(f"{len(cases)} cases")
        return 0
    work = args.work or Path(tempfile.mkdtemp(prefix="dressmeup-sweep-"))
    os.environ.setdefault("DRESSMEUP_CACHE", str(work / "cache"))
    _preload()
    fx = fixtures.build(work / "fixtures")
    shutil.rmtree(work / "cases", ignore_errors=True)
    counts: collections.Counter = collections.Counter()
    rows = []
    t0 = time.monotonic()
    for i, case in enumerate(cases):
        wd = work / "cases" / f"{i:04d}"
        try:
            results = run_case(case, wd, fx, args.mem_gb)
            outcome, note = classify(case, results, wd)
            secs = max(r.seconds for r in results)
        except Exception as exc:  # noqa: BLE001 - a broken case must not stop the sweep
            outcome, note, secs = "sweep error", f"{type(exc).__name__}: {exc}", 0.0
        counts[outcome] += 1
        rows.append({"group": case.group, "case": case.name, "outcome": outcome,
                     "note": note, "seconds": round(secs, 1)})
        flag = "" if outcome in ("clear error", "correct") else "  <--"
        print(f"[{i + 1}/{len(cases)}] {outcome:13s} {secs:5.1f}s {case.name}"
              f"{(': ' + note) if flag else ''}{flag}", flush=True)
        shutil.rmtree(wd, ignore_errors=True)
    load = os.getloadavg()
    print(f"\n{len(cases)} cases in {time.monotonic() - t0:.0f} s (load average "
          f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f})")
    for o in (*OUTCOMES, "sweep error"):
        if counts[o] or o in OUTCOMES:
            print(f"  {o:14s} {counts[o]}")
    bad = [r for r in rows if r["outcome"] not in ("clear error", "correct")]
    by_group = collections.Counter((r["group"], r["outcome"]) for r in rows)
    print("  per group: " + ", ".join(f"{g}/{o} {n}" for (g, o), n in sorted(by_group.items())))
    if args.json:
        args.json.write_text(json.dumps({"counts": dict(counts), "cases": rows}, indent=1))
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
