"""Shape hypotheses (stature-matched phenotype starts) and the final shape search."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.synthetic import synthetic_scan


@pytest.fixture(scope="module")
def model():
    return get_body_model("procedural")


def _wrong_shape_problem(model, truth, start, seed):
    """(shape search stage, FitProblem) on a scan of the rest body with shape ``truth``,
    the problem's shape set to ``start``."""
    from dressmeup.body.registration.config import get_config
    from dressmeup.body.registration.plan import build_plan
    from dressmeup.body.registration.problem import FitProblem
    from dressmeup.body.registration.scan import prepare_scan

    body = BodyParams("procedural", shape=np.array(truth), pose=np.zeros((model.n_joints, 3)))
    scan = synthetic_scan(model, body, n_points=8000, noise=0.002, seed=seed)
    config = get_config(n_scan_points=3000, n_body_points=2000, iterations=(20, 40, 40))
    problem = FitProblem.from_config(config, model, prepare_scan(scan, 3000, 0))
    problem.set_params(shape=np.array(start))
    return build_plan(config).stages[-1], problem


def _objective(problem) -> float:
    from dressmeup.body.registration.problem import Objective

    return problem.objective(Objective("shape", far_cloth=True))


def test_stature_grows_with_the_height_parameter(model):
    """The bisection's premise, on the test body."""
    from dressmeup.body.registration.shapes import I_HEIGHT, stature

    statures = []
    for h in np.linspace(0.02, 0.98, 7):
        shape = np.full(6, 0.5)
        shape[I_HEIGHT] = h
        statures.append(stature(model, shape))
    assert np.all(np.diff(statures) > 0)
    # the procedural body's rest pose stands along y: its stature is its y extent
    rest = model.posed(model.default_params()).vertices
    assert stature(model, np.full(6, 0.5)) == pytest.approx(np.ptp(rest[:, 1]), abs=1e-9)


def test_stature_matched_shapes_match_the_stature_per_gender(model):
    from dressmeup.body.registration.shapes import (
        GENDERS,
        I_GENDER,
        I_HEIGHT,
        stature,
        stature_matched_shapes,
    )

    body = np.array([0.9, 0.8, 0.9, 0.2, 0.6, 0.5])  # height reached partly by age and muscle
    starts = stature_matched_shapes(model, body)
    assert [s[I_GENDER] for s in starts] == list(GENDERS)
    for s in starts:
        assert stature(model, s) == pytest.approx(stature(model, body), abs=1e-4)
        others = [i for i in range(6) if i not in (I_GENDER, I_HEIGHT)]
        assert np.allclose(s[others], np.asarray(model.default_shape)[others])
    # out of reach (taller than either gender gets at height 0.98): clipped, not extrapolated
    tall = stature_matched_shapes(model, np.array([0.5, 1.0, 1.0, 1.0, 1.0, 1.0]))
    assert [s[I_HEIGHT] for s in tall] == pytest.approx([0.98, 0.98], abs=1e-6)


def test_no_shape_hypotheses_without_phenotype_parameters():
    from dressmeup.body.registration.shapes import stature_matched_shapes

    class Pca:  # a SMPL-like model: PCA betas, no phenotype names
        shape_names = ()
        default_shape = np.zeros(10)

    assert stature_matched_shapes(Pca(), np.zeros(10)) == []


def test_shape_search_keeps_the_lowest_objective(model):
    """From a body with the wrong phenotype (the truth's stature reached by age and muscle
    instead of height, the other gender), the search's starts run, the kept body has the
    lowest shape objective of all starts, and it is not worse than the start."""
    from dressmeup.body.registration.shapes import shape_search

    spec, problem = _wrong_shape_problem(model, truth=[1.0, 0.5, 0.3, 0.1, 0.95, 0.5],
                                         start=[0.0, 0.9, 0.9, 0.5, 0.75, 0.5], seed=1)
    before = _objective(problem)
    scores, losses = shape_search(problem, spec)
    assert len(scores) == 4 and "fitted" in scores
    assert sorted(k.split(" height")[0] for k in scores if k.startswith("gender")) == [
        "gender 0", "gender 1"]
    assert scores["kept"] != "fitted"  # the wrong phenotype's basin is left
    kept = scores["kept"]
    assert scores[kept] == min(v for k, v in scores.items() if k != "kept")
    assert _objective(problem) <= before + 1e-9
    assert _objective(problem) == pytest.approx(scores[kept], rel=1e-3)
    assert {"search_pose_data", "search_shape_data"} <= set(losses)


def test_build_grid_starts_match_the_stature_with_each_build(model):
    from dressmeup.body.registration.shapes import (
        BUILD_GRID,
        GENDERS,
        I_BUILD,
        I_GENDER,
        stature,
        stature_matched_shapes,
    )

    body = np.array([0.3, 0.5, 0.7, 0.4, 0.5, 0.5])
    starts = stature_matched_shapes(model, body, BUILD_GRID)
    assert len(starts) == len(GENDERS) * len(BUILD_GRID) == 54
    for i, s in enumerate(starts):  # gender first, then the builds in order
        assert s[I_GENDER] == GENDERS[i // len(BUILD_GRID)]
        assert tuple(s[I_BUILD]) == BUILD_GRID[i % len(BUILD_GRID)]
        assert stature(model, s) == pytest.approx(stature(model, body), abs=1e-4)


def test_shape_search_ranks_the_builds_and_starts_from_the_scan_s(model):
    """A thin, unmuscular body fitted with the opposite build: each gender's start is the
    build whose placed body fits the scan best, which for the truth's gender has the
    truth's muscle and weight (proportions trade off with height); the search leaves the
    wrong build."""
    from dressmeup.body.registration.shapes import shape_search

    spec, problem = _wrong_shape_problem(model, truth=[1.0, 0.5, 0.0, 0.0, 0.5, 0.5],
                                         start=[1.0, 0.5, 1.0, 1.0, 0.3, 0.5], seed=3)
    scores, _ = shape_search(problem, spec)
    names = [k for k in scores if k.startswith("gender 1")]
    assert len(names) == 1 and " build 0.0 0.0 " in names[0], scores
    assert scores["kept"] != "fitted"
