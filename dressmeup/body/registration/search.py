"""Several starts, keep the best: the one way a fit compares alternatives.

A registration meets local minima everywhere (a body facing backwards, an arm left
hanging, legs bent into a skirt, a wrong phenotype), so at several points it runs
alternatives from a common state and keeps the one a stated objective prefers: the yaw
candidates and the pose hypotheses of the start (:mod:`.init`), the hypothesis and keypoint
starts, a limb move against no move (:mod:`.limbs`), the pose stage with and without the
far-cloth rule, the shape-search starts (:mod:`.shapes`). All of them call :func:`best_of`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Candidate:
    """One alternative: ``run(problem)`` moves the problem's parameters (from the common
    start, or from ones it sets itself) and returns info about what it did (or None)."""

    name: str
    run: Callable[[Any], dict | None]


@dataclass
class Scored:
    """A candidate after its run: its name, the objective's value (lower is better), the
    parameters it ended with (:meth:`~.problem.FitProblem.snapshot`) and its info."""

    name: str
    score: float
    snapshot: dict
    info: dict = field(default_factory=dict)


def best_of(problem, candidates: Sequence[Candidate],
            objective: Callable[[Any, dict], float], start: dict | None = None) -> list[Scored]:
    """Run every candidate, score each result, leave the best in ``problem``.

    Parameters
    ----------
    problem : the :class:`~dressmeup.body.registration.problem.FitProblem`.
    candidates : the alternatives, in order of preference on equal scores.
    objective : ``objective(problem, info) -> float`` right after a candidate's run
        (``info``: what its ``run`` returned), lower is better.
    start : a :meth:`~.problem.FitProblem.snapshot` every candidate starts from (restored
        before each run); None: each candidate sets the parameters it starts from.

    Returns
    -------
    ranked : the scored candidates, best first (equal scores: the earlier candidate first);
        ``problem`` holds the first one's parameters. Empty for no candidates.
    """
    scored = []
    for cand in candidates:
        if start is not None:
            problem.restore(start)
        info = cand.run(problem) or {}
        scored.append(Scored(cand.name, float(objective(problem, info)), problem.snapshot(),
                             info))
    scored.sort(key=lambda s: s.score)  # stable: equal scores keep the candidates' order
    if scored:
        problem.restore(scored[0].snapshot)
    return scored
