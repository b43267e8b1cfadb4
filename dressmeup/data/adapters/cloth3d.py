"""CLOTH3D reader (Bertiche et al., ECCV 2020 workshops).

Layout read (from the public dataset description and starter kit)::

    <root>/<sequence>/info.mat          MATLAB struct: gender, shape (10,), poses (72, T),
                                        trans (3, T), zrot, outfit (garment -> {type, ...})
    <root>/<sequence>/<Garment>.obj     garment topology (+ UVs), e.g. Top.obj, Trousers.obj
    <root>/<sequence>/<Garment>.pc16    per-frame vertices, point cache (float16), or .pc2
                                        (float32)

Point cache (PC2): a 32-byte header (``b"POINTCACHE2\\0"``, int32 version, int32 number of
points, float32 start frame, float32 sample rate, int32 number of samples) followed by
``samples * points * 3`` floats. ``.pc16`` is the same with float16 values.

One sequence is one subject; each garment of its outfit is one garment; the chosen frames
are its poses (topology shared). The body is SMPL: ``pose = poses[:, t]`` (24 joints) with
the sequence's ``zrot`` composed into the root orientation (assumed: a rotation about the
vertical axis of the data), ``transl = trans[:, t]``, ``scale = 1``.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.data.adapters.base import SampleCollection, clean_id, make_row
from dressmeup.data.dataset import GarmentMesh, Sample
from dressmeup.errors import InputError

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
    from dressmeup.io.atomic import atomic_write_bytes

    frames = np.asarray(frames)
    head = PC2_MAGIC + struct.pack("<iiffi", 1, frames.shape[1], 0.0, 1.0, frames.shape[0])
    atomic_write_bytes(path, head + frames.astype(np.float16 if float16 else "<f4").tobytes())


def _mat_to_dict(obj: Any) -> Any:
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
    import scipy.io

    try:
        raw = scipy.io.loadmat(path, struct_as_record=False, squeeze_me=True)
    except Exception as exc:  # noqa: BLE001 - scipy raises several types on bad files
        raise InputError(f"{path}: cannot read info.mat ({exc})") from exc
    return _mat_to_dict(raw)


def _body(info: dict, t: int, source: str):
    from scipy.spatial.transform import Rotation

    from dressmeup.body.params import BodyParams

    poses = np.asarray(info["poses"], np.float64)
    if poses.ndim == 1:
        poses = poses[:, None]
    trans = np.asarray(info.get("trans", np.zeros((3, poses.shape[1]))), np.float64)
    if trans.ndim == 1:
        trans = trans[:, None]
    if poses.shape[0] != 72:
        raise InputError(f"{source}: poses has shape {poses.shape}, expected (72, frames)")
    pose = poses[:, t].reshape(24, 3).copy()
    zrot = float(info.get("zrot", 0.0))
    if zrot:
        root = Rotation.from_rotvec([0, 0, zrot]) * Rotation.from_rotvec(pose[0])
        pose[0] = root.as_rotvec()
    g = info.get("gender", 0)
    gender = g if isinstance(g, str) else ("male" if int(g) == 1 else "female")
    return BodyParams(model="smpl", gender=gender, shape=np.asarray(info["shape"], np.float64),
                      pose=pose, transl=trans[:, t], scale=1.0)


def read_cloth3d(root: str | os.PathLike, frames: list[int] | None = None, stride: int = 10,
                 split: str = "test") -> SampleCollection:
    """Read CLOTH3D sequences into samples (one per garment and chosen frame).

    Parameters
    ----------
    root : folder holding sequence folders (each with ``info.mat``).
    frames : frame indices to use as poses (default every ``stride``-th frame).
    stride : frame step when ``frames`` is None.
    split : split assigned to every sample (CLOTH3D ships its own train/val/test folders:
        read each with its name).

    Returns
    -------
    SampleCollection of :class:`Sample` with lazy ``garment()``, ``body()``; no scan.
    """
    root = Path(root)
    seqs = sorted(p.parent for p in root.glob("*/info.mat"))
    if not seqs:
        raise FileNotFoundError(f"{root}: no CLOTH3D sequence folders (<seq>/info.mat)")
    samples = []
    for seq in seqs:
        info = load_info(seq / "info.mat")
        outfit = info.get("outfit", {}) or {}
        n_frames = np.atleast_2d(np.asarray(info["poses"]).T).shape[0] if \
            np.asarray(info["poses"]).ndim == 2 else 1
        use = [f for f in (frames if frames is not None else range(0, n_frames, stride))
               if 0 <= f < n_frames]
        subject = clean_id(seq.name)
        for gname in sorted(outfit) if isinstance(outfit, dict) else []:
            obj = seq / f"{gname}.obj"
            pc = next((seq / f"{gname}{ext}" for ext in (".pc16", ".pc2")
                       if (seq / f"{gname}{ext}").is_file()), None)
            if not obj.is_file() or pc is None:
                continue
            gtype = str((outfit[gname] or {}).get("type", gname)) if isinstance(
                outfit[gname], dict) else gname
            cat = CATEGORY.get(gname.lower(), CATEGORY.get(gtype.lower(), "other"))
            gid = clean_id(f"{seq.name}_{gname}")
            for t in use:
                row = make_row(sample_id=f"{gid}-F{t:04d}", subject_id=subject, garment_id=gid,
                               pose_id=f"F{t:04d}", category=cat,
                               garment_type=gname.lower(), split=split,
                               garment_path=str(obj), frame=t, topology_shared=True)

                def g_loader(obj=obj, pc=pc, t=t):
                    from dressmeup.io.mesh import load_mesh

                    m = load_mesh(obj)
                    cache = read_pc2(pc)
                    if cache.shape[1] != len(m.vertices):
                        raise InputError(f"{pc}: {cache.shape[1]} points but {obj.name} has "
                                         f"{len(m.vertices)} vertices")
                    return GarmentMesh(cache[t], m.faces, m.uv, m.uv_faces, m.texture_path)

                samples.append(Sample(row, None, {
                    "garment": g_loader,
                    "body": lambda info=info, t=t, src=str(seq): _body(info, t, src),
                    "scan": lambda: None}))
    return SampleCollection(samples, str(root))
