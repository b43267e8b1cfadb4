"""THuman2.0 / 2.1 reader (Yu et al., CVPR 2021): textured scans with fitted SMPL-X.

Layout read (from the public release description)::

    <scans>/<id>/<id>.obj (+ material0.mtl, material0.jpeg)     the textured scan
    <smplx>/<id>/smplx_param.pkl                                 fitted SMPL-X parameters

``smplx_param.pkl`` holds arrays ``betas (1, 10)``, ``global_orient (1, 3)``,
``body_pose (1, 63)``, ``transl (1, 3)`` (SMPL-X's own translation), hand/face poses,
``scale (1,)`` and ``translation (3,)``. Convention (assumed from the public fitting and
rendering code): the scan is aligned with ``scale * (smplx(params) + transl) + translation``.
In this toolkit's convention (``vertices = scale * model(shape, pose) + transl``) that is
``scale = scale`` and ``transl = scale * transl + translation``; the importer does this
conversion. The pose keeps the 22 body joints (root + 21); hand and face poses are dropped.

THuman scans are whole clothed people, not separated garments: each scan is one sample
whose ``garment()`` and ``scan()`` both return the scan (category ``fullbody``); each scan
is its own subject and garment (no pose pairs).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from dressmeup.data.adapters.base import SampleCollection, as_array, clean_id, load_pickle, make_row
from dressmeup.data.dataset import GarmentMesh, Sample
from dressmeup.errors import InputError


def thuman_body(param: dict, source: str = "smplx_param.pkl"):
    """Convert a THuman SMPL-X parameter dict into :class:`~dressmeup.body.BodyParams`."""
    from dressmeup.body.params import BodyParams

    for k in ("betas", "global_orient", "body_pose"):
        if k not in param:
            raise InputError(f"{source}: missing field {k!r}")
    betas = as_array(param["betas"], "betas", source).reshape(-1)
    pose = np.concatenate([as_array(param["global_orient"], "global_orient", source).reshape(-1),
                           as_array(param["body_pose"], "body_pose", source).reshape(-1)])
    if pose.size % 3:
        raise InputError(f"{source}: pose size {pose.size} is not a multiple of 3")
    scale = float(as_array(param.get("scale", 1.0), "scale", source).reshape(-1)[0])
    inner = as_array(param.get("transl", np.zeros(3)), "transl", source).reshape(3)
    outer = as_array(param.get("translation", np.zeros(3)), "translation", source).reshape(3)
    return BodyParams(model="smplx", gender=str(param.get("gender", "neutral")), shape=betas,
                      pose=pose.reshape(-1, 3), transl=scale * inner + outer, scale=scale)


def read_thuman(scans: str | os.PathLike, smplx: str | os.PathLike | None = None,
                split: str = "test") -> SampleCollection:
    """Read THuman2.x scans (and their SMPL-X fits when ``smplx`` is given).

    Parameters
    ----------
    scans : folder of ``<id>/<id>.obj``.
    smplx : folder of ``<id>/smplx_param.pkl`` (optional).
    split : split given to every sample.
    """
    scans = Path(scans)
    objs = sorted(p for p in scans.glob("*/*.obj") if p.stem == p.parent.name)
    if not objs:
        raise FileNotFoundError(f"{scans}: no THuman scans (<id>/<id>.obj)")
    samples = []
    for obj in objs:
        sid = clean_id(obj.stem)
        pkl = Path(smplx) / obj.stem / "smplx_param.pkl" if smplx is not None else None
        row = make_row(sample_id=sid, subject_id=sid, garment_id=sid, pose_id="P1",
                       category="fullbody", garment_type="scan", split=split,
                       scan_path=str(obj), body_path=str(pkl) if pkl else None,
                       topology_shared=False)

        def g_loader(obj=obj):
            from dressmeup.io.mesh import load_mesh

            m = load_mesh(obj)
            return GarmentMesh(m.vertices, m.faces, m.uv, m.uv_faces, m.texture_path)

        def s_loader(obj=obj):
            from dressmeup.io.mesh import load_mesh

            m = load_mesh(obj)
            return m.vertices, m.faces

        def b_loader(pkl=pkl):
            if pkl is None or not pkl.is_file():
                return None
            return thuman_body(load_pickle(pkl), str(pkl))

        samples.append(Sample(row, None, {"garment": g_loader, "scan": s_loader,
                                          "body": b_loader}))
    return SampleCollection(samples, str(scans))
