"""Splits by garment (SPEC.md section 4): test garments are never seen in training."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

DEFAULT_FRACTIONS = (0.6, 0.2, 0.2)


def split_by_garment(garment_ids: Sequence[str], fractions: Sequence[float] = DEFAULT_FRACTIONS,
                     seed: int = 0) -> dict[str, str]:
    """Assign every garment to ``train``, ``val`` or ``test``.

    The garments are sorted, shuffled with ``seed`` and cut by ``fractions``
    (train, val, test). With two or more garments, test gets at least one; with three or more,
    val too; train always keeps at least one.

    Parameters
    ----------
    garment_ids : unique garment ids.
    fractions : (3,) non-negative, summing to 1.
    seed : shuffling seed.

    Returns
    -------
    dict garment_id -> split.
    """
    ids = sorted(set(garment_ids))
    if len(ids) != len(list(garment_ids)):
        raise ValueError("garment_ids: expected unique ids")
    f = np.asarray(fractions, dtype=np.float64)
    if f.shape != (3,) or np.any(f < 0) or not np.isclose(f.sum(), 1.0):
        raise ValueError(f"fractions: expected 3 non-negative numbers summing to 1, got {fractions}")
    n = len(ids)
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
    order = np.random.default_rng(seed).permutation(n)
    out = {}
    for rank, i in enumerate(order):
        out[ids[i]] = "test" if rank < n_test else ("val" if rank < n_test + n_val else "train")
    return out
