"""Shape hypotheses: phenotype starts of the same stature, for the final shape search.

The size handover (:meth:`~dressmeup.body.registration.problem.FitProblem.scale_into_shape`)
turns the start's uniform scale into a shape by matching a uniformly scaled average body.
A phenotype model's tall or short bodies are not scaled average bodies (a tall body's legs
are longer for its size), so the handover can reach a tall scan's size by age and muscle
instead of height, and the shape stage then stays there, the legs too short for the scan
and the ankles stretched to make up for it (session 20: a 2.08 m woman fitted 26.7 mm
off). The search (``OptimizationRegistrar.shape_search``) restarts the shape from the
shapes below and keeps the one whose settled body fits the scan best; each gender's start
is the build of :data:`BUILD_GRID` whose stature-matched body, placed in the fitted pose,
fits best (``shape_search_builds``: a thin unmuscular adult had been fitted muscle 0.98,
and the average build's start did not leave that basin either; session 21).

Only for phenotype models (shape names :data:`~dressmeup.body.skeleton.PHENOTYPE_NAMES`:
gender, age, muscle, weight, height, proportions, each in [0, 1]); other models get no
hypotheses. Stature is the rest body's extent along the model's up axis (y).
"""

from __future__ import annotations

import numpy as np

from dressmeup.body.skeleton import PHENOTYPE_NAMES

#: the two sexes of a phenotype model's gender parameter, one start each
GENDERS = (0.0, 1.0)
#: where gender and height sit in a phenotype shape vector
I_GENDER, I_HEIGHT = PHENOTYPE_NAMES.index("gender"), PHENOTYPE_NAMES.index("height")
#: the height parameter is solved within these bounds (the fit's sigmoid never reaches 0 or 1)
HEIGHT_RANGE = (0.02, 0.98)
#: where muscle, weight and proportions (a body's build) sit in a phenotype shape vector
I_BUILD = [PHENOTYPE_NAMES.index(n) for n in ("muscle", "weight", "proportions")]
#: the model's average build
DEFAULT_BUILD = (0.5, 0.5, 0.5)
#: builds ranked for each gender by the shape search: muscle, weight and proportions each
#: at an end or the middle of its range (27)
BUILD_GRID = tuple((m, w, p) for m in (0.0, 0.5, 1.0) for w in (0.0, 0.5, 1.0)
                   for p in (0.0, 0.5, 1.0))


def statures(model, shapes: np.ndarray) -> np.ndarray:
    """(b,) extents (m) along y of ``model``'s rest bodies with ``shapes`` (b, k): one
    batched rest body."""
    # heavy: torch (~1.1 s to import)
    import torch

    with torch.no_grad():
        rest, _ = model.rest(torch.as_tensor(np.asarray(shapes, np.float64)))
    y = rest[:, :, 1]
    return (y.max(1).values - y.min(1).values).numpy()


def stature(model, shape: np.ndarray) -> float:
    """Extent (m) of ``model``'s rest body with ``shape`` (k,) along y."""
    return float(statures(model, np.asarray(shape, np.float64)[None])[0])


def stature_matched_shapes(model, shape: np.ndarray, builds=(DEFAULT_BUILD,),
                           steps: int = 24) -> list[np.ndarray]:
    """Phenotype starts as tall as the body with ``shape``: for each gender in
    :data:`GENDERS` and each build ``(muscle, weight, proportions)`` in ``builds`` (in
    that order, gender first), the model's default shape with those values and the height
    parameter solved by bisection (``steps`` halvings of :data:`HEIGHT_RANGE`; stature
    grows with height) so the rest stature matches; clipped to the range when the stature
    is out of reach. Returns a list of (k,) arrays; empty for a model without the
    phenotype parameters."""
    if tuple(getattr(model, "shape_names", ())) != PHENOTYPE_NAMES:
        return []
    target = stature(model, shape)
    starts = np.repeat(np.asarray(model.default_shape, dtype=np.float64)[None],
                       len(GENDERS) * len(builds), axis=0)
    for i, (gender, build) in enumerate((g, b) for g in GENDERS for b in builds):
        starts[i, I_GENDER] = gender
        starts[i, I_BUILD] = build
    lo = np.full(len(starts), HEIGHT_RANGE[0])
    hi = np.full(len(starts), HEIGHT_RANGE[1])
    for _ in range(steps):  # all starts at once: one batched rest body a step
        starts[:, I_HEIGHT] = 0.5 * (lo + hi)
        short = statures(model, starts) < target
        lo = np.where(short, starts[:, I_HEIGHT], lo)
        hi = np.where(short, hi, starts[:, I_HEIGHT])
    starts[:, I_HEIGHT] = 0.5 * (lo + hi)
    return list(starts)
