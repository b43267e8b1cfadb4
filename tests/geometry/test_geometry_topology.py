"""geometry.topology against slow, obviously-correct references (BFS over faces, edge dicts)."""

from __future__ import annotations

from collections import defaultdict, deque

import numpy as np
import pytest

from dressmeup.geometry.topology import (
    component_labels,
    face_adjacency,
    large_components,
    largest_component,
    largest_component_faces,
    vertex_adjacency,
)


def grid(nx: int, ny: int, offset: int = 0) -> np.ndarray:
    """Faces of an (nx x ny)-vertex grid, vertex ids shifted by ``offset``."""
    F = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a = j * nx + i + offset
            F += [[a, a + 1, a + nx], [a + 1, a + nx + 1, a + nx]]
    return np.asarray(F, dtype=np.int64)


def random_soup(seed: int) -> tuple[np.ndarray, int]:
    """Several grids of random sizes, shuffled faces, plus isolated vertices."""
    rng = np.random.default_rng(seed)
    parts, off = [], 3  # vertices 0..2 isolated
    for _ in range(rng.integers(2, 6)):
        nx, ny = rng.integers(2, 7, size=2)
        parts.append(grid(int(nx), int(ny), off))
        off += int(nx * ny)
    F = np.concatenate(parts)
    perm = rng.permutation(off)  # scramble vertex ids so components interleave
    F = perm[F]
    return F[rng.permutation(len(F))], off


def ref_face_components(F: np.ndarray) -> list[set[int]]:
    """Faces grouped by BFS over shared vertices."""
    by_vertex = defaultdict(list)
    for f, tri in enumerate(F):
        for v in tri:
            by_vertex[int(v)].append(f)
    seen, comps = set(), []
    for f0 in range(len(F)):
        if f0 in seen:
            continue
        comp, todo = set(), deque([f0])
        seen.add(f0)
        while todo:
            f = todo.popleft()
            comp.add(f)
            for v in F[f]:
                for g in by_vertex[int(v)]:
                    if g not in seen:
                        seen.add(g)
                        todo.append(g)
        comps.append(comp)
    return comps


def ref_largest(F: np.ndarray, by: str) -> set[int]:
    comps = ref_face_components(F)
    size = (lambda c: len(c)) if by == "faces" else (lambda c: len(np.unique(F[list(c)])))
    best = max(size(c) for c in comps)
    # tie: the component holding the lowest vertex index
    tied = [c for c in comps if size(c) == best]
    return min(tied, key=lambda c: F[list(c)].min())


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("by", ["faces", "vertices"])
def test_largest_component_matches_bfs(seed, by):
    F, n = random_soup(seed)
    want = ref_largest(F, by)
    mask = largest_component_faces(F, n, by=by)
    assert set(np.flatnonzero(mask)) == want
    ids, Fc = largest_component(F, n, by=by)
    assert np.all(np.diff(ids) > 0) and ids.dtype == np.int64 and Fc.dtype == np.int64
    np.testing.assert_array_equal(ids[Fc], F[sorted(want)])  # re-indexing is exact, order kept
    assert set(ids) == set(np.unique(F[sorted(want)]))


def test_tie_goes_to_the_component_with_the_lowest_vertex():
    F = np.concatenate([grid(3, 3, offset=9), grid(3, 3, offset=0)])
    ids, _ = largest_component(F, 18)
    np.testing.assert_array_equal(ids, np.arange(9))


def test_empty_and_isolated_vertices():
    F = np.zeros((0, 3), dtype=np.int64)
    assert largest_component_faces(F, 4).shape == (0,)
    ids, Fc = largest_component(F, 4)
    assert ids.shape == (0,) and Fc.shape == (0, 3)
    assert large_components(F, 4, 0.5).shape == (0,)
    labels = component_labels(grid(2, 2), 6)  # vertices 4, 5 isolated
    assert labels[4] != labels[5] and len(set(labels[:4])) == 1


@pytest.mark.parametrize("seed", range(5))
def test_large_components_threshold(seed):
    F, n = random_soup(seed)
    comps = ref_face_components(F)
    biggest = max(len(c) for c in comps)
    for frac in (0.0, 0.3, 0.7, 1.0):
        want = set().union(*[c for c in comps if len(c) >= frac * biggest])
        assert set(np.flatnonzero(large_components(F, n, frac))) == want


def ref_face_pairs(F: np.ndarray, manifold_only: bool) -> set[tuple[int, int]]:
    by_edge = defaultdict(list)
    for f, (a, b, c) in enumerate(F):
        for e in ((a, b), (b, c), (c, a)):
            key = tuple(sorted(map(int, e)))
            if f not in by_edge[key]:
                by_edge[key].append(f)
    pairs = set()
    for faces in by_edge.values():
        faces = sorted(faces)
        if manifold_only and len(faces) != 2:
            continue
        pairs |= {(faces[i], faces[i + 1]) for i in range(len(faces) - 1)}
    return pairs


@pytest.mark.parametrize("manifold_only", [False, True])
def test_face_adjacency_matches_edge_dict(manifold_only):
    F, _ = random_soup(3)
    # a non-manifold fin: two extra faces on edge (F[0, 0], F[0, 1])
    a, b = F[0, 0], F[0, 1]
    n = F.max() + 1
    F = np.concatenate([F, [[a, b, n], [b, a, n + 1]]])
    got = face_adjacency(F, manifold_only=manifold_only)
    assert got.dtype == np.int64 and np.all(got[:, 0] < got[:, 1])
    assert len(got) == len({tuple(p) for p in got})
    assert {tuple(p) for p in got} == ref_face_pairs(F, manifold_only)
    if not manifold_only:
        fin = len(F) - 1
        assert sum(fin in p for p in got.tolist()) == 1  # chained, not all pairs


def test_vertex_adjacency_symmetric_edges():
    F = grid(3, 2)
    A = vertex_adjacency(F, 7).toarray()
    assert np.array_equal(A, A.T) and A[6].sum() == 0
    assert A[0, 1] == 1 and A[0, 3] == 1 and A[0, 4] == 0 and A[1, 3] == 1


def test_corner_order_is_the_stacked_edge_order():
    F, _ = random_soup(5)
    face = face_adjacency(F)
    corner = face_adjacency(F, order="corner")
    # same pairs, possibly swapped within a pair
    assert {tuple(sorted(p)) for p in corner.tolist()} == {tuple(p) for p in face.tolist()}
    # corner order: within an edge, the face whose edge slot comes first in the stacked list
    m = len(F)
    slot = {}
    for k, (i, j) in enumerate(((0, 1), (1, 2), (2, 0))):
        for f in range(m):
            slot[(f, tuple(sorted((int(F[f, i]), int(F[f, j])))))] = k * m + f
    for a, b in corner.tolist():
        shared = set(map(int, F[a])) & set(map(int, F[b]))
        e = tuple(sorted(shared))
        assert slot[(a, e)] < slot[(b, e)]
    assert not np.array_equal(corner, face)  # the option does something on this soup
    with pytest.raises(ValueError, match="order"):
        face_adjacency(F, order="bogus")
