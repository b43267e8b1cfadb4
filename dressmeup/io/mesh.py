"""Mesh files: PLY and OBJ with UVs (per vertex or per corner), textures and vertex colours.

:func:`load_mesh` returns a :class:`MeshData`; :func:`save_mesh` writes PLY or OBJ
(+ MTL + PNG) atomically. OBJ is read and written by a small reader/writer of our own so that
per-corner UVs (``f v/vt``, texture seams) round-trip exactly: trimesh splits seam vertices
when it loads textured OBJs, which would change the vertex count. PLY is parsed by trimesh's
PLY parser and written by our own binary writer (coordinates in float64).

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
import logging
import os
from array import array
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from dressmeup.errors import InputError
from dressmeup.geometry.mesh import as_arrays, as_faces, as_points
from dressmeup.io.atomic import atomic_write_bytes, atomic_write_text

__all__ = ["MeshData", "load_mesh", "save_mesh", "write_ply"]

log = logging.getLogger(__name__)

MESH_SUFFIXES = (".ply", ".obj")
#: Largest mesh file read (bytes; ``DRESSMEUP_MAX_MESH_BYTES`` overrides): a bound on memory,
#: checked before reading (the OBJ reader holds Python lists, about 2x the file size).
MAX_MESH_BYTES = 1 << 30
_PLY_HEADER_MAX = 65536
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2,
              "int16": 2, "uint16": 2, "int": 4, "uint": 4, "int32": 4, "uint32": 4,
              "float": 4, "float32": 4, "double": 8, "float64": 8}


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
    size = path.stat().st_size
    limit = int(os.environ.get("DRESSMEUP_MAX_MESH_BYTES", MAX_MESH_BYTES))
    if size > limit:
        raise InputError(f"{path}: {size / 1e6:.0f} MB is over the mesh size limit of "
                         f"{limit / 1e6:.0f} MB (set DRESSMEUP_MAX_MESH_BYTES to allow it)")
    if suffix == ".ply":
        check_ply_header(path)
    try:
        mesh = _load_obj(path) if suffix == ".obj" else _load_ply(path)
    except InputError:
        raise
    except (OSError, UnicodeDecodeError, ValueError, KeyError, IndexError, TypeError) as exc:
        raise InputError(f"{path}: cannot read mesh ({type(exc).__name__}: {exc})") from exc
    mesh.path = path
    _check_loaded(mesh, path)
    return mesh


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


def _obj_index(tok: str, count: int) -> int:
    i = int(tok)
    return i - 1 if i > 0 else count + i


def _load_obj(path: Path) -> MeshData:
    # compact buffers (8 bytes per number) instead of lists of Python floats: a large OBJ
    # costs about its own size in memory, not several times it
    verts, colors, uvs = array("d"), array("d"), array("d")
    faces, uv_faces = array("q"), array("q")
    n_v = n_c = n_t = 0
    missing_vt = False
    mtllibs: list[str] = []
    first_mtl: str | None = None
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            if not line or line[0] == "#":
                continue
            parts = line.split()
            if not parts:
                continue
            key = parts[0]
            try:
                if key == "v":
                    vals = [float(x) for x in parts[1:7]]
                    if len(vals) < 3:
                        raise ValueError("a vertex needs three coordinates")
                    verts.extend(vals[:3])
                    n_v += 1
                    if len(vals) >= 6:
                        colors.extend(vals[3:6])
                        n_c += 1
                elif key == "vt":
                    vals = [float(x) for x in parts[1:3]]
                    if len(vals) < 2:
                        raise ValueError("a texture coordinate needs u and v")
                    uvs.extend(vals)
                    n_t += 1
                elif key == "f":
                    vi: list[int] = []
                    ti: list[int] = []
                    for corner in parts[1:]:
                        sub = corner.split("/")
                        vi.append(_obj_index(sub[0], n_v))
                        if len(sub) > 1 and sub[1]:
                            ti.append(_obj_index(sub[1], n_t))
                    if len(vi) < 3:
                        raise InputError("a face needs at least three corners")
                    if len(ti) != len(vi):
                        missing_vt = True
                    for k in range(1, len(vi) - 1):
                        faces.extend((vi[0], vi[k], vi[k + 1]))
                        if len(ti) == len(vi):
                            uv_faces.extend((ti[0], ti[k], ti[k + 1]))
                elif key == "mtllib":
                    mtllibs.append(line.strip()[len("mtllib") :].strip())
                elif key == "usemtl" and first_mtl is None:
                    first_mtl = line.strip()[len("usemtl") :].strip()
            except (ValueError, IndexError, OverflowError) as exc:
                raise InputError(
                    f"{path}: line {lineno}: cannot parse {line.strip()[:60]!r} ({exc})"
                ) from exc
    V = np.frombuffer(verts, dtype=np.float64).reshape(-1, 3).copy() if n_v else np.zeros((0, 3))
    F = np.frombuffer(faces, dtype=np.int64).reshape(-1, 3).copy()
    uv = uvf = None
    if n_t and len(faces) and not missing_vt and len(uv_faces) == len(faces):
        uv = np.frombuffer(uvs, dtype=np.float64).reshape(-1, 2).copy()
        uvf = np.frombuffer(uv_faces, dtype=np.int64).reshape(-1, 3).copy()
    elif n_t and len(faces):
        log.warning("%s: some faces have no texture coordinates; UVs ignored", path)
    vc = None
    if n_c and n_c == n_v:
        c = np.frombuffer(colors, dtype=np.float64).reshape(-1, 3)
        vc = np.clip(np.round(c * 255.0 if c.max() <= 1.0 else c), 0, 255).astype(np.uint8)
    tex = _obj_texture(path, mtllibs, first_mtl)
    return MeshData(V, F, uv, uvf, tex, vc)


def _obj_texture(path: Path, mtllibs: list[str], material: str | None) -> Path | None:
    for lib in mtllibs:
        mtl = path.parent / lib
        if not mtl.is_file():
            log.warning("%s: material library %s not found", path, mtl)
            continue
        current = None
        found: dict[str, str] = {}
        for line in mtl.read_text(encoding="utf-8", errors="replace").splitlines():
            parts = line.strip().split(maxsplit=1)
            if len(parts) < 2:
                continue
            if parts[0] == "newmtl":
                current = parts[1].strip()
            elif parts[0] == "map_Kd" and current is not None:
                # options such as "-s 1 1 1" may precede the file name: take the last token
                found.setdefault(current, parts[1].split()[-1])
        name = found.get(material) if material in found else next(iter(found.values()), None)
        if name:
            tex = mtl.parent / name
            if tex.is_file():
                return tex
            log.warning("%s: texture %s not found", path, tex)
    return None


def _load_ply(path: Path) -> MeshData:
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
        head = fh.read(65536).split(b"end_header")[0].decode("ascii", errors="replace")
    for line in head.splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[0] == "comment" and parts[1].lower() == "texturefile":
            cand = path.parent / line.split(maxsplit=2)[2].strip()
            if cand.is_file():
                tex = cand
            else:
                log.warning("%s: texture %s not found", path, cand)
    return MeshData(V, F, uv, uvf, tex, vc)


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
            return src.read_bytes()
        with Image.open(src) as im:
            buf = io.BytesIO()
            im.convert("RGB").save(buf, format="PNG")
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
    if suffix == ".obj":
        _save_obj(path, V, F, uv, uv_faces, tex_name, vc)
    else:
        _save_ply(path, V, F, uv, uv_faces, tex_name, vc)
    return path


def _fmt_rows(arr: np.ndarray, prefix: str, fmt: str, row: str | None = None) -> str:
    if arr.shape[0] == 0:
        return ""
    if row is None:
        row = prefix + " " + " ".join([fmt] * arr.shape[1]) + "\n"
    return (row * arr.shape[0]) % tuple(arr.ravel().tolist())


def _save_obj(path: Path, V, F, uv, uv_faces, tex_name, vc) -> None:
    parts = ["# written by dressmeup\n"]
    if tex_name is not None:
        mtl_name = f"{path.stem}.mtl"
        atomic_write_text(
            path.parent / mtl_name,
            f"# written by dressmeup\nnewmtl material0\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\nmap_Kd {tex_name}\n",
        )
        parts.append(f"mtllib {mtl_name}\n")
    if vc is not None:
        parts.append(_fmt_rows(np.hstack([V, vc.astype(np.float64) / 255.0]), "v", "%.17g"))
    else:
        parts.append(_fmt_rows(V, "v", "%.17g"))
    if uv is not None:
        parts.append(_fmt_rows(uv, "vt", "%.17g"))
    if tex_name is not None:
        parts.append("usemtl material0\n")
    F1 = F + 1
    if uv is not None:
        T1 = (uv_faces if uv_faces is not None else F) + 1
        corners = np.stack([F1, T1], axis=2).reshape(F.shape[0], 6)
        parts.append(_fmt_rows(corners, "f", "%d", row="f %d/%d %d/%d %d/%d\n"))
    else:
        parts.append(_fmt_rows(F1, "f", "%d"))
    atomic_write_text(path, "".join(parts))


def _save_ply(path: Path, V, F, uv, uv_faces, tex_name, vc) -> None:
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
