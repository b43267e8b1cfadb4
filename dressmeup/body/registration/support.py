"""Support surfaces in a scan: the floor, a seat, a wall, found and left out of the fit.

A capture of a sitting or standing person contains the chair, box or floor; a body fitted
to person + seat is placed on their joint centroid and height and ends inside the seat.
:func:`find_supports` fits planes by repeated RANSAC (triples of points whose normals agree
with their plane, scored by the points near the plane with agreeing normals) and keeps a plane only where it is a *support*: its slab (``band`` either side) holds points
whose local normal agrees with the plane's (within ``max_tilt``) over squares of side
``min_side`` that are at least ``fill`` occupied (cells of a grid in the plane), in both
in-plane directions; the support is the union of those squares. :func:`support_mask`
marks the points on supports, :func:`remove_support` drops them.

Why the human surface does not qualify: a surface of radius of curvature ``R`` leaves its
best plane by the sagitta ``s = c^2 / (8 R)`` over a chord ``c``. Staying inside the slab
(``2 band`` thick) across a square of side ``min_side`` needs
``R >= min_side^2 / (16 band)`` in every direction: 0.70 m with the defaults (0.3 m, 8 mm),
while limbs have ``R`` <= 0.1 m and the torso, across its width, 0.1-0.2 m (a 30 cm chord of
a torso of radius 0.15 m has a sagitta of 7.5 cm). The agreeing normals also need
``R >= min_side / (2 sin max_tilt)`` (0.35 m), and they leave out the curves along which a
plane slices the body (there the surface crosses the plane). Flat strips of the body (a
foot's sole, a thigh's underside on a seat) are narrower than ``min_side``. Measured on
anny scans (benchmarks/perf/registration.py bodies, docs/body-models.md): the flattest
patches of a body (the back, a clothed torso, both thighs side by side) passed the test at
16-20 cm with an 8 mm band, none at 25 cm. Body points lying on a support (a sole on the
floor, a thigh's underside on the seat) go with it; a capture does not see them either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from dressmeup.body.registration.scan import normal_lines
from dressmeup.errors import InputError

#: Largest share of the scan that may lie on supports before the fit refuses the scan.
MAX_SUPPORT_SHARE = 0.9


@dataclass(frozen=True)
class SupportPlane:
    """A support found in a scan: a plane and the region of it the support covers.

    Attributes
    ----------
    normal : (3,) unit normal; ``offset`` : plane ``normal . x + offset = 0`` (m).
    basis : (2, 3) in-plane unit axes ``u, v`` of the occupancy grid.
    cell : grid cell side (m); ``origin`` : (2,) int, grid index of ``region[0, 0]``.
    region : (a, b) bool, the cells of the support (after the opening).
    band : half thickness (m) of the slab around the plane that counts as the support.
    points : points of the scan it was found in that lie on it.
    """

    normal: np.ndarray
    offset: float
    basis: np.ndarray
    cell: float
    origin: np.ndarray
    region: np.ndarray
    band: float
    points: int

    def contains(self, points: np.ndarray) -> np.ndarray:
        """(p,) bool: which of ``points`` (p, 3) lie on this support (inside the band and
        over a cell of its region)."""
        P = np.asarray(points, dtype=np.float64)
        near = np.abs(P @ self.normal + self.offset) <= self.band
        ij = np.floor(P[near] @ self.basis.T / self.cell).astype(np.int64) - self.origin
        a, b = self.region.shape
        ok = (ij[:, 0] >= 0) & (ij[:, 0] < a) & (ij[:, 1] >= 0) & (ij[:, 1] < b)
        hit = np.zeros(len(ij), dtype=bool)
        hit[ok] = self.region[ij[ok, 0], ij[ok, 1]]
        out = np.zeros(len(P), dtype=bool)
        out[np.flatnonzero(near)[hit]] = True
        return out

    def rotated(self, R: np.ndarray) -> SupportPlane:
        """This support in a frame rotated by ``R`` (3, 3): it holds ``points @ R.T`` of
        the points it holds (the grid coordinates ``x . u`` are unchanged)."""
        R = np.asarray(R, dtype=np.float64)
        return replace(self, normal=R @ self.normal, basis=self.basis @ R.T)

    def summary(self, up=(0.0, 1.0, 0.0)) -> dict:
        """JSON-friendly description: orientation against ``up`` (horizontal: floor or seat
        top; vertical: a side or a wall), normal, offset (m), area (m^2), points."""
        tilt = math.degrees(math.acos(min(abs(float(self.normal @ np.asarray(up))), 1.0)))
        kind = "horizontal" if tilt <= 15 else "vertical" if tilt >= 75 else "tilted"
        return {"kind": kind, "tilt_deg": round(tilt, 1),
                "normal": [round(float(x), 4) for x in self.normal],
                "offset_m": round(float(self.offset), 4),
                "area_m2": round(float(self.region.sum()) * self.cell ** 2, 3),
                "points": int(self.points)}


def find_supports(points: np.ndarray, band: float = 0.008, min_side: float = 0.3,
                  max_tilt: float = 25.0, fill: float = 0.9, cell: float = 0.02,
                  max_planes: int = 8, max_rejected: int = 3, ransac_points: int = 8000,
                  iterations: int = 20000, seed: int = 0) -> list[SupportPlane]:
    """Find the support surfaces of a scan (see the module docstring).

    Parameters
    ----------
    points : (p, 3) scan points in metres.
    band : half thickness (m) of a plane's slab (scan noise of a few mm fits inside).
    min_side : side (m) of the square a support must cover (in both in-plane directions).
    max_tilt : degrees; only points whose local surface normal is within this of the
        plane's count towards a support (a plane slicing the body meets it in curves whose
        normals lie across the plane).
    fill : share of the cells of a ``min_side`` square that must hold such points.
    cell : occupancy grid cell (m); raised for sparse scans so a flat surface fills its
        cells (at least 4 times the median nearest-neighbour spacing: ~3.5 points a cell).
    max_planes : supports kept at most.
    max_rejected : planes in a row that may fail the test before the search stops.
    ransac_points, iterations : each RANSAC round draws ``iterations`` point triples and
        scores the planes whose three normals agree with them on a random subset of
        ``ransac_points`` points (the best plane is then tested on all points).
    seed : seed of the subsets and triples.

    Returns
    -------
    The supports in the order found (largest first, roughly).
    """
    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise InputError(f"scan: expected points (p, 3), got {P.shape}")
    if not 0 < band < min_side:
        raise ValueError(f"band: expected 0 < band < min_side ({min_side}), got {band}")
    if not 0 < fill <= 1 or not 0 < max_tilt < 90:
        raise ValueError(f"fill, max_tilt: expected (0, 1] and (0, 90) degrees, got {fill}, "
                         f"{max_tilt}")
    if len(P) < 10:
        return []
    rng = np.random.default_rng(seed)
    cell = max(cell, 4.0 * _spacing(P, rng))
    k = int(math.ceil(min_side / cell)) | 1  # odd: the square has a centre cell
    cos_tilt = math.cos(math.radians(max_tilt))
    N = normal_lines(P, k=30)
    test = _RegionTest(P, N, band, cos_tilt, cell, k, fill)
    free = np.ones(len(P), dtype=bool)  # not on a support found so far
    pool = np.ones(len(P), dtype=bool)  # may seed a plane
    planes: list[SupportPlane] = []
    rejected = 0
    while len(planes) < max_planes and rejected < max_rejected:
        ids = np.flatnonzero(pool)
        if len(ids) < max(3, k * k):  # fewer points than one filled square could hold
            break
        best = _ransac_plane(P[ids], N[ids], band, cos_tilt, iterations, ransac_points, rng)
        if best is None:
            break
        n, d = best
        plane = test(free, n, d)
        if plane is None:  # not a support: its slab no longer seeds planes
            rejected += 1
            pool &= np.abs(P @ n + d) > band
            continue
        # refit the plane on the support's own points, then take its region again
        on = plane.contains(P) & free
        c = P[on].mean(0)
        n2 = np.linalg.svd(P[on] - c, full_matrices=False)[2][2]
        plane = test(free, n2, -float(n2 @ c)) or plane
        on = plane.contains(P) & free
        planes.append(plane)
        free &= ~on
        pool &= ~on
        rejected = 0
    return planes


def _ransac_plane(Q: np.ndarray, NQ: np.ndarray, band: float, cos_tilt: float,
                  iterations: int, n_score: int, rng) -> tuple[np.ndarray, float] | None:
    """Best plane ``(unit normal (3,), offset)`` of points ``Q`` (q, 3) with normal lines
    ``NQ``: of ``iterations`` random triples, those whose points' normals agree with the
    triple's plane are scored by the points of a subset within ``band`` of the plane with
    agreeing normals. None when no triple agrees."""
    tri = rng.integers(0, len(Q), size=(iterations, 3))
    a = Q[tri[:, 0]]
    n = np.cross(Q[tri[:, 1]] - a, Q[tri[:, 2]] - a)
    length = np.linalg.norm(n, axis=1)
    ok = length > 1e-12
    n[ok] /= length[ok, None]
    ok &= np.all(np.abs(np.einsum("tkd,td->tk", NQ[tri], n)) >= cos_tilt, axis=1)
    if not ok.any():
        return None
    n = n[ok][:1000]  # enough agreeing candidates
    d = -np.einsum("td,td->t", n, a[ok][:1000])
    sub = rng.choice(len(Q), min(n_score, len(Q)), replace=False)
    score = np.zeros(len(n), dtype=np.int64)
    for s in range(0, len(n), 100):
        dist = np.abs(Q[sub] @ n[s:s + 100].T + d[s:s + 100])
        agree = np.abs(NQ[sub] @ n[s:s + 100].T) >= cos_tilt
        score[s:s + 100] = ((dist <= band) & agree).sum(0)
    i = int(score.argmax())
    return n[i], float(d[i])


def support_mask(points: np.ndarray, planes: list[SupportPlane]) -> np.ndarray:
    """(p,) bool: the points (p, 3) lying on any of ``planes``."""
    P = np.asarray(points, dtype=np.float64)
    out = np.zeros(len(P), dtype=bool)
    for plane in planes:
        out |= plane.contains(P)
    return out


def scan_without_support(scan, planes: list[SupportPlane]):
    """``scan`` (a ``(V, F)`` mesh, a trimesh, or ``(p, 3)`` points) without what lies on
    ``planes``, of the same kind: points on a support dropped; for a mesh the faces whose
    three vertices lie on supports dropped and the vertices no face uses left out (so a
    render or a bounding box sees only the person). ``planes`` empty: ``scan`` itself."""
    if not planes:
        return scan
    if hasattr(scan, "vertices") and hasattr(scan, "faces"):
        scan = (np.asarray(scan.vertices), np.asarray(scan.faces))
    if isinstance(scan, (tuple, list)):
        V, F = np.asarray(scan[0], dtype=np.float64), np.asarray(scan[1], dtype=np.int64)
        F = F[~support_mask(V, planes)[F].all(1)]
        used = np.unique(F)
        remap = np.full(len(V), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        return V[used], remap[F]
    P = np.asarray(scan, dtype=np.float64)
    return P[~support_mask(P, planes)]


def remove_support(points: np.ndarray, **options) -> tuple[np.ndarray, list[SupportPlane]]:
    """Drop the points on supports; return ``(kept points (q, 3), planes)``.

    ``options`` go to :func:`find_supports`. Raises InputError when supports cover more
    than :data:`MAX_SUPPORT_SHARE` of the scan (no person left to fit).
    """
    P = np.asarray(points, dtype=np.float64)
    planes = find_supports(P, **options)
    on = support_mask(P, planes)
    if on.mean() > MAX_SUPPORT_SHARE or len(P) - on.sum() < 10:
        raise InputError(
            f"scan: {int(on.sum())} of {len(P)} points lie on {len(planes)} large flat "
            f"surfaces (floor, seat, wall), too few are left for a person; crop the scan, or "
            f"keep the flat surfaces (remove_support=False, dressmeup register --keep-support)")
    return P[~on], planes


def _spacing(P: np.ndarray, rng, n: int = 2000) -> float:
    """Median nearest-neighbour distance (m) of a random subset of ``P`` to all of ``P``."""
    sub = P[rng.choice(len(P), min(n, len(P)), replace=False)]
    d, _ = cKDTree(P).query(sub, k=2, workers=1)
    return float(np.median(d[:, 1]))


@dataclass
class _RegionTest:
    """The support test of one plane on a scan (points ``P`` with unit normals ``N``)."""

    P: np.ndarray
    N: np.ndarray
    band: float
    cos_tilt: float
    cell: float
    k: int
    fill: float

    def __call__(self, free: np.ndarray, normal: np.ndarray, offset: float
                 ) -> SupportPlane | None:
        """The plane's support region, or None: cells holding free slab points whose normal
        agrees with the plane, kept where a ``k`` x ``k`` square around them is at least
        ``fill`` occupied (the union of those squares)."""
        k = self.k
        slab = free & (np.abs(self.P @ normal + offset) <= self.band)
        on = slab & (np.abs(self.N @ normal) >= self.cos_tilt)
        if on.sum() < k * k:
            return None
        u = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        basis = np.stack([u, np.cross(normal, u)])
        ij = np.floor(self.P[on] @ basis.T / self.cell).astype(np.int64)
        lo = ij.min(0) - k  # a margin of k cells: the filters see no border
        ij -= lo
        grid = np.zeros(ij.max(0) + 1 + k, dtype=bool)
        grid[ij[:, 0], ij[:, 1]] = True
        share = ndimage.uniform_filter(grid.astype(np.float64), size=k, mode="constant")
        centres = share >= self.fill - 1e-9
        if not centres.any():
            return None
        region = ndimage.binary_dilation(centres, structure=np.ones((k, k), dtype=bool))
        plane = SupportPlane(normal=normal, offset=offset, basis=basis, cell=self.cell,
                             origin=lo, region=region, band=self.band, points=0)
        return replace(plane, points=int((plane.contains(self.P) & free).sum()))
