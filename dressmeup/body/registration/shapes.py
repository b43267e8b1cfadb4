"""Shape hypotheses: phenotype starts of the same stature, and the final shape search.

The size handover (:meth:`~dressmeup.body.registration.problem.FitProblem.scale_into_shape`)
turns the start's uniform scale into a shape by matching a uniformly scaled average body.
A phenotype model's tall or short bodies are not scaled average bodies (a tall body's legs
are longer for its size), so the handover can reach a tall scan's size by age and muscle
instead of height, and the shape stage then stays there, the legs too short for the scan
and the ankles stretched to make up for it (a 2.08 m woman fitted 26.7 mm off). The search
(:func:`shape_search`) restarts the shape from the shapes below and keeps the one whose
settled body fits the scan best; each gender's start is the build of :data:`BUILD_GRID`
whose stature-matched body, placed in the fitted pose, fits best (a thin unmuscular adult
had been fitted muscle 0.98, and the average build's start did not leave that basin).

Only for phenotype models (shape names :data:`~dressmeup.body.skeleton.PHENOTYPE_NAMES`:
gender, age, muscle, weight, height, proportions, each in [0, 1]); other models get no
hypotheses. Stature is the rest body's extent along the model's up axis (y).
"""

from __future__ import annotations

import numpy as np

from dressmeup.body.registration.problem import Objective
from dressmeup.body.registration.search import Candidate, best_of
from dressmeup.body.registration.stages import run_adam, shape_stage
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
    batched rest body (:meth:`~dressmeup.body.base.LBSBodyModel.rest_extent`)."""
    # heavy: torch (~1.1 s to import)
    import torch

    with torch.no_grad():
        return model.rest_extent(torch.as_tensor(np.asarray(shapes, np.float64)), 1).numpy()


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


def shape_search(problem, spec, keypoints: float = 0.0, verbose: bool = False
                 ) -> tuple[dict, dict[str, float]]:
    """The final shape search (:class:`~dressmeup.body.registration.plan.ShapeSearch`):
    from the finished body, each gender's best build at its stature
    (:func:`stature_matched_shapes` over :data:`BUILD_GRID`, ranked by the shape objective
    with the body placed in the fitted pose, its centroid kept) gets ``spec.pose_steps``
    pose steps (shape held) and the shape stage ``spec.shape``; the body with the lowest
    shape objective (the fitted one included; equal: the earlier) stays in ``problem``.

    Returns
    -------
    info : the objective of each start (``"fitted"``, ``"gender <g> height <h> build <m>
        <w> <p>"``; 4 decimals) and ``"kept"``; empty for a model without phenotypes.
    losses : the kept start's loss terms, prefixed ``search_`` (none when the fitted body
        stays).
    """
    # heavy: torch (~1.1 s to import)
    import torch

    shapes = stature_matched_shapes(problem.model, problem.body_params().shape, BUILD_GRID)
    if not shapes:
        return {}, {}
    objective = Objective("shape", far_cloth=True, keypoints=keypoints)
    pose_objective = Objective("pose", far_cloth=True, keypoints=keypoints)
    fitted = problem.snapshot()
    centroid = problem.posed_numpy()[problem.body_ids].mean(0)

    def place(p, shape: np.ndarray) -> None:  # the fitted pose, the centroid kept
        p.restore(fitted)
        p.set_params(shape=shape)
        with torch.no_grad():
            moved = p.posed_numpy()[p.body_ids].mean(0)
            p.transl.add_(torch.as_tensor(centroid - moved, dtype=p.dt, device=p.dev))

    starts = []
    for g in range(len(GENDERS)):  # each gender's build that fits the scan best as placed
        ranked = []
        for shape in shapes[g * len(BUILD_GRID):(g + 1) * len(BUILD_GRID)]:
            place(problem, shape)
            ranked.append((problem.objective(objective), shape))
        starts.append(min(ranked, key=lambda r: r[0])[1])

    def restart(shape: np.ndarray) -> Candidate:
        def run(p) -> dict:
            place(p, shape)
            losses = {f"pose_{k}": x for k, x in run_adam(
                p, pose_objective, spec.pose_steps, [p.pose, p.transl],
                [spec.rates.pose, spec.rates.transl], verbose=verbose).items()}
            losses.update(shape_stage(p, spec.shape, keypoints, verbose))
            return {"losses": losses}
        return Candidate(f"gender {shape[I_GENDER]:.0f} height {shape[I_HEIGHT]:.2f}"
                         + " build {:.1f} {:.1f} {:.1f}".format(*shape[I_BUILD]), run)

    def score(p, info: dict) -> float:
        # the restarts compare at the precision they are reported (4 decimals), the
        # fitted body at full precision
        value = p.objective(objective)
        return round(value, 4) if "losses" in info else value

    ranked = best_of(problem, [Candidate("fitted", lambda p: p.restore(fitted)),
                               *map(restart, starts)], score)
    info = {c.name: round(c.score, 4) for c in sorted(ranked, key=lambda c: c.name != "fitted")}
    info["kept"] = ranked[0].name
    losses = ranked[0].info.get("losses", {})
    return info, {f"search_{k}": x for k, x in losses.items()}
