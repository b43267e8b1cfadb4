"""Bootstrap confidence intervals over independent units, and paired rank separation.

Items of a benchmark are not independent: the retargeting pairs of one garment share its
geometry, the captures of one subject share the body. Intervals therefore resample whole
*units* (retarget: source garment; uvparam: mesh; registration: subject; fusion: session;
each task config names its ``UNIT_COLUMN``) with replacement and recompute the item mean
over the items of the drawn units (a cluster bootstrap; the statistic is the same item-
weighted mean the tables print). Percentile intervals, seeded.

How few resamples small groups allow
------------------------------------
Drawing ``n`` units with replacement from ``n`` can give only ``C(2n-1, n)`` distinct
multisets: 1 for n = 1 (the interval is a single point: *degenerate*), 3 for n = 2, 10 for
n = 3, 35 for n = 4, 126 for n = 5, 462 for n = 6, 1716 for n = 7. Below about 8 units the
bootstrap distribution is a handful of values, and an interval from it is coarse (its ends
are two of those values) and too narrow (the bootstrap under-covers with few clusters).
:func:`bootstrap_mean` reports ``distinct_resamples`` and ``degenerate`` beside the interval
so tables can say so; read intervals over fewer than ~8 units as indicative only.

Paired separation
-----------------
Two methods scored on the same items are compared on the *same* resampled units
(:func:`paired_difference`): the interval of the difference of their means excludes 0 when
the ranking between them is separated at the 95 % level. Leaderboards give no verdict below
:data:`MIN_UNITS_SEPARATION` shared units: with 2 or 3 units a percentile interval cannot
put less than 2.5 % in a tail, so "separated" would only mean "every unit agrees".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: Bootstrap resamples drawn per interval.
N_RESAMPLES = 2000
#: Seed of the resampling (intervals are reproducible).
SEED = 0
#: Confidence level.
LEVEL = 0.95
#: Below this many units an interval is flagged as coarse in tables and docs.
FEW_UNITS = 8
#: Fewest shared units for a separation verdict: with n units the most extreme resample
#: (every draw the unit with the smallest difference) has probability n^-n (0.25 for 2,
#: 0.037 for 3, 0.0039 for 4), so only from 4 units can a 2.5 % tail leave it out; below
#: that "separated" would just mean "every unit agrees", and tables print "–".
MIN_UNITS_SEPARATION = 4


def distinct_resamples(n_units: int) -> int:
    """Number of distinct multisets of ``n_units`` units drawn with replacement from
    ``n_units``: ``C(2n - 1, n)`` (1 for n = 1, 3 for n = 2, 10 for n = 3)."""
    if n_units <= 0:
        return 0
    return math.comb(2 * n_units - 1, n_units)


@dataclass(frozen=True)
class Interval:
    """A bootstrap percentile interval of an item mean.

    Attributes
    ----------
    mean : the item mean over all finite values (stored units).
    lo, hi : interval ends (stored units); equal to ``mean`` when degenerate.
    n_units : independent units holding at least one finite value.
    n_items : finite values.
    resamples : bootstrap resamples drawn.
    distinct_resamples : ``C(2n-1, n)`` for ``n = n_units``.
    degenerate : True when fewer than 2 units (the interval is a point).
    """

    mean: float
    lo: float
    hi: float
    n_units: int
    n_items: int
    resamples: int
    distinct_resamples: int
    degenerate: bool

    def to_dict(self) -> dict:
        """JSON form stored in ``summary.json`` (``ci95`` + bookkeeping)."""
        return {"ci95": [self.lo, self.hi], "n_units": self.n_units,
                "distinct_resamples": self.distinct_resamples,
                "degenerate": self.degenerate}


def _unit_sums(values: np.ndarray, units: Sequence) -> tuple[np.ndarray, np.ndarray]:
    """Per-unit sums and counts of the finite ``values`` (units in sorted order)."""
    v = np.asarray(values, dtype=np.float64)
    u = np.asarray([str(x) for x in units], dtype=object)
    if v.shape != u.shape:
        raise ValueError(f"values {v.shape} and units {u.shape} differ in length")
    ok = np.isfinite(v)
    keys, inv = np.unique(u[ok].astype(str), return_inverse=True)
    sums = np.bincount(inv, weights=v[ok], minlength=len(keys))
    counts = np.bincount(inv, minlength=len(keys)).astype(np.float64)
    return sums, counts


def _weights(n_units: int, resamples: int, seed: int) -> np.ndarray:
    """``(resamples, n_units)`` multiplicities of each unit in each resample."""
    rng = np.random.default_rng(seed)
    return rng.multinomial(n_units, np.full(n_units, 1.0 / n_units), size=resamples
                           ).astype(np.float64)


def _percentiles(samples: np.ndarray, level: float) -> tuple[float, float]:
    """Percentile ends, rounded outwards to bootstrap values (never interpolated)."""
    a = (1.0 - level) / 2.0
    lo = np.quantile(samples, a, method="lower")
    hi = np.quantile(samples, 1.0 - a, method="higher")
    return float(lo), float(hi)


def bootstrap_mean(values: Sequence[float] | np.ndarray, units: Sequence, *,
                   resamples: int = N_RESAMPLES, seed: int = SEED,
                   level: float = LEVEL) -> Interval | None:
    """Cluster-bootstrap percentile interval of the item mean.

    Parameters
    ----------
    values : ``(n,)`` per-item values (NaN/inf are left out, as in the table means).
    units : ``(n,)`` unit id of each item (garment id, mesh id, subject id, ...).
    resamples, seed, level : bootstrap size, RNG seed, confidence level.

    Returns
    -------
    Interval, or None when no value is finite.
    """
    sums, counts = _unit_sums(values, units)
    n = len(sums)
    if n == 0:
        return None
    mean = float(sums.sum() / counts.sum())
    if n == 1:
        return Interval(mean, mean, mean, 1, int(counts.sum()), 0, 1, True)
    w = _weights(n, resamples, seed)
    boot = (w @ sums) / (w @ counts)
    lo, hi = _percentiles(boot, level)
    return Interval(mean, min(lo, mean), max(hi, mean), n, int(counts.sum()), resamples,
                    distinct_resamples(n), False)


@dataclass(frozen=True)
class PairedDifference:
    """Paired bootstrap of ``mean(a) - mean(b)`` over shared items.

    Attributes
    ----------
    diff : observed difference of the item means over items both methods scored.
    lo, hi : percentile interval of the difference.
    n_units, n_items : shared units and items.
    separated : the interval excludes 0 (False when fewer than 2 units).
    """

    diff: float
    lo: float
    hi: float
    n_units: int
    n_items: int
    separated: bool


def paired_difference(a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray,
                      units: Sequence, *, resamples: int = N_RESAMPLES, seed: int = SEED,
                      level: float = LEVEL) -> PairedDifference | None:
    """Paired cluster bootstrap of the difference of two methods' item means.

    Parameters
    ----------
    a, b : ``(n,)`` values of two methods on the SAME items (aligned); items where either is
        not finite are left out of both.
    units : ``(n,)`` unit id of each item.

    Returns
    -------
    PairedDifference, or None when no item is shared.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    both = np.isfinite(a) & np.isfinite(b)
    d = np.where(both, a - b, np.nan)
    sums, counts = _unit_sums(d, units)
    n = len(sums)
    if n == 0:
        return None
    diff = float(sums.sum() / counts.sum())
    if n == 1:
        return PairedDifference(diff, diff, diff, 1, int(counts.sum()), False)
    w = _weights(n, resamples, seed)
    boot = (w @ sums) / (w @ counts)
    lo, hi = _percentiles(boot, level)
    return PairedDifference(diff, lo, hi, n, int(counts.sum()), bool(lo > 0 or hi < 0))


def describe_resolution(n_units: int) -> str:
    """One sentence on how coarse an interval over ``n_units`` units is (for captions)."""
    if n_units <= 1:
        return ("one independent unit: the interval is degenerate (a single point); the "
                "data cannot say how far the mean would move on other units")
    k = distinct_resamples(n_units)
    if n_units < FEW_UNITS:
        return (f"{n_units} independent units allow only {k} distinct resamples: the "
                "interval is coarse and too narrow; read it as indicative")
    return f"{n_units} independent units ({k:.3g} distinct resamples)"
