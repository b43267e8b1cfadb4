"""When a training run has converged: the one rule every trainer of the toolkit uses.

A run has converged when its best validation figure improved by less than ``tol`` (1 %)
over the last ``fraction`` (20 %) of the steps so far, and over at least ``min_window``
steps (a trainer passes one pass over its training set: a run stopped inside its first
passes has not seen its data), with at least ``min_tail`` evaluations in that window (one
noisy evaluation is no plateau). The figure compared is the mean of the last ``min_tail``
evaluations at each one, so that one lucky evaluation (a noise dip of a few validation
items) does not stand for a level the network has not reached.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def converged(val: Sequence[tuple[int, float]], tol: float = 0.01, fraction: float = 0.2,
              min_tail: int = 4, min_window: int = 0) -> bool:
    """True when the best trailing mean of ``min_tail`` validation losses improved by less
    than ``tol`` (relative) over the last ``fraction`` of the steps so far, a window of at
    least ``min_window`` steps.

    Parameters
    ----------
    val : ``[(step, loss), ...]`` in step order.
    tol : relative improvement threshold (0.01 = 1 %).
    fraction : the trailing share of the steps compared (0.2 = the last fifth).
    min_tail : the last fifth must hold at least this many evaluations (so at least
        ``min_tail / fraction`` evaluations in all), and the losses are averaged over this
        many evaluations (fewer at the start) before the bests are compared.
    min_window : the window's least length in steps (e.g. one pass over the training set;
        0: the fraction alone).
    """
    steps = np.array([s for s, _ in val], dtype=float)
    loss = np.array([v for _, v in val], dtype=float)
    if steps.size == 0:
        return False
    end = np.arange(1, loss.size + 1)                 # evaluations up to and including each
    start = np.maximum(end - int(min_tail), 0)
    sums = np.concatenate([[0.0], np.cumsum(loss)])
    level = (sums[end] - sums[start]) / (end - start)  # trailing mean of min_tail evaluations
    cut = min(steps[-1] * (1.0 - fraction), steps[-1] - float(min_window))
    before = level[steps <= cut]
    if before.size == 0 or int(np.count_nonzero(steps > cut)) < min_tail:
        return False
    best_before, best_now = float(before.min()), float(level.min())
    return (best_before - best_now) < tol * abs(best_before)
