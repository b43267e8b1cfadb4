"""4D-DRESS reader (Wang et al., CVPR 2024): per-frame scans with segmented garments.

Layout read (from the public dataset description)::

    <root>/<subject>/<Inner|Outer>/<Take>/
        basic_info.pkl                     {"gender", "outfit": {label: type}, "scan_frames"}
        Meshes_pkl/mesh-f<frame>.pkl       {"vertices", "faces", "colors", "uvs", ...}
        SMPL/mesh-f<frame>_smpl.pkl        {"global_orient", "body_pose", "transl", "betas"}
        Semantic/clothes/cloth-f<frame>.pkl  {label: {"vertices", "faces", ...}} per garment

Each (subject, outfit, take, garment label) is a garment; each frame is a pose. Garments
are cut from per-frame scans, so their topology changes between frames
(``topology_shared`` is false: ED is not defined, P2S/Chamfer are). Bodies are SMPL with
``scale = 1``. Every pickle goes through the restricted unpickler (numpy data only).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from dressmeup.data.adapters.base import SampleCollection, as_array, clean_id, load_pickle, make_row
from dressmeup.data.dataset import GarmentMesh, Sample
from dressmeup.errors import InputError

CATEGORY = {"upper": "topwear", "outer": "topwear", "lower": "bottomwear", "dress": "dress"}


def dress4d_body(param: dict, gender: str = "neutral", source: str = "smpl.pkl"):
    """Convert a 4D-DRESS SMPL parameter dict into :class:`~dressmeup.body.BodyParams`."""
    from dressmeup.body.params import BodyParams

    for k in ("global_orient", "body_pose", "betas"):
        if k not in param:
            raise InputError(f"{source}: missing field {k!r}")
    pose = np.concatenate([as_array(param["global_orient"], "global_orient", source).reshape(-1),
                           as_array(param["body_pose"], "body_pose", source).reshape(-1)])
    return BodyParams(model="smpl", gender=gender,
                      shape=as_array(param["betas"], "betas", source).reshape(-1),
                      pose=pose.reshape(-1, 3),
                      transl=as_array(param.get("transl", np.zeros(3)), "transl",
                                      source).reshape(3), scale=1.0)


def _frames(take: Path) -> list[str]:
    out = []
    for p in sorted((take / "Meshes_pkl").glob("mesh-f*.pkl")):
        m = re.match(r"mesh-f(\d+)\.pkl$", p.name)
        if m:
            out.append(m.group(1))
    return out


def read_4ddress(root: str | os.PathLike, frames: list[str] | None = None,
                 split: str = "test") -> SampleCollection:
    """Read 4D-DRESS takes into samples (one per garment label and frame).

    Parameters
    ----------
    root : dataset folder (``<subject>/<outfit>/<take>/``).
    frames : frame numbers (strings as in file names) to use; default all.
    split : split assigned to every sample.
    """
    root = Path(root)
    takes = sorted(p.parent for p in root.glob("*/*/*/basic_info.pkl"))
    if not takes:
        raise FileNotFoundError(f"{root}: no 4D-DRESS takes (<subject>/<outfit>/<take>/"
                                "basic_info.pkl)")
    samples = []
    for take in takes:
        info = load_pickle(take / "basic_info.pkl")
        gender = str(info.get("gender", "neutral"))
        outfit = info.get("outfit", {}) or {}
        subject = clean_id(take.parents[1].name)
        use = [f for f in _frames(take) if frames is None or f in frames]
        for label in sorted(outfit):
            gtype = str(outfit[label])
            gid = clean_id(f"{take.parents[1].name}_{take.parent.name}_{take.name}_{label}")
            for f in use:
                cloth = take / "Semantic" / "clothes" / f"cloth-f{f}.pkl"
                smpl = take / "SMPL" / f"mesh-f{f}_smpl.pkl"
                mesh = take / "Meshes_pkl" / f"mesh-f{f}.pkl"
                row = make_row(sample_id=f"{gid}-F{f}", subject_id=subject, garment_id=gid,
                               pose_id=f"F{f}", category=CATEGORY.get(label, "other"),
                               garment_type=gtype, split=split, garment_path=str(cloth),
                               scan_path=str(mesh), body_path=str(smpl), topology_shared=False)

                def g_loader(cloth=cloth, label=label):
                    d = load_pickle(cloth)
                    if label not in d:
                        raise InputError(f"{cloth}: no garment {label!r} (has {sorted(d)})")
                    g = d[label]
                    V = as_array(g["vertices"], "vertices", str(cloth))
                    F = np.asarray(g["faces"], np.int64)
                    uv = g.get("uvs")
                    return GarmentMesh(V, F, None if uv is None else np.asarray(uv, np.float64),
                                       None, None)

                def s_loader(mesh=mesh):
                    d = load_pickle(mesh)
                    return (as_array(d["vertices"], "vertices", str(mesh)),
                            np.asarray(d["faces"], np.int64))

                def b_loader(smpl=smpl, gender=gender):
                    return dress4d_body(load_pickle(smpl), gender, str(smpl)) if smpl.is_file() \
                        else None

                samples.append(Sample(row, None, {"garment": g_loader, "scan": s_loader,
                                                  "body": b_loader}))
    return SampleCollection(samples, str(root))
