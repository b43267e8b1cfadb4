"""Confidence intervals of item means over every factor an edition shares, and paired
separation of two methods.

The items of a benchmark are not independent, and not only through one unit: the pairs of a
retargeting edition share their garment, *and* the few bodies and poses every garment is
worn in; registration scans share subject and pose. A bootstrap that resamples garments only
treats the 4 bodies as fixed, and a nominal 95 % interval then covers the mean of a new
edition far less often (79 % in a simulation with garment SD 10 mm and subject SD 6 mm).

The estimator
-------------
Each task names the factors of its items (``config.UNIT_COLUMNS``: retargeting the garment,
the target subject and the target pose; registration subject and pose; uvparam the mesh).
:func:`crossed_bootstrap` is the reweighting bootstrap for crossed random effects of Owen &
Eckles (2012, *Bootstrapping data arrays of arbitrary order*, Ann. Appl. Stat. 6(3)), a
form of Owen's (2007) pigeonhole bootstrap: in each of :data:`N_RESAMPLES` seeded resamples
every *level* of every factor (each garment, each subject, each pose) draws an independent
weight ``W ~ Poisson(1)``, an item's weight is the product of its levels' weights, and the
statistic is the weighted item mean ``sum(w x) / sum(w)``. Poisson weights (variance 1) do
not shrink a factor's variance by ``(n - 1) / n`` as multinomial resampling does, which
matters with 3 poses or 4 bodies. The interval is the 2.5 and 97.5 % percentiles of the
resampled means, moved away from the mean by ``t(df, 0.975) / z(0.975)`` (and kept inside
the range of the item values, where every weighted mean lies): with so few levels the
variance itself is uncertain, and ``df`` is the Satterthwaite degrees of freedom
``(sum v_f)^2 / sum(v_f^2 / (n_f - 1))`` of the per-factor variance contributions ``v_f``
(resampled means when only factor ``f`` is reweighted). ``tests/bench/test_bench_intervals.py``
checks by simulation (1,000 editions with known garment, subject and pose effects) that the
nominal 95 % interval covers the true mean at least 93 % of the time; it over-covers when
the item noise dominates (the reweighting counts it once per factor), the safe side.

How few levels a group has
--------------------------
:func:`distinct_resamples` counts, per factor, the multisets of ``n`` levels drawn with
replacement, ``C(2n - 1, n)`` (3 for 2 levels, 10 for 3, 35 for 4), and multiplies them over
the factors: a group whose product is under :data:`FEW_RESAMPLES` is flagged in captions
(its interval rests on a handful of configurations).

Paired separation
-----------------
Two methods scored on the same items are compared on the *same* resampled weights
(:func:`paired_difference`): the interval of the difference of their means excludes 0 when
the two are separated at the 95 % level, else the tables say "not separated".
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

#: Bootstrap resamples drawn per interval.
N_RESAMPLES = 2000
#: Seed of the resampling (intervals are reproducible).
SEED = 0
#: Confidence level.
LEVEL = 0.95
#: Groups whose factors allow fewer distinct resamples than this are flagged in captions.
FEW_RESAMPLES = 1000
#: A short name of the estimator, stored with every interval.
METHOD = ("reweighting bootstrap over crossed factors (Owen & Eckles 2012; Poisson(1) weights "
          "per level), percentile interval widened by t(df)/z with Satterthwaite df")


def distinct_resamples(n_units: int) -> int:
    """Number of distinct multisets of ``n_units`` levels drawn with replacement from
    ``n_units``: ``C(2n - 1, n)`` (1 for n = 1, 3 for n = 2, 10 for n = 3)."""
    if n_units <= 0:
        return 0
    return math.comb(2 * n_units - 1, n_units)


def resample_count(levels: Mapping[str, int]) -> int:
    """:func:`distinct_resamples` multiplied over the factors (``{factor: levels}``)."""
    out = 1
    for n in levels.values():
        out *= distinct_resamples(int(n))
    return out


@dataclass(frozen=True)
class Interval:
    """A bootstrap interval of an item mean.

    Attributes
    ----------
    mean : the item mean over all finite values (stored units).
    lo, hi : interval ends (stored units); equal to ``mean`` when degenerate.
    n_items : finite values.
    levels : factor -> number of its levels among those items.
    df : Satterthwaite degrees of freedom of the variance (inf: no widening).
    resamples : bootstrap resamples used.
    distinct_resamples : :func:`resample_count` of ``levels``.
    degenerate : True when no factor has 2 levels (the interval is a point).
    """

    mean: float
    lo: float
    hi: float
    n_items: int
    levels: dict[str, int] = field(default_factory=dict)
    df: float = math.inf
    resamples: int = 0
    distinct_resamples: int = 1
    degenerate: bool = False

    @property
    def n_units(self) -> int:
        """Levels of the first factor (the cluster unit of one-factor tasks)."""
        return next(iter(self.levels.values()), 0)

    def to_dict(self) -> dict:
        """JSON form stored in ``summary.json`` (``ci95`` + bookkeeping)."""
        return {"ci95": [self.lo, self.hi], "levels": dict(self.levels),
                "df": None if not math.isfinite(self.df) else round(self.df, 2),
                "distinct_resamples": self.distinct_resamples,
                "degenerate": self.degenerate}


def _codes(labels: Sequence, keep: np.ndarray) -> tuple[np.ndarray, int]:
    """Integer codes ``(n_kept,)`` of the labels of the kept items and their level count."""
    lab = np.asarray([str(x) for x in labels], dtype=object)[keep]
    _, inv = np.unique(lab.astype(str), return_inverse=True)
    return inv.astype(np.int64), int(inv.max()) + 1 if len(inv) else 0


def _weights(codes: Mapping[str, tuple[np.ndarray, int]], resamples: int, seed: int
             ) -> dict[str, np.ndarray]:
    """Per factor, the ``(resamples, n_items)`` weight of each item's level (Poisson(1) per
    level; factors drawn in name order from one seeded generator)."""
    rng = np.random.default_rng(seed)
    out = {}
    for name in sorted(codes):
        c, n = codes[name]
        out[name] = rng.poisson(1.0, size=(resamples, n)).astype(np.float64)[:, c]
    return out


def _ratio(w: np.ndarray, x: np.ndarray) -> np.ndarray:
    den = w.sum(axis=1)
    ok = den > 0
    return (w[ok] @ x) / den[ok]


def _interval(x: np.ndarray, codes: Mapping[str, tuple[np.ndarray, int]], resamples: int,
              seed: int, level: float) -> tuple[float, float, float, float]:
    """(mean, lo, hi, df) of the weighted-mean bootstrap of ``x`` over the factors."""
    mean = float(x.mean())
    varying = {k: v for k, v in codes.items() if v[1] > 1}
    if not varying:
        return mean, mean, mean, math.inf
    w = _weights(varying, resamples, seed)
    total = np.prod(np.stack(list(w.values())), axis=0)
    boot = _ratio(total, x)
    a = (1.0 - level) / 2.0
    lo = float(np.quantile(boot, a, method="lower"))
    hi = float(np.quantile(boot, 1.0 - a, method="higher"))
    v = {k: float(_ratio(wf, x).var()) for k, wf in w.items()}
    num = sum(v.values()) ** 2
    den = sum(v[k] ** 2 / (varying[k][1] - 1) for k in v)
    df = num / den if den > 0 else math.inf
    # heavy: scipy.special
    from scipy.special import ndtri, stdtrit

    k = float(stdtrit(df, 1.0 - a) / ndtri(1.0 - a)) if math.isfinite(df) else 1.0
    lo, hi = mean - k * (mean - min(lo, mean)), mean + k * (max(hi, mean) - mean)
    # no weighting of these items can give a mean outside their range: the widened ends stay
    # inside it (a distance's interval never goes below 0)
    return mean, max(lo, float(x.min())), min(hi, float(x.max())), df


def _factor_codes(n: int, factors: Mapping[str, Sequence], keep: np.ndarray
                  ) -> dict[str, tuple[np.ndarray, int]]:
    out = {}
    for name, labels in factors.items():
        if len(labels) != n:
            raise ValueError(f"factor {name!r} has {len(labels)} labels for {n} values")
        out[name] = _codes(labels, keep)
    return out


def crossed_bootstrap(values: Sequence[float] | np.ndarray, factors: Mapping[str, Sequence],
                      *, resamples: int = N_RESAMPLES, seed: int = SEED,
                      level: float = LEVEL) -> Interval | None:
    """Interval of the item mean over crossed factors (module docstring).

    Parameters
    ----------
    values : ``(n,)`` per-item values (NaN/inf are left out, as in the table means).
    factors : factor name -> ``(n,)`` level of each item (garment id, subject id, ...);
        at least one factor.
    resamples, seed, level : bootstrap size, RNG seed, confidence level.

    Returns
    -------
    Interval, or None when no value is finite.
    """
    v = np.asarray(values, dtype=np.float64)
    if not factors:
        raise ValueError("factors: give at least one factor (e.g. the garment)")
    keep = np.isfinite(v)
    if not keep.any():
        return None
    codes = _factor_codes(len(v), factors, keep)
    x = v[keep]
    mean, lo, hi, df = _interval(x, codes, resamples, seed, level)
    levels = {k: c[1] for k, c in codes.items()}
    degenerate = all(n <= 1 for n in levels.values())
    return Interval(mean, lo, hi, int(x.size), levels, df, 0 if degenerate else resamples,
                    resample_count(levels), degenerate)


def bootstrap_mean(values: Sequence[float] | np.ndarray, units: Sequence, *,
                   resamples: int = N_RESAMPLES, seed: int = SEED,
                   level: float = LEVEL) -> Interval | None:
    """:func:`crossed_bootstrap` over one factor (``units``: the cluster of each item)."""
    return crossed_bootstrap(values, {"unit": units}, resamples=resamples, seed=seed,
                             level=level)


@dataclass(frozen=True)
class PairedDifference:
    """Paired bootstrap of ``mean(a) - mean(b)`` over shared items.

    Attributes
    ----------
    diff : observed difference of the item means over items both methods scored.
    lo, hi : interval of the difference.
    n_items : shared items.
    levels : factor -> levels among them.
    separated : the interval excludes 0.
    """

    diff: float
    lo: float
    hi: float
    n_items: int
    levels: dict[str, int]
    separated: bool

    @property
    def n_units(self) -> int:
        """Levels of the first factor."""
        return next(iter(self.levels.values()), 0)


def paired_difference(a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray,
                      factors: Mapping[str, Sequence] | Sequence, *,
                      resamples: int = N_RESAMPLES, seed: int = SEED,
                      level: float = LEVEL) -> PairedDifference | None:
    """Paired bootstrap of the difference of two methods' item means over crossed factors.

    Parameters
    ----------
    a, b : ``(n,)`` values of two methods on the SAME items (aligned); items where either is
        not finite are left out of both.
    factors : factor name -> ``(n,)`` levels (a plain sequence: one factor).

    Returns
    -------
    PairedDifference, or None when no item is shared.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if not isinstance(factors, Mapping):
        factors = {"unit": factors}
    d = np.where(np.isfinite(a) & np.isfinite(b), a - b, np.nan)
    iv = crossed_bootstrap(d, factors, resamples=resamples, seed=seed, level=level)
    if iv is None:
        return None
    return PairedDifference(iv.mean, iv.lo, iv.hi, iv.n_items, iv.levels,
                            bool(not iv.degenerate and (iv.lo > 0 or iv.hi < 0)))


def describe_levels(levels: Mapping[str, int]) -> str:
    """One phrase on what an interval rests on, e.g. ``12 garment_id x 4 target_subject x 3
    target_pose (3.6e+04 distinct resamples)`` (flagged below :data:`FEW_RESAMPLES`)."""
    if not levels or all(n <= 1 for n in levels.values()):
        return ("one level of every factor: the interval is degenerate (a single point); the "
                "data cannot say how far the mean would move on other garments or bodies")
    k = resample_count(levels)
    text = " x ".join(f"{n} {name}" for name, n in levels.items())
    if k < FEW_RESAMPLES:
        return (f"{text} allow only {k} distinct resamples: the interval is coarse; read it "
                "as indicative")
    return f"{text} ({k:.3g} distinct resamples)"


def describe_resolution(n_units: int) -> str:
    """:func:`describe_levels` for one factor of ``n_units`` levels."""
    return describe_levels({"units": n_units})
