"""OBJ files (+ MTL): a small reader and writer of our own.

Per-corner UVs (``f v/vt``, texture seams) round-trip exactly: trimesh splits seam vertices
when it loads textured OBJs, which would change the vertex count. :func:`read_obj` and
:func:`write_obj` are the OBJ side of :func:`dressmeup.io.mesh.load_mesh` /
:func:`~dressmeup.io.mesh.save_mesh`.
"""

from __future__ import annotations

import logging
from array import array
from pathlib import Path

import numpy as np

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text

__all__ = ["read_obj", "write_obj"]

log = logging.getLogger(__name__)


#: The statements of the OBJ format that :func:`read_obj` reads past without using (normals,
#: lines, groups, smoothing, free-form geometry, render attributes, ...).
_OBJ_IGNORED = frozenset((
    "vn vp p l o g s mg lod usemap maplib bevel c_interp d_interp shadow_obj trace_obj "
    "ctech stech cstype deg bmat step curv curv2 surf parm trim hole scrv sp end con call "
    "csh").split())


def _is_keyword(key: str) -> bool:
    """True for a word that could be an OBJ statement (ASCII letters, digits, ``_``)."""
    return key.isascii() and key.replace("_", "a").isalnum()


def _obj_index(tok: str, count: int) -> int:
    i = int(tok)
    return i - 1 if i > 0 else count + i


def _obj_face(parts: list[str], n_v: int, n_t: int) -> tuple[list[int], list[int]]:
    """The 0-based vertex and texture indices of the corners of one ``f`` line (texture
    indices only for the corners that have one)."""
    vi: list[int] = []
    ti: list[int] = []
    for corner in parts[1:]:
        sub = corner.split("/")
        vi.append(_obj_index(sub[0], n_v))
        if len(sub) > 1 and sub[1]:
            ti.append(_obj_index(sub[1], n_t))
    if len(vi) < 3:
        raise InputError("a face needs at least three corners")
    return vi, ti


def read_obj(path: Path) -> tuple:
    """Parse an OBJ file into ``(V, F, uv, uv_faces, texture, colours)``, exactly as written.

    ``V`` is ``(n, 3) float64``, ``F`` ``(m, 3) int64`` (polygons fan-triangulated, negative
    indices resolved); with ``vt`` on every face corner, ``uv (k, 2)`` and ``uv_faces (m, 3)``
    are per corner (seam vertices are not split); ``v x y z r g b`` lines give ``(n, 3) uint8``
    colours; the texture is the ``map_Kd`` of the first ``usemtl`` in a ``mtllib`` beside it.

    Statements it does not use (normals, groups, ...) are skipped; an unknown statement that
    is a plain word is skipped with a warning, and a line that starts with anything else
    (control characters such as NUL, bytes that are not UTF-8) is an error: a damaged ``f``
    or ``v`` line is never dropped silently.

    Raises
    ------
    InputError
        A line that cannot be parsed (the file and the line number are in the message).
    """
    # compact buffers (8 bytes per number) instead of lists of Python floats: a large OBJ
    # costs about its own size in memory, not several times it
    verts, colors, uvs = array("d"), array("d"), array("d")
    faces, uv_faces = array("q"), array("q")
    n_v = n_c = n_t = 0
    missing_vt = False
    mtllibs: list[str] = []
    first_mtl: str | None = None
    unknown: dict[str, int] = {}  # unknown statement -> the first line that has it
    # utf-8-sig: a byte-order mark is not part of the first statement
    with open(path, encoding="utf-8-sig", errors="replace") as fh:
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
                    vi, ti = _obj_face(parts, n_v, n_t)
                    if len(ti) != len(vi):
                        missing_vt = True
                    for k in range(1, len(vi) - 1):
                        faces.extend((vi[0], vi[k], vi[k + 1]))
                        if len(ti) == len(vi):
                            uv_faces.extend((ti[0], ti[k], ti[k + 1]))
                elif key == "mtllib":
                    mtllibs.append(line.strip()[len("mtllib") :].strip())
                elif key == "usemtl":
                    if first_mtl is None:
                        first_mtl = line.strip()[len("usemtl") :].strip()
                elif key not in _OBJ_IGNORED:
                    if not _is_keyword(key):
                        raise ValueError(f"{key[:20]!r} is not an OBJ statement")
                    unknown.setdefault(key, lineno)
            except (ValueError, IndexError, OverflowError) as exc:
                raise InputError(
                    f"{path}: line {lineno}: cannot parse {line.strip()[:60]!r} ({exc})"
                ) from exc
    if unknown:
        log.warning("%s: unknown OBJ statement(s) skipped: %s", path,
                    ", ".join(f"{k!r} (first on line {n})" for k, n in unknown.items()))
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
    tex = _mtl_texture(path, mtllibs, first_mtl)
    return V, F, uv, uvf, tex, vc


def _mtl_texture(path: Path, mtllibs: list[str], material: str | None) -> Path | None:
    """The texture of ``material`` (else the first one) in the existing ``mtllibs``."""
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


def _fmt_rows(arr: np.ndarray, prefix: str, fmt: str, row: str | None = None) -> str:
    """``arr (r, c)`` as ``r`` text lines ``prefix v1 ... vc`` (or the given ``row`` format)."""
    if arr.shape[0] == 0:
        return ""
    if row is None:
        row = prefix + " " + " ".join([fmt] * arr.shape[1]) + "\n"
    return (row * arr.shape[0]) % tuple(arr.ravel().tolist())


def write_obj(path: Path, V: np.ndarray, F: np.ndarray, uv: np.ndarray | None,
              uv_faces: np.ndarray | None, tex_name: str | None,
              vc: np.ndarray | None) -> None:
    """Write checked arrays as OBJ (``%.17g``: float64 round-trips exactly), atomically.

    ``V (n, 3) float64``, ``F (m, 3) int64``; ``uv`` per vertex ``(n, 2)`` or per corner with
    ``uv_faces (m, 3)`` (``f v/vt``); with ``tex_name``, a ``<stem>.mtl`` beside it whose
    ``map_Kd`` names the texture; ``vc (n, 3) uint8`` as ``v x y z r g b`` in [0, 1].
    """
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
