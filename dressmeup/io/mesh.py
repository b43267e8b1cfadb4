"""Mesh files: PLY and OBJ with UVs (per vertex or per corner), textures and vertex colours.

:func:`load_mesh` returns a :class:`MeshData`; :func:`save_mesh` writes PLY or OBJ
(+ MTL + PNG) atomically. The formats live beside this module: :mod:`dressmeup.io.obj` (a
small reader/writer of our own, so that per-corner UVs round-trip exactly) and
:mod:`dressmeup.io.ply` (trimesh's parser behind a header check, our binary writers); here are
the checks both share (suffix, size bound, arguments, the loaded arrays) and the texture.

Conventions
-----------
- ``uv`` with ``uv_faces is None`` is per vertex, ``(n, 2)``; with ``uv_faces (m, 3)`` it is
  per corner (``uv_faces`` indexes into ``uv``), as in OBJ files.
- An OBJ with ``vt`` always loads per corner (``uv``, ``uv_faces``), exactly as the file says.
- A PLY with per-vertex ``s, t`` / ``u, v`` / ``texture_u, texture_v`` loads per vertex; a PLY
  with a per-face ``texcoord`` list (MeshLab) loads per corner.
- Textures: OBJ through ``mtllib`` / ``map_Kd``; PLY through a ``comment TextureFile`` line
  (MeshLab). The texture is written as a PNG beside the mesh (``<stem>.png``).
- Polygons with more than three corners are fan-triangulated on load.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from dressmeup.errors import InputError
from dressmeup.geometry.mesh import as_arrays, as_faces, as_points
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.io.images import image_header, read_image
from dressmeup.io.obj import read_obj, write_obj
from dressmeup.io.ply import check_ply_header, read_ply, write_mesh_ply
from dressmeup.limits import MESH_BYTES

__all__ = ["MeshData", "load_mesh", "save_mesh"]

MESH_SUFFIXES = (".ply", ".obj")


@dataclass
class MeshData:
    """A triangle mesh read from a file.

    Attributes
    ----------
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
    uv : (n, 2) or (k, 2) float64 ndarray or None
        Per-vertex UVs (``uv_faces is None``) or per-corner UVs indexed by ``uv_faces``.
    uv_faces : (m, 3) int64 ndarray or None
    texture_path : pathlib.Path or None
        Texture image referenced by the file (only when it exists on disk).
    vertex_colors : (n, 3) uint8 ndarray or None
    path : pathlib.Path or None
        The file the mesh came from.
    """

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None = None
    uv_faces: np.ndarray | None = None
    texture_path: Path | None = None
    vertex_colors: np.ndarray | None = None
    path: Path | None = None

    @property
    def has_uv(self) -> bool:
        """Whether the mesh carries UV coordinates."""
        return self.uv is not None

    def to_trimesh(self):
        """The geometry as a ``trimesh.Trimesh`` (``process=False``; UVs not attached)."""
        # heavy: trimesh (~0.7 s to import)
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)


# ----------------------------------------------------------------------------------- loading
def load_mesh(path: str | os.PathLike) -> MeshData:
    """Read a triangle mesh from a PLY or OBJ file.

    Parameters
    ----------
    path : str or path-like
        ``.ply`` or ``.obj`` file.

    Returns
    -------
    MeshData

    Raises
    ------
    FileNotFoundError
        The file does not exist (the message names it).
    InputError
        The file cannot be parsed, has an unsupported extension, has no vertices or no faces,
        or its faces point outside the vertex list.
    """
    path = Path(path)
    if not path.is_file():
        if path.exists():
            raise InputError(f"{path}: not a regular file (expected a .ply or .obj mesh)")
        raise FileNotFoundError(f"mesh file not found: {path}")
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise InputError(f"{path}: unsupported mesh format {suffix!r} (expected .ply or .obj)")
    MESH_BYTES.check(path.stat().st_size, str(path))  # before reading (dressmeup.limits)
    if suffix == ".ply":
        check_ply_header(path)
    try:
        mesh = MeshData(*(read_obj(path) if suffix == ".obj" else read_ply(path)))
    except InputError:
        raise
    except (OSError, UnicodeDecodeError, ValueError, KeyError, IndexError, TypeError) as exc:
        raise InputError(f"{path}: cannot read mesh ({type(exc).__name__}: {exc})") from exc
    mesh.path = path
    _check_loaded(mesh, path)
    return mesh


def _check_loaded(mesh: MeshData, path: Path) -> None:
    V, F = mesh.vertices, mesh.faces
    if V.ndim != 2 or V.shape[0] == 0:
        raise InputError(f"{path}: the mesh has no vertices")
    if F.ndim != 2 or F.shape[0] == 0:
        raise InputError(f"{path}: the mesh has no triangle faces")
    if not np.all(np.isfinite(V)):
        raise InputError(f"{path}: vertex coordinates contain NaN or inf")
    if F.min() < 0 or F.max() >= V.shape[0]:
        raise InputError(f"{path}: face indices out of range [0, {V.shape[0] - 1}]")
    if mesh.uv is not None and mesh.uv_faces is not None:
        if (
            mesh.uv_faces.shape != F.shape
            or mesh.uv_faces.min() < 0
            or mesh.uv_faces.max() >= len(mesh.uv)
        ):
            raise InputError(f"{path}: texture-coordinate indices out of range")


# ----------------------------------------------------------------------------------- saving
def _check_save_args(vertices, faces, uv, uv_faces, vertex_colors):
    V, F = as_arrays(vertices, faces, name="mesh")
    if uv is not None:
        uv = as_points(uv, name="uv", dim=2)
        if uv_faces is None:
            if uv.shape[0] != V.shape[0]:
                raise InputError(
                    f"uv: per-vertex UVs need shape ({V.shape[0]}, 2), got {uv.shape}; "
                    "pass uv_faces for per-corner UVs"
                )
        else:
            uv_faces = as_faces(uv_faces, uv.shape[0], name="uv_faces")
            if uv_faces.shape != F.shape:
                raise InputError(
                    f"uv_faces: expected shape {F.shape} (one row per face), got {uv_faces.shape}"
                )
    elif uv_faces is not None:
        raise InputError("uv_faces: given without uv")
    if vertex_colors is not None:
        vc = np.asarray(vertex_colors)
        if vc.ndim != 2 or vc.shape[0] != V.shape[0] or vc.shape[1] not in (3, 4):
            raise InputError(f"vertex_colors: expected shape ({V.shape[0]}, 3), got {vc.shape}")
        if np.issubdtype(vc.dtype, np.floating):
            vc = np.clip(np.round(vc * 255.0), 0, 255)
        vertex_colors = vc[:, :3].astype(np.uint8)
    return V, F, uv, uv_faces, vertex_colors


def _texture_bytes(texture) -> bytes:
    if isinstance(texture, (str, os.PathLike)):
        src = Path(texture)
        if not src.is_file():
            raise FileNotFoundError(f"texture file not found: {src}")
        if src.suffix.lower() == ".png":
            image_header(src, "texture", verify=True)
            return src.read_bytes()
        buf = io.BytesIO()
        Image.fromarray(read_image(src, "texture")).save(buf, format="PNG")
        return buf.getvalue()
    arr = np.asarray(texture)
    if (
        arr.ndim not in (2, 3)
        or (arr.ndim == 3 and arr.shape[2] not in (3, 4))
        or arr.dtype != np.uint8
    ):
        raise InputError(
            f"texture: expected an (H, W, 3) uint8 image or a file path, got {arr.dtype} {arr.shape}"
        )
    buf = io.BytesIO()
    Image.fromarray(arr).save(buf, format="PNG")
    return buf.getvalue()


def save_mesh(
    path: str | os.PathLike,
    vertices: np.ndarray,
    faces: np.ndarray,
    uv: np.ndarray | None = None,
    uv_faces: np.ndarray | None = None,
    texture: np.ndarray | str | os.PathLike | None = None,
    vertex_colors: np.ndarray | None = None,
) -> Path:
    """Write a triangle mesh as PLY or OBJ (with MTL and PNG texture when given), atomically.

    Parameters
    ----------
    path : str or path-like
        Target file; the extension (``.ply`` or ``.obj``) picks the format.
    vertices : (n, 3) float array
    faces : (m, 3) int array
    uv : (n, 2) or (k, 2) float array, optional
        Per-vertex UVs, or per-corner UVs when ``uv_faces`` is given.
    uv_faces : (m, 3) int array, optional
        Per-corner UV indices into ``uv``.
    texture : (H, W, 3) uint8 array or path, optional
        Texture image, written as ``<stem>.png`` beside the mesh.
    vertex_colors : (n, 3) uint8 (or float in [0, 1]) array, optional

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ValueError
        Bad arrays (naming the argument) or an unsupported extension.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise InputError(f"path: unsupported mesh format {suffix!r} (expected .ply or .obj)")
    V, F, uv, uv_faces, vc = _check_save_args(vertices, faces, uv, uv_faces, vertex_colors)
    tex_name = None
    if texture is not None:
        tex_name = f"{path.stem}.png"
        data = _texture_bytes(texture)
        target = path.parent / tex_name
        if isinstance(texture, (str, os.PathLike)) and Path(texture).resolve() == target.resolve():
            pass  # already in place
        else:
            atomic_write_bytes(target, data)
    write = write_obj if suffix == ".obj" else write_mesh_ply
    write(path, V, F, uv, uv_faces, tex_name, vc)
    return path
