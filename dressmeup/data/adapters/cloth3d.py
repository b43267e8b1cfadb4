"""CLOTH3D reader (Bertiche et al., ECCV 2020 workshops).

Layout read (the dataset's starter kit ``DataReader`` in ``read.py`` and ``IO.py``, also used
by hbertiche/DeePSD)::

    <root>/<sample>/info.mat          MATLAB struct: gender (0 female / 1 male), shape (10,),
                                      poses (72, T) or (72,), trans (3, T) or (3,), zrot,
                                      outfit {garment: {type, fabric, texture: {type, data}}}
    <root>/<sample>/<Garment>.obj     garment topology and UVs (the rest garment), e.g. Top.obj
    <root>/<sample>/<Garment>.pc16    per-frame vertices, point cache (float16), or .pc2
    <root>/<sample>/<Garment>.png     the garment's texture when texture.type is not 'color'

Point cache (PC2): a 32-byte header (``b"POINTCACHE2\\0"``, int32 version, int32 number of
points, float32 start frame, float32 sample rate, int32 number of samples) followed by
``samples * points * 3`` floats. ``.pc16`` is the same with float16 values.

Frame convention (starter kit ``read_garment_vertices`` / ``read_human``): cached garment
vertices are relative to the SMPL root joint; absolute garment vertices are
``zRot @ (V + trans[:, t])``; the absolute body is ``zRot @ (SMPL(pose, shape) - J0(shape) +
trans[:, t])`` with ``J0`` the rest root joint of the shaped body and ``zRot`` the rotation by
``zrot`` about the data's z axis, applied about the origin to garment and body alike. In this
toolkit's convention (``vertices = model(shape, pose) + transl``) the body is the pose with
``zRot`` composed into the root orientation and ``transl = zRot @ trans - J0(shape)``;
computing ``J0`` needs the user's SMPL model file (only when ``body()`` is called).

One sample folder is one subject; each garment of its outfit is one garment; the chosen frames
are its poses (topology shared).
"""

from __future__ import annotations

import os
import struct
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from dressmeup.body import get_body_model
from dressmeup.body.params import BodyParams
from dressmeup.data.adapters.base import ReadReport, SampleCollection, clean_id, make_row
from dressmeup.data.dataset import GarmentMesh, Sample
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.io.mesh import load_mesh

CATEGORY = {"top": "topwear", "tshirt": "topwear", "t-shirt": "topwear", "shirt": "topwear",
            "trousers": "bottomwear", "skirt": "bottomwear", "shorts": "bottomwear",
            "dress": "dress", "jumpsuit": "dress"}
PC2_MAGIC = b"POINTCACHE2\x00"


def read_pc2(path: str | os.PathLike, float16: bool | None = None) -> np.ndarray:
    """Read a point cache file.

    Parameters
    ----------
    path : ``.pc2`` (float32) or ``.pc16`` (float16) file.
    float16 : value type; default from the extension.

    Returns
    -------
    (samples, points, 3) float64 array.
    """
    path = Path(path)
    if float16 is None:
        float16 = path.suffix.lower() == ".pc16"
    data = path.read_bytes()
    if len(data) < 32 or data[:12] != PC2_MAGIC:
        raise InputError(f"{path}: not a point cache file (missing POINTCACHE2 header)")
    _version, n_points, _start, _rate, n_samples = struct.unpack("<iiffi", data[12:32])
    dt = np.float16 if float16 else np.float32
    need = 32 + n_samples * n_points * 3 * np.dtype(dt).itemsize
    if len(data) < need or n_points <= 0 or n_samples <= 0:
        raise InputError(f"{path}: point cache truncated or empty ({len(data)} bytes, "
                         f"header needs {need})")
    arr = np.frombuffer(data, dtype=dt, count=n_samples * n_points * 3, offset=32)
    return arr.reshape(n_samples, n_points, 3).astype(np.float64)


def write_pc2(path: str | os.PathLike, frames: np.ndarray, float16: bool = False) -> None:
    """Write ``frames (samples, points, 3)`` as a point cache (for tests and conversions)."""

    frames = np.asarray(frames)
    head = PC2_MAGIC + struct.pack("<iiffi", 1, frames.shape[1], 0.0, 1.0, frames.shape[0])
    atomic_write_bytes(path, head + frames.astype(np.float16 if float16 else "<f4").tobytes())


def _mat_to_dict(obj: Any) -> Any:
    # heavy: scipy.io
    from scipy.io.matlab import mat_struct

    if isinstance(obj, mat_struct):
        return {k: _mat_to_dict(getattr(obj, k)) for k in obj._fieldnames}
    if isinstance(obj, dict):
        return {k: _mat_to_dict(v) for k, v in obj.items() if not k.startswith("__")}
    if isinstance(obj, np.ndarray) and obj.dtype == object:
        return [_mat_to_dict(v) for v in obj.ravel()]
    return obj


def load_info(path: str | os.PathLike) -> dict[str, Any]:
    """Read a CLOTH3D ``info.mat`` into plain Python (dicts, arrays, strings)."""
    # heavy: scipy.io
    import scipy.io

    try:
        raw = scipy.io.loadmat(path, struct_as_record=False, squeeze_me=True)
    except Exception as exc:  # noqa: BLE001 - scipy raises several types on bad files
        raise InputError(f"{path}: cannot read info.mat ({exc})") from exc
    return _mat_to_dict(raw)


def z_rotation(zrot: float) -> np.ndarray:
    """(3, 3) rotation by ``zrot`` radians about the z axis (the starter kit's ``zRotMatrix``)."""
    c, sn = np.cos(zrot), np.sin(zrot)
    return np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])


def _frame_columns(info: dict, key: str, rows: int, source: str) -> np.ndarray:
    """``info[key]`` as a (rows, T) array (a single frame is stored as (rows,))."""
    a = np.asarray(info[key], np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.shape[0] != rows:
        raise InputError(f"{source}: {key} has shape {a.shape}, expected ({rows}, frames)")
    return a


def cloth3d_gender(info: dict) -> str:
    """``male`` when ``info['gender']`` is true/1, else ``female`` (starter kit
    ``read_smpl_params``: ``'m' if info['gender'] else 'f'``)."""
    g = info.get("gender", 0)
    if isinstance(g, str):
        return {"m": "male", "f": "female"}.get(g.lower(), g.lower())
    return "male" if bool(np.asarray(g).ravel()[0]) else "female"


def cloth3d_garment_vertices(cache_frame: np.ndarray, info: dict, t: int,
                             source: str = "info.mat") -> np.ndarray:
    """Absolute garment vertices ``zRot @ (V + trans[:, t])`` from root-relative cached ones.

    Parameters
    ----------
    cache_frame : (n, 3) vertices of frame ``t`` read from the point cache.
    info : the sample's ``info.mat``; t : frame index.
    """
    trans = _frame_columns(info, "trans", 3, source)
    tt = t if trans.shape[1] > 1 else 0
    R = z_rotation(float(np.asarray(info.get("zrot", 0.0)).ravel()[0]))
    return (np.asarray(cache_frame, np.float64) + trans[:, tt]) @ R.T


def cloth3d_body(info: dict, t: int, body_model=None, source: str = "info.mat",
                 model_path: str | os.PathLike | None = None):
    """The frame's SMPL body as :class:`~dressmeup.body.BodyParams` in this toolkit's
    convention (see the module docstring).

    Parameters
    ----------
    info : the sample's ``info.mat``; t : frame index.
    body_model : an SMPL :class:`~dressmeup.body.BodyModel` of the sample's gender (default:
        ``get_body_model("smpl", gender=..., model_path=model_path)``, the user's files).

    Raises
    ------
    MissingModelError : no SMPL model file (the message says where to put it).
    """
    poses = _frame_columns(info, "poses", 72, source)
    trans = _frame_columns(info, "trans", 3, source)
    pose = poses[:, t if poses.shape[1] > 1 else 0].reshape(24, 3).copy()
    R = z_rotation(float(np.asarray(info.get("zrot", 0.0)).ravel()[0]))
    pose[0] = (Rotation.from_matrix(R) * Rotation.from_rotvec(pose[0])).as_rotvec()
    gender = cloth3d_gender(info)
    shape = np.asarray(info["shape"], np.float64).ravel()
    if body_model is None:
        kw = {"gender": gender} if model_path is None else {"gender": gender,
                                                             "model_path": str(model_path)}
        body_model = get_body_model("smpl", **kw)
    # heavy: torch (~1.1 s to import)
    import torch

    with torch.no_grad():
        out = body_model.forward(torch.as_tensor(shape[None, :body_model.shape_dim]),
                                 torch.zeros((1, len(body_model.joint_names), 3),
                                             dtype=torch.float64))
    j0 = out.rest_joints[0, 0].detach().cpu().numpy().astype(np.float64)
    transl = R @ trans[:, t if trans.shape[1] > 1 else 0] - j0
    return BodyParams(model="smpl", gender=gender, shape=shape, pose=pose, transl=transl,
                      scale=1.0)


def cloth3d_texture(info: dict, garment: str, folder: Path) -> dict:
    """The garment's texture as the outfit entry gives it: ``{"kind": "color", "color":
    (3,) floats in [0, 1]}`` or ``{"kind": "image", "path": <folder>/<garment>.png}``
    (starter kit ``read_garment_vertex_colors``), or ``{"kind": None}``."""
    entry = (info.get("outfit", {}) or {}).get(garment, {}) or {}
    tex = entry.get("texture") if isinstance(entry, dict) else None
    if not isinstance(tex, dict):
        return {"kind": None}
    if str(tex.get("type", "")) == "color":
        return {"kind": "color",
                "color": [float(x) for x in np.asarray(tex.get("data"), np.float64).ravel()[:3]]}
    p = folder / f"{garment}.png"
    return {"kind": "image", "path": p if p.is_file() else None}


def read_cloth3d(root: str | os.PathLike, frames: list[int] | None = None, stride: int = 10,
                 split: str = "test", smpl_model_path: str | os.PathLike | None = None
                 ) -> SampleCollection:
    """Read CLOTH3D sequences into samples (one per garment and chosen frame).

    Parameters
    ----------
    root : folder holding sample folders (each with ``info.mat``).
    frames : frame indices to use as poses (default every ``stride``-th frame).
    stride : frame step when ``frames`` is None.
    split : split assigned to every sample (CLOTH3D ships its own train/val/test folders:
        read each with its name).
    smpl_model_path : SMPL model file or folder for ``body()`` (default: the toolkit's SMPL
        folder, see :func:`dressmeup.body.smpl.find_model_file`).

    Returns
    -------
    SampleCollection of :class:`Sample` with lazy ``garment()`` (absolute vertices, UVs, and
    the texture: image path, or the plain colour in the row's ``texture_color``), ``body()``;
    no scan; a :class:`ReadReport` as ``.report``.
    """
    root = Path(root)
    seqs = sorted(p.parent for p in root.glob("*/info.mat"))
    if not seqs:
        raise FileNotFoundError(f"{root}: no CLOTH3D sequence folders (<seq>/info.mat)")
    report = ReadReport("cloth3d", str(root))
    samples = []
    for seq in seqs:
        info = load_info(seq / "info.mat")
        outfit = info.get("outfit", {}) or {}
        if not isinstance(outfit, dict) or not outfit:
            report.skip(seq.name, "info.mat has no outfit")
            continue
        n_frames = _frame_columns(info, "poses", 72, str(seq / "info.mat")).shape[1]
        use = [f for f in (frames if frames is not None else range(0, n_frames, stride))
               if 0 <= f < n_frames]
        subject = clean_id(seq.name)
        for gname in sorted(outfit):
            obj = seq / f"{gname}.obj"
            pc = next((seq / f"{gname}{ext}" for ext in (".pc16", ".pc2")
                       if (seq / f"{gname}{ext}").is_file()), None)
            if not obj.is_file() or pc is None:
                report.skip(f"{seq.name}/{gname}", "garment .obj or .pc16/.pc2 missing")
                continue
            gtype = str((outfit[gname] or {}).get("type", gname)) if isinstance(
                outfit[gname], dict) else gname
            cat = CATEGORY.get(gname.lower(), CATEGORY.get(gtype.lower(), "other"))
            gid = clean_id(f"{seq.name}_{gname}")
            tex = cloth3d_texture(info, gname, seq)
            if tex["kind"] == "image" and tex["path"] is None:
                report.note(f"{seq.name}/{gname}: image texture announced but {gname}.png "
                            "is missing")
            for t in use:
                row = make_row(sample_id=f"{gid}-F{t:04d}", subject_id=subject, garment_id=gid,
                               pose_id=f"F{t:04d}", category=cat,
                               garment_type=gname.lower(), split=split,
                               garment_path=str(obj), frame=t, topology_shared=True,
                               gender=cloth3d_gender(info), texture_kind=tex["kind"],
                               texture_color=tex.get("color"))

                def g_loader(obj=obj, pc=pc, t=t, info=info, tex=tex):
                    m = load_mesh(obj)
                    cache = read_pc2(pc)
                    if cache.shape[1] != len(m.vertices):
                        raise InputError(f"{pc}: {cache.shape[1]} points but {obj.name} has "
                                         f"{len(m.vertices)} vertices")
                    V = cloth3d_garment_vertices(cache[t], info, t, str(obj.parent / "info.mat"))
                    return GarmentMesh(V, m.faces, m.uv, m.uv_faces, tex.get("path"))

                def b_loader(info=info, t=t, src=str(seq / "info.mat")):
                    return cloth3d_body(info, t, source=src, model_path=smpl_model_path)

                samples.append(Sample(row, None, {"garment": g_loader, "body": b_loader,
                                                  "scan": lambda: None}))
    return SampleCollection(samples, str(root), report)
