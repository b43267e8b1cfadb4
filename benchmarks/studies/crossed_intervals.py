"""Re-read per-pair results of ``retarget_variants.py`` with the benchmark's crossed intervals.

``retarget_variants.py`` reports intervals that resample source garments only. The
leaderboards resample garments, target subjects and target poses together
(``dressmeup.bench.scoring.intervals.crossed_bootstrap``, factors ``UNIT_COLUMNS`` of the retarget
task), which is wider when a body or a pose is hard for every method. This script recomputes,
from a committed per-pair JSON, the paired difference of chosen method pairs both ways, so a
study's "separated" can be checked against the leaderboard's rule without re-running any
method (seconds, no data needed).

    python benchmarks/studies/crossed_intervals.py benchmarks/results/studies/2026-12-01-retarget_v3_cross.json \\
        --pairs isomap-refine-sup:isomap-refine-fast isomap-refine:skinning \\
        --out benchmarks/results/studies/2026-12-04-retarget_v3_cross_crossed.md
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from dressmeup.bench.scoring.intervals import paired_difference
from dressmeup.io.atomic import atomic_write_text

#: metric -> (scale to the printed unit, format)
METRICS = {"p2s": (1000.0, ".2f"), "ed": (1000.0, ".2f"), "nc": (1.0, ".4f"), "ir": (100.0, ".2f")}


def _target_factors(pair_id: str) -> tuple[str, str]:
    """Target subject and pose of ``<subject>-<garment>-<pose>__to__<subject>-<garment>-<pose>``."""
    target = pair_id.split("__to__")[1].split("-")
    if len(target) != 3:
        raise ValueError(f"pair id {pair_id!r}: expected '<S>-<G>-<P>__to__<S>-<G>-<P>'")
    return target[0], target[2]


def _cell(d, scale: float, fmt: str) -> str:
    if d is None:
        return "-"
    sep = "sep." if d.separated else "not sep."
    return f"{scale * d.diff:+{fmt}} [{scale * d.lo:+{fmt}}, {scale * d.hi:+{fmt}}] {sep}"


def crossed_table(rows: list[dict], pairs: list[tuple[str, str]]) -> list[str]:
    """Markdown rows: per method pair and metric, garment-only and crossed paired differences."""
    by: dict[str, dict[str, dict]] = {}
    for r in rows:
        by.setdefault(r["method"], {})[r["pair"]] = r
    lines = ["| a - b | metric | garment only [95 %] | garments x target subjects x target poses [95 %] |",
             "|---|---|---|---|"]
    for a, b in pairs:
        if a not in by or b not in by:
            raise ValueError(f"--pairs {a}:{b}: methods in the file are {sorted(by)}")
        shared = sorted(set(by[a]) & set(by[b]))
        garment = [by[a][p]["garment"] for p in shared]
        targets = [_target_factors(p) for p in shared]
        crossed = {"garment_id": garment, "target_subject": [t[0] for t in targets],
                   "target_pose": [t[1] for t in targets]}
        for m, (scale, fmt) in METRICS.items():
            x = [by[a][p][m] for p in shared]
            y = [by[b][p][m] for p in shared]
            lines.append(f"| `{a}` - `{b}` | {m} | {_cell(paired_difference(x, y, garment), scale, fmt)} | "
                         f"{_cell(paired_difference(x, y, crossed), scale, fmt)} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("results", help="per-pair JSON written by retarget_variants.py")
    ap.add_argument("--pairs", nargs="+", required=True, help="A:B method pairs (difference A - B)")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    pairs = [tuple(p.split(":", 1)) for p in args.pairs]
    rows = json.loads(Path(args.results).read_text())["rows"]
    n = len({r["pair"] for r in rows})
    text = "\n".join([
        f"# Crossed intervals for `{args.results}`", "",
        f"{n} pairs. Paired differences of the item means (P2S and ED in mm, IR in %), 95 % "
        "intervals: resampling source garments only (as the study printed them) and resampling "
        "garments, target subjects and target poses together (the leaderboards' rule, "
        "`dressmeup.bench.scoring.intervals.crossed_bootstrap`). Produced by "
        f"`python benchmarks/studies/crossed_intervals.py {args.results} --pairs {' '.join(args.pairs)}`.",
        "", *crossed_table(rows, pairs)]) + "\n"
    print(text)  # noqa: T201
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, text)


if __name__ == "__main__":
    main()
