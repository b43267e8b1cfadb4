"""The UV-parameterisation test meshes, generated deterministically by name.

Benchmark editions of the ``uvparam`` task refer to meshes by id; :func:`make_test_mesh`
builds each one from code (no mesh files are shipped). A mesh id is ``<shape>-<resolution>``
where the resolution is an approximate vertex count with a ``k`` suffix (``sphere-2k``,
``torus-30k``, ``blob-100k``) or ``native`` for the body model's own mesh.

Shapes
------
``sphere``  closed, genus 0: a cube-sphere (cube faces subdivided and projected), radius 0.3 m.
``torus``   closed, genus 1: major radius 0.3 m, minor radius 0.1 m, parametric grid.
``blob``    closed, genus 0: a sphere with smooth random radial bumps (fixed seed).
``sheet``   open, disk: a 0.6 m square cloth sheet with two crossing folds.
``skirt``   open, annulus (two boundary loops): a flared tube with sinusoidal folds, the
            synthetic garment.
``body``    closed: the default body model's skin (largest connected component) in its rest
            pose; ``body-native`` is the model's mesh, other resolutions are decimated
            (quadric) or Loop-subdivided from it.

All generators are deterministic: the same id gives bit-identical arrays on any machine with
the same numpy. Units are metres.
"""

from __future__ import annotations

import re

import numpy as np

from dressmeup.body import get_body_model
from dressmeup.errors import InputError

__all__ = ["SHAPES", "make_test_mesh", "parse_mesh_id", "DEFAULT_MESH_IDS", "SHAPES_VERSION"]

SHAPES_VERSION = "uvparam-shapes-v1"
SHAPES = ("sphere", "torus", "blob", "sheet", "skirt", "body")
#: the mesh set the ``synth-uvparam-v1`` edition is meant to contain
DEFAULT_MESH_IDS = (
    "sphere-2k", "sphere-10k", "torus-3k", "torus-30k", "blob-3k", "blob-30k",
    "sheet-2k", "skirt-3k", "skirt-30k", "body-native",
)


def parse_mesh_id(mesh_id: str) -> tuple[str, int | None]:
    """Split ``"torus-30k"`` into ``("torus", 30000)``; ``"body-native"`` gives ``None``.

    Raises
    ------
    InputError
        Unknown shape or malformed resolution.
    """
    m = re.fullmatch(r"([a-z]+)-(native|\d+(?:\.\d+)?k|\d+)", str(mesh_id))
    if not m or m.group(1) not in SHAPES:
        raise InputError(
            f"mesh id {mesh_id!r}: expected '<shape>-<count>' with shape in {', '.join(SHAPES)} "
            "and count like '3k', '100k' or 'native' (body only)")
    shape, res = m.group(1), m.group(2)
    if res == "native":
        if shape != "body":
            raise InputError(f"mesh id {mesh_id!r}: 'native' resolution exists only for 'body'")
        return shape, None
    n = int(round(float(res[:-1]) * 1000)) if res.endswith("k") else int(res)
    if n < 100:
        raise InputError(f"mesh id {mesh_id!r}: at least 100 vertices are needed, got {n}")
    return shape, n


def _grid_faces(nu: int, nv: int, wrap_u: bool, wrap_v: bool) -> np.ndarray:
    """Triangles of an nu x nv vertex grid (index u * nv + v), optionally periodic."""
    cu = nu if wrap_u else nu - 1
    cv = nv if wrap_v else nv - 1
    iu, iv = np.meshgrid(np.arange(cu), np.arange(cv), indexing="ij")
    iu, iv = iu.ravel(), iv.ravel()
    a = iu * nv + iv
    b = ((iu + 1) % nu) * nv + iv
    c = ((iu + 1) % nu) * nv + (iv + 1) % nv
    d = iu * nv + (iv + 1) % nv
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)


def cube_sphere(r: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit sphere from a cube whose faces are r x r grids (6 r^2 + 2 vertices).

    Returns
    -------
    V : (6 r^2 + 2, 3) float64 on the unit sphere
    F : (12 r^2, 3) int64, outward (counter-clockwise seen from outside)
    """
    t = np.tan(np.linspace(-np.pi / 4, np.pi / 4, r + 1))  # equi-angular grid
    verts, faces = [], []
    axes = [(0, 1, 2), (1, 2, 0), (2, 0, 1)]
    for ax in axes:
        for sign in (1.0, -1.0):
            a, b = np.meshgrid(t, t, indexing="ij")
            p = np.zeros((r + 1, r + 1, 3))
            p[..., ax[0]] = sign
            p[..., ax[1]] = a
            p[..., ax[2]] = b
            f = _grid_faces(r + 1, r + 1, False, False)
            if sign < 0:
                f = f[:, ::-1]
            faces.append(f + sum(len(v) for v in verts))
            verts.append(p.reshape(-1, 3))
    V = np.concatenate(verts)
    F = np.concatenate(faces)
    # weld duplicated cube-edge vertices
    key = np.round(V * 1e9).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    remap = np.empty_like(order)
    remap[order] = np.arange(len(order))
    V = V[first[order]]
    F = remap[inverse.reshape(-1)[F]]
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    # make faces outward
    c = V[F].mean(1)
    nrm = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    flip = np.einsum("ij,ij->i", nrm, c) < 0
    F[flip] = F[flip][:, ::-1]
    return V, F


def _sphere(n: int) -> tuple[np.ndarray, np.ndarray]:
    r = max(2, int(round(np.sqrt(max(n - 2, 1) / 6.0))))
    V, F = cube_sphere(r)
    return 0.3 * V, F


def _blob(n: int) -> tuple[np.ndarray, np.ndarray]:
    V, F = _sphere(n)
    d = V / np.linalg.norm(V, axis=1, keepdims=True)
    rng = np.random.default_rng(7)
    dirs = rng.normal(size=(6, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    amps = rng.uniform(0.05, 0.15, size=6)
    widths = rng.uniform(3.0, 6.0, size=6)
    bump = np.zeros(len(d))
    for k in range(6):
        bump += amps[k] * np.exp(widths[k] * (d @ dirs[k] - 1.0))
    stretch = np.array([1.0, 0.8, 0.7])
    return 0.3 * d * stretch * (1.0 + bump)[:, None], F


def _torus(n: int) -> tuple[np.ndarray, np.ndarray]:
    nv = max(3, int(round(np.sqrt(n / 3.0))))
    nu = max(3, int(round(n / nv)))
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    U, W = np.meshgrid(u, v, indexing="ij")
    R, r = 0.3, 0.1
    x = (R + r * np.cos(W)) * np.cos(U)
    y = (R + r * np.cos(W)) * np.sin(U)
    z = r * np.sin(W)
    V = np.stack([x, y, z], -1).reshape(-1, 3)
    F = _grid_faces(nu, nv, True, True)
    return V, F


def _sheet(n: int) -> tuple[np.ndarray, np.ndarray]:
    k = max(3, int(round(np.sqrt(n))))
    s = np.linspace(-0.3, 0.3, k)
    X, Y = np.meshgrid(s, s, indexing="ij")
    Z = 0.06 * np.sin(np.pi * X / 0.3) + 0.05 * np.exp(-((Y - 0.05) ** 2) / 0.01)
    V = np.stack([X, Y, Z], -1).reshape(-1, 3)
    return V, _grid_faces(k, k, False, False)


def _skirt(n: int) -> tuple[np.ndarray, np.ndarray]:
    nv = max(3, int(round(np.sqrt(n / 3.0))))
    nu = max(6, int(round(n / nv)))
    u = 2 * np.pi * np.arange(nu) / nu
    h = np.linspace(0.0, 1.0, nv)
    U, H = np.meshgrid(u, h, indexing="ij")
    radius = 0.16 + 0.14 * H + 0.02 * H * np.sin(8 * U)  # waist -> flared, folded hem
    x = radius * np.cos(U)
    y = radius * np.sin(U)
    z = -0.55 * H + 0.015 * np.sin(3 * U) * H
    V = np.stack([x, y, z], -1).reshape(-1, 3)
    return V, _grid_faces(nu, nv, True, False)


def _body(n: int | None) -> tuple[np.ndarray, np.ndarray]:
    # heavy: trimesh (~0.7 s to import)
    import trimesh

    model = get_body_model("anny")
    V = np.asarray(model.template_vertices, dtype=np.float64)
    F = np.asarray(model.faces, dtype=np.int64)
    mesh = trimesh.Trimesh(V, F, process=False)
    parts = mesh.split(only_watertight=False)
    skin = max(parts, key=lambda p: len(p.faces))
    V, F = np.asarray(skin.vertices, dtype=np.float64), np.asarray(skin.faces, dtype=np.int64)
    if n is None:
        return V, F
    # heavy: igl (~0.4 s to import)
    import igl

    while len(V) * 1.2 < n:  # Loop subdivision roughly quadruples the count
        V, F = igl.loop(V, F)
        V, F = np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)
    if len(V) > 1.2 * n:
        ok, V2, F2, _, _ = igl.decimate(V, F, int(2 * n))
        V, F = np.asarray(V2, dtype=np.float64), np.asarray(F2, dtype=np.int64)
    return V, F


def make_test_mesh(mesh_id: str) -> tuple[np.ndarray, np.ndarray]:
    """Build a named test mesh.

    Parameters
    ----------
    mesh_id : str
        ``<shape>-<count>`` as in :data:`DEFAULT_MESH_IDS` (e.g. ``"torus-30k"``), or
        ``"body-native"``. The vertex count is approximate (grids round it).

    Returns
    -------
    V : (n, 3) float64, metres
    F : (m, 3) int64

    Raises
    ------
    InputError
        Unknown id, or the body model is unavailable.
    """
    shape, n = parse_mesh_id(mesh_id)
    if shape == "body":
        return _body(n)
    fn = {"sphere": _sphere, "torus": _torus, "blob": _blob, "sheet": _sheet, "skirt": _skirt}[shape]
    V, F = fn(n)
    return np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(F, dtype=np.int64)
