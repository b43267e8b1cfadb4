"""PLY files: the header check, the reader (trimesh's parser), our binary writers.

:func:`check_ply_header` runs before any body is parsed so that a damaged or hostile header
never makes the reader allocate for it. :func:`read_ply` and :func:`write_mesh_ply` are the
PLY side of :func:`dressmeup.io.mesh.load_mesh` / :func:`~dressmeup.io.mesh.save_mesh`
(float64 coordinates, per-vertex ``s, t`` or per-corner ``texcoord`` UVs, a MeshLab
``comment TextureFile``); :func:`write_ply` is the compact float32 writer of fused scans and
labelled meshes.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_bytes

__all__ = ["check_ply_header", "read_ply", "write_mesh_ply", "write_ply"]

log = logging.getLogger(__name__)

_PLY_HEADER_MAX = 65536
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2,
              "int16": 2, "uint16": 2, "int": 4, "uint": 4, "int32": 4, "uint32": 4,
              "float": 4, "float32": 4, "double": 8, "float64": 8}


def check_ply_header(path: str | os.PathLike) -> dict[str, int]:
    """Read and check a PLY header before the body is parsed.

    Returns the declared element counts (e.g. ``{"vertex": n, "face": m}``).

    Raises
    ------
    InputError
        Not a PLY file, no ``end_header`` within 64 KiB, an unknown format, or declared
        counts that the file is too small to hold (so a damaged or hostile header never makes
        the reader allocate for it).
    """
    path = Path(path)
    with open(path, "rb") as fh:
        head = fh.read(_PLY_HEADER_MAX)
    if not (head.startswith(b"ply\n") or head.startswith(b"ply\r\n")):
        raise InputError(f"{path}: not a PLY file (it does not start with 'ply')")
    end = head.find(b"end_header")
    if end < 0:
        raise InputError(f"{path}: PLY header has no 'end_header' within "
                         f"{_PLY_HEADER_MAX // 1024} KiB")
    lines = head[:end].decode("ascii", "replace").splitlines()[1:]
    fmt, counts, min_row = None, {}, {}
    current = None
    for ln in lines:
        parts = ln.split()
        if not parts or parts[0] in ("comment", "obj_info"):
            continue
        if parts[0] == "format" and len(parts) >= 2:
            fmt = parts[1]
        elif parts[0] == "element" and len(parts) == 3:
            try:
                counts[parts[1]] = int(parts[2])
            except ValueError:
                raise InputError(f"{path}: PLY header: element {parts[1]!r} count "
                                 f"{parts[2]!r} is not an integer") from None
            if counts[parts[1]] < 0:
                raise InputError(f"{path}: PLY header: negative count for {parts[1]!r}")
            current = parts[1]
            min_row[current] = 0
        elif parts[0] == "property" and current is not None:
            if parts[1] == "list" and len(parts) >= 5:  # at least the count of each list
                min_row[current] += _PLY_SIZES.get(parts[2], 1)
            else:
                min_row[current] += _PLY_SIZES.get(parts[1], 1)
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise InputError(f"{path}: PLY header: unknown format {fmt!r}")
    body = path.stat().st_size - (end + len("end_header"))
    # ASCII rows take at least two bytes ("0\n"); binary rows their fixed part
    need = sum(counts[e] * (2 if fmt == "ascii" else min_row.get(e, 0)) for e in counts)
    if need > body:
        decl = ", ".join(f"{n} {e}" for e, n in counts.items())
        raise InputError(f"{path}: PLY header declares {decl} but the file holds only "
                         f"{body} bytes after the header (truncated or damaged)")
    return counts


def _fan(F: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons ``(m, k)`` with ``k > 3`` corners into ``(m (k-2), 3)``."""
    k = F.shape[1]
    tris = [F[:, [0, j, j + 1]] for j in range(1, k - 1)]
    return np.stack(tris, axis=1).reshape(-1, 3)


def read_ply(path: Path) -> tuple:
    """Parse a PLY file (trimesh's parser) into ``(V, F, uv, uv_faces, texture, colours)``.

    ``V`` is ``(n, 3) float64``, ``F`` ``(m, 3) int64`` (polygons fan-triangulated); ``uv`` is
    per vertex ``(n, 2)`` (``s, t`` / ``u, v`` / ``texture_u, texture_v``) with ``uv_faces``
    None, or per corner ``(3 m, 2)`` from a face ``texcoord`` list with ``uv_faces (m, 3)``;
    the texture is the existing file named by a ``comment TextureFile`` line; colours are
    ``(n, 3) uint8``. Call :func:`check_ply_header` first on untrusted files.

    Raises
    ------
    InputError
        The parser fails, or the file has no vertices or no polygon faces.
    """
    # heavy: trimesh (~0.7 s to import)
    from trimesh.exchange.ply import load_ply

    # the texture is resolved below from the header; trimesh would try too and log a
    # traceback ("unable to load image!", logger trimesh.util) when it cannot
    tlog = logging.getLogger("trimesh.util")
    was_disabled = tlog.disabled
    tlog.disabled = True
    try:
        with open(path, "rb") as fh:
            kwargs = load_ply(fh, fix_texture=False, skip_materials=True)
    except Exception as exc:  # noqa: BLE001 - a third-party parser on untrusted bytes
        raise InputError(f"{path}: cannot parse PLY ({type(exc).__name__}: {exc})") from exc
    finally:
        tlog.disabled = was_disabled
    raw = kwargs.get("metadata", {}).get("_ply_raw", {})
    vdata = raw.get("vertex", {}).get("data")
    if vdata is None or not raw.get("vertex", {}).get("length"):
        raise InputError(f"{path}: the mesh has no vertices")
    V = np.column_stack([np.asarray(vdata[c], dtype=np.float64) for c in "xyz"])
    F = kwargs.get("faces")
    if F is None:
        raise InputError(f"{path}: the mesh has no triangle faces")
    F = np.asarray(F, dtype=np.int64)
    polygons = F.ndim == 2 and F.shape[1] > 3
    if polygons:  # quads and other polygons: fan-triangulated, as OBJ
        F = _fan(F)
    if F.ndim != 2 or F.shape[1] != 3:
        raise InputError(f"{path}: expected polygon faces, got shape {F.shape}")
    uv = uvf = None
    names = set(vdata.dtype.names or ()) if hasattr(vdata, "dtype") else set(vdata)
    for su, sv in (("s", "t"), ("texture_u", "texture_v"), ("u", "v"), ("texture_s", "texture_t")):
        if su in names and sv in names:
            uv = np.column_stack(
                [np.asarray(vdata[su], np.float64), np.asarray(vdata[sv], np.float64)]
            )
            break
    fdata = raw.get("face", {}).get("data")
    texcoord = None
    if isinstance(fdata, dict) and "texcoord" in fdata:
        texcoord = fdata["texcoord"]
    elif hasattr(fdata, "dtype") and fdata.dtype.names and "texcoord" in fdata.dtype.names:
        texcoord = fdata["texcoord"]["f1"] if fdata["texcoord"].dtype.names else fdata["texcoord"]
    if texcoord is not None and uv is None and not polygons:
        tc = np.asarray(texcoord, dtype=np.float64)
        if tc.ndim == 2 and tc.shape == (F.shape[0], 6):
            uv = tc.reshape(-1, 2)
            uvf = np.arange(uv.shape[0], dtype=np.int64).reshape(-1, 3)
    vc = None
    if {"red", "green", "blue"} <= names:
        c = np.column_stack([np.asarray(vdata[k]) for k in ("red", "green", "blue")])
        vc = (
            np.clip(np.round(c * 255.0), 0, 255) if np.issubdtype(c.dtype, np.floating) else c
        ).astype(np.uint8)
    tex = None
    with open(path, "rb") as fh:
        head = fh.read(_PLY_HEADER_MAX).split(b"end_header")[0].decode("ascii", errors="replace")
    for line in head.splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[0] == "comment" and parts[1].lower() == "texturefile":
            cand = path.parent / line.split(maxsplit=2)[2].strip()
            if cand.is_file():
                tex = cand
            else:
                log.warning("%s: texture %s not found", path, cand)
    return V, F, uv, uvf, tex, vc


def write_mesh_ply(path: Path, V: np.ndarray, F: np.ndarray, uv: np.ndarray | None,
                   uv_faces: np.ndarray | None, tex_name: str | None,
                   vc: np.ndarray | None) -> None:
    """Write checked arrays as a binary little-endian PLY with float64 coordinates, atomically.

    ``V (n, 3) float64``, ``F (m, 3) int64``; per-vertex ``uv (n, 2)`` (``uv_faces`` None)
    becomes vertex properties ``s, t``, per-corner UVs a face ``texcoord`` list; ``tex_name``
    a ``comment TextureFile`` line; ``vc (n, 3) uint8`` the vertex ``red, green, blue``.
    """
    n, m = V.shape[0], F.shape[0]
    vfields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    header = ["ply", "format binary_little_endian 1.0", "comment written by dressmeup"]
    if tex_name is not None:
        header.append(f"comment TextureFile {tex_name}")
    header += [f"element vertex {n}", "property double x", "property double y", "property double z"]
    per_vertex_uv = uv is not None and uv_faces is None
    if per_vertex_uv:
        vfields += [("s", "<f8"), ("t", "<f8")]
        header += ["property double s", "property double t"]
    if vc is not None:
        vfields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
        header += ["property uchar red", "property uchar green", "property uchar blue"]
    vert = np.empty(n, dtype=vfields)
    vert["x"], vert["y"], vert["z"] = V[:, 0], V[:, 1], V[:, 2]
    if per_vertex_uv:
        vert["s"], vert["t"] = uv[:, 0], uv[:, 1]
    if vc is not None:
        vert["red"], vert["green"], vert["blue"] = vc[:, 0], vc[:, 1], vc[:, 2]
    header += [f"element face {m}", "property list uchar int vertex_indices"]
    ffields = [("n", "u1"), ("vi", "<i4", (3,))]
    if uv is not None and not per_vertex_uv:
        header.append("property list uchar double texcoord")
        ffields += [("nt", "u1"), ("tc", "<f8", (6,))]
    face = np.empty(m, dtype=ffields)
    face["n"] = 3
    face["vi"] = F
    if uv is not None and not per_vertex_uv:
        face["nt"] = 6
        face["tc"] = uv[uv_faces].reshape(m, 6)
    header.append("end_header")
    data = ("\n".join(header) + "\n").encode("ascii") + vert.tobytes() + face.tobytes()
    atomic_write_bytes(path, data)


def write_ply(path: str | os.PathLike, vertices: np.ndarray, faces: np.ndarray,
              colors: np.ndarray | None = None, face_labels: np.ndarray | None = None) -> Path:
    """Write a compact binary PLY (float32 coordinates), atomically: fused scans and labelled
    meshes. :func:`save_mesh` is the general writer (float64, UVs, textures).

    Parameters
    ----------
    path : target ``.ply`` file.
    vertices : (n, 3) float (stored as float32), faces : (m, 3) int (stored as int32).
    colors : (n, 3) uint8 or None, per-vertex ``red, green, blue``.
    face_labels : (m,) int in [0, 255] or None, a per-face ``label`` property.

    Returns
    -------
    pathlib.Path of the written file.
    """
    V = np.asarray(vertices, dtype=np.float32)
    F = np.asarray(faces, dtype=np.int32)
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(V)}",
              "property float x", "property float y", "property float z"]
    vdt = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if colors is not None:
        header += ["property uchar red", "property uchar green", "property uchar blue"]
        vdt += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    header += [f"element face {len(F)}", "property list uchar int vertex_indices"]
    fdt = [("n", "u1"), ("v", "<i4", (3,))]
    if face_labels is not None:
        header.append("property uchar label")
        fdt.append(("label", "u1"))
    header.append("end_header")
    va = np.empty(len(V), dtype=vdt)
    va["x"], va["y"], va["z"] = V[:, 0], V[:, 1], V[:, 2]
    if colors is not None:
        c = np.asarray(colors, dtype=np.uint8)
        va["red"], va["green"], va["blue"] = c[:, 0], c[:, 1], c[:, 2]
    fa = np.empty(len(F), dtype=fdt)
    fa["n"] = 3
    fa["v"] = F
    if face_labels is not None:
        fa["label"] = np.asarray(face_labels, dtype=np.uint8)
    path = Path(path)
    atomic_write_bytes(path, ("\n".join(header) + "\n").encode("ascii") + va.tobytes() + fa.tobytes())
    return path
