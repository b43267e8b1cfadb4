"""Splits by garment (docs/spec.md section 4): test garments are never seen in training.

Two strategies:

``"stratified"`` (default when categories are given)
    Garments are grouped by category (the manifest's ``category``: topwear, bottomwear,
    dress, ...). Within each category with at least two garments, the garments are sorted,
    shuffled with a seed derived from ``seed`` and the category name, and cut by the fractions:
    such a category gets at least one test garment, at least one val garment when it has three
    or more, and always keeps at least one train garment. Categories with a single garment are
    pooled and the pool is cut by the same rule (so two singleton categories still give one
    test garment). Test therefore covers every category that has two or more garments, so a
    benchmark's test set cannot consist of one kind of garment only (e.g. only bottomwear,
    which arm-only poses barely move).
``"random"``
    The plain seeded shuffle of all garments, cut by the fractions (the behaviour of
    synthetic generator 1.0.0).
"""

from __future__ import annotations

import zlib
from collections.abc import Mapping, Sequence

import numpy as np

from dressmeup.errors import InputError

DEFAULT_FRACTIONS = (0.6, 0.2, 0.2)
STRATEGIES = ("stratified", "random")


def _counts(n: int, f: np.ndarray) -> tuple[int, int]:
    """(n_val, n_test) for ``n`` garments: rounded fractions, with the minimums of the docs."""
    n_test = int(round(f[2] * n))
    n_val = int(round(f[1] * n))
    if n >= 2 and f[2] > 0:
        n_test = max(n_test, 1)
    if n >= 3 and f[1] > 0:
        n_val = max(n_val, 1)
    while n_test + n_val > max(n - 1, 0):
        if n_val > 0:
            n_val -= 1
        else:
            n_test -= 1
    return n_val, n_test


def _cut(ids: list[str], f: np.ndarray, rng: np.random.Generator) -> dict[str, str]:
    """Shuffle sorted ``ids`` with ``rng`` and cut them into test, val, train (in that order)."""
    n_val, n_test = _counts(len(ids), f)
    order = rng.permutation(len(ids))
    out = {}
    for rank, i in enumerate(order):
        out[ids[i]] = "test" if rank < n_test else ("val" if rank < n_test + n_val else "train")
    return out


def split_by_garment(garment_ids: Sequence[str], fractions: Sequence[float] = DEFAULT_FRACTIONS,
                     seed: int = 0, categories: Mapping[str, str] | None = None,
                     strategy: str | None = None) -> dict[str, str]:
    """Assign every garment to ``train``, ``val`` or ``test``.

    Deterministic for a seed and independent of the order of ``garment_ids``. See the module
    docstring for the two strategies. With ``strategy="random"`` (or no ``categories``): the
    garments are sorted, shuffled with ``seed`` and cut by ``fractions``; with two or more
    garments, test gets at least one; with three or more, val too; train always keeps at
    least one. With ``strategy="stratified"`` the same rule is applied within each category
    (shuffled with ``np.random.default_rng([seed, crc32(category)])``), categories with a
    single garment being pooled (seed ``[seed, 0]``); train keeps at least one garment of
    every category (and of the pool).

    Parameters
    ----------
    garment_ids : unique garment ids.
    fractions : (3,) non-negative (train, val, test) fractions summing to 1.
    seed : shuffling seed.
    categories : garment id -> category (every id of ``garment_ids`` must have one);
        required for ``strategy="stratified"``.
    strategy : ``"stratified"`` or ``"random"``; default: ``"stratified"`` when
        ``categories`` is given, else ``"random"``.

    Returns
    -------
    dict garment_id -> split.

    Raises
    ------
    ValueError
        For duplicate ids, invalid fractions, an unknown strategy or missing categories.
    """
    ids = sorted(set(garment_ids))
    if len(ids) != len(list(garment_ids)):
        raise InputError("garment_ids: expected unique ids")
    f = np.asarray(fractions, dtype=np.float64)
    if f.shape != (3,) or np.any(f < 0) or not np.isclose(f.sum(), 1.0):
        raise InputError(f"fractions: expected 3 non-negative numbers summing to 1, got {fractions}")
    if strategy is None:
        strategy = "stratified" if categories is not None else "random"
    if strategy not in STRATEGIES:
        raise InputError(f"strategy: expected one of {STRATEGIES}, got {strategy!r}")
    if strategy == "random":
        return _cut(ids, f, np.random.default_rng(seed))
    if categories is None:
        raise InputError("categories: strategy 'stratified' needs a garment id -> category "
                         "mapping (e.g. the manifest's 'category' column)")
    missing = [g for g in ids if g not in categories]
    if missing:
        raise InputError(f"categories: no category for garments {missing[:5]}")
    groups: dict[str, list[str]] = {}
    for g in ids:
        groups.setdefault(str(categories[g]), []).append(g)
    out: dict[str, str] = {}
    pool: list[str] = []
    for cat in sorted(groups):
        members = groups[cat]
        if len(members) < 2:
            pool += members
            continue
        out.update(_cut(members, f, np.random.default_rng([seed, zlib.crc32(cat.encode())])))
    if pool:
        out.update(_cut(sorted(pool), f, np.random.default_rng([seed, 0])))
    return out
