"""A leaderboard's statistics recomputed from the per-item tables of its results: every
cell's interval and median, and the paired separation of two rows (never the summary's
stored figures, which a hand-edited ``summary.json`` could forge)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from dressmeup.bench.scoring.intervals import PairedDifference, crossed_bootstrap, paired_difference

if TYPE_CHECKING:  # pragma: no cover - annotations only
    import pandas as pd


@dataclass(frozen=True)
class CellStats:
    """Recomputed figures of one cell (SI units): mean, median, the interval (None when
    degenerate) and the levels of each factor it rests on."""

    mean: float | None
    median: float | None
    ci: tuple[float, float] | None
    levels: dict[str, int]


def rows_of(table: pd.DataFrame, track: str | None, category: str | None) -> pd.DataFrame:
    """The OK rows of a column (a track, a category or all), indexed by item id."""
    t = table[table["status"] == "ok"] if "status" in table else table
    if track is not None:
        t = t[t["track"].astype(str) == track] if "track" in t else t.iloc[0:0]
    if category is not None:
        t = t[t["category"].astype(str) == category] if "category" in t else t.iloc[0:0]
    return t.set_index("sample_id", drop=False)


def cell_stats(table: pd.DataFrame, metric: str, track: str | None, category: str | None,
               factors: Sequence[str]) -> CellStats:
    """Mean, median and interval of ``metric`` over a column's rows."""
    t = rows_of(table, track, category)
    if metric not in t or not len(t):
        return CellStats(None, None, None, {})
    v = t[metric].to_numpy(dtype=np.float64)
    fin = v[np.isfinite(v)]
    if not fin.size:
        return CellStats(None, None, None, {})
    iv = crossed_bootstrap(v, {f: t[f].to_numpy() for f in factors if f in t}) \
        if any(f in t for f in factors) else None
    ci = None if iv is None or iv.degenerate else (iv.lo, iv.hi)
    return CellStats(float(fin.mean()), float(np.median(fin)), ci,
                     {} if iv is None else dict(iv.levels))


def compare(a: pd.DataFrame, b: pd.DataFrame, metric: str, track: str | None,
            factors: Sequence[str]) -> PairedDifference | None:
    """Paired bootstrap of ``mean(a) - mean(b)`` of ``metric`` over the items both scored
    (None when they share none or the tables lack the metric or every factor)."""
    ta, tb = rows_of(a, track, None), rows_of(b, track, None)
    if metric not in ta or metric not in tb:
        return None
    shared = ta.index.intersection(tb.index)
    facs = [f for f in factors if f in ta]
    if not len(shared) or not facs:
        return None
    return paired_difference(ta.loc[shared, metric].to_numpy(dtype=np.float64),
                             tb.loc[shared, metric].to_numpy(dtype=np.float64),
                             {f: ta.loc[shared, f].to_numpy() for f in facs})
