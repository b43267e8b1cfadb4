"""NearestTree: the single-thread k = 1 queries of registration's inner loops, on pykdtree
or scipy, against a brute-force search."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dressmeup.geometry import neighbors
from dressmeup.geometry.neighbors import NearestTree, nearest_backend

BACKENDS = ["scipy", pytest.param("pykdtree", marks=pytest.mark.skipif(
    neighbors._pykdtree_class() is None, reason="pykdtree not installed"))]


def _brute(P, X):
    D = np.linalg.norm(X[:, None, :] - P[None, :, :], axis=2)
    return D.min(1), D.argmin(1)


@pytest.fixture
def backend(request, monkeypatch):
    monkeypatch.setattr(neighbors, "BACKEND", request.param)
    return request.param


@pytest.mark.parametrize("backend", BACKENDS, indirect=True)
def test_nearest_tree_matches_brute_force(backend):
    rng = np.random.default_rng(3)
    P = rng.normal(size=(700, 3))
    X = rng.normal(size=(300, 3)).astype(np.float32)  # float32 queries, as from torch
    tree = NearestTree(P)
    assert tree.backend == backend
    d, i = tree.query(X)
    d_ref, i_ref = _brute(P, X.astype(np.float64))
    assert d.dtype == np.float64 and i.dtype == np.int64 and d.shape == i.shape == (300,)
    np.testing.assert_allclose(d, d_ref, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(i, i_ref)


@pytest.mark.parametrize("backend", BACKENDS, indirect=True)
def test_nearest_tree_bound_gives_inf_and_n_beyond(backend):
    rng = np.random.default_rng(4)
    P = rng.random((500, 3))
    X = rng.random((400, 3)) * 1.5
    d_ref, i_ref = _brute(P, X)
    d, i = NearestTree(P).query(X, distance_upper_bound=0.05)
    inside = d_ref < 0.05
    assert 0 < inside.sum() < len(X)  # the bound cuts some queries, not all
    np.testing.assert_allclose(d[inside], d_ref[inside], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(i[inside], i_ref[inside])
    assert np.isinf(d[~inside]).all() and (i[~inside] == len(P)).all()


@pytest.mark.parametrize("backend", BACKENDS, indirect=True)
def test_nearest_tree_copies_points_and_takes_empty_queries(backend):
    P = np.array([[0.0, 0, 0], [1, 0, 0]])
    tree = NearestTree(P)
    P[1] = [50, 0, 0]  # the caller's later edit does not reach the tree
    d, i = tree.query(np.array([[0.9, 0, 0]]))
    assert i[0] == 1 and d[0] == pytest.approx(0.1)
    d, i = tree.query(np.zeros((0, 3)))
    assert d.shape == i.shape == (0,)


def test_nearest_tree_rejects_what_it_does_not_answer():
    with pytest.raises(ValueError, match="n >= 1"):
        NearestTree(np.zeros((0, 3)))
    tree = NearestTree(np.eye(3))
    with pytest.raises(ValueError, match="k=1"):
        tree.query(np.eye(3), k=2)
    with pytest.raises(ValueError, match="one thread"):
        tree.query(np.eye(3), workers=2)
    with pytest.raises(ValueError, match=r"\(q, 3\)"):
        tree.query(np.ones((4, 2)))


def test_backend_choice_and_fallback(monkeypatch):
    monkeypatch.setattr(neighbors, "BACKEND", None)
    expected = "pykdtree" if neighbors._pykdtree_class() is not None else "scipy"
    assert nearest_backend() == expected
    # without pykdtree the tree falls back to scipy, and asking for it says what to install
    monkeypatch.setattr(neighbors, "_pykdtree_class", lambda: None)
    assert nearest_backend() == "scipy" and NearestTree(np.eye(3)).backend == "scipy"
    monkeypatch.setattr(neighbors, "BACKEND", "pykdtree")
    with pytest.raises(ImportError, match="pip install pykdtree"):
        nearest_backend()
    monkeypatch.setattr(neighbors, "BACKEND", "kd")
    with pytest.raises(ValueError, match="BACKEND"):
        nearest_backend()


@pytest.mark.skipif(neighbors._pykdtree_class() is None, reason="pykdtree not installed")
@pytest.mark.parametrize("value", [None, "7"])
def test_pykdtree_import_puts_the_thread_variable_back(value):
    # pykdtree is loaded with the module, in a fresh interpreter here
    env = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}
    if value is not None:
        env["OMP_NUM_THREADS"] = value
    code = ("import os; from dressmeup.geometry import neighbors; "
            "print(neighbors._pykdtree_class() is not None, os.environ.get('OMP_NUM_THREADS'))")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[2]).stdout.split()
    assert out == ["True", str(value)]
