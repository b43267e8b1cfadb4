"""When a training run has converged: the one rule every trainer of the toolkit uses.

A run has converged when its best validation figure improved by less than ``tol`` (1 %)
over the last ``fraction`` (20 %) of the steps so far, with at least ``min_tail``
evaluations in that window (one noisy evaluation is no plateau).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def converged(val: Sequence[tuple[int, float]], tol: float = 0.01, fraction: float = 0.2,
              min_tail: int = 4) -> bool:
    """True when the best validation loss improved by less than ``tol`` (relative) over the
    last ``fraction`` of the steps so far.

    Parameters
    ----------
    val : ``[(step, loss), ...]`` in step order.
    tol : relative improvement threshold (0.01 = 1 %).
    fraction : the trailing share of the steps compared (0.2 = the last fifth).
    min_tail : the last fifth must hold at least this many evaluations (so at least
        ``min_tail / fraction`` evaluations in all): one noisy evaluation is no plateau.
    """
    steps = np.array([s for s, _ in val], dtype=float)
    loss = np.array([v for _, v in val], dtype=float)
    if steps.size == 0:
        return False
    cut = steps[-1] * (1.0 - fraction)
    before = loss[steps <= cut]
    if before.size == 0 or int(np.count_nonzero(steps > cut)) < min_tail:
        return False
    best_before, best_now = float(before.min()), float(loss.min())
    return (best_before - best_now) < tol * abs(best_before)
