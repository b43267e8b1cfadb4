"""THuman2.0 / 2.1 reader (Yu et al., CVPR 2021): textured scans with fitted SMPL-X.

Layout read (the release README, ytrock/THuman2.0-Dataset)::

    <scans>/<id>/<id>.obj (+ material0.mtl, material0.jpeg)     the textured scan
    <smplx>/<id>/smplx_param.pkl                                 fitted SMPL-X parameters

Two alignment conventions exist, chosen by ``convention`` (``auto`` picks by the keys):

- ``icon`` (THuman2.0 as ICON reads it, YuliangXiu/ICON ``lib/dataset/mesh_util.py``
  ``load_fit_body``): ``scan = smplx(betas, global_orient, body_pose, ...) * scale +
  translation``. The model is built with ``create_transl=False``, so a ``transl`` key is
  never used. In this toolkit's convention (``vertices = scale * model + transl``) that is
  ``scale = scale`` and ``transl = translation``. ``auto`` picks it when ``scale`` and
  ``translation`` are present.
- ``transl`` (fits that carry only SMPL-X's own ``transl``, as some THuman2.1 loaders read
  them): ``scan = smplx(...) + transl``, ``scale = 1``. ``auto`` picks it when ``transl`` is
  present without ``scale``/``translation``.

Gender: ICON fits and reads THuman2.0 with the **male** SMPL-X model (``model_init_params``
``gender='male'``, also passed as ``smpl_gender='male'`` in ``PIFuDataset``); that is the
default here. Pass ``gender=`` for fits made otherwise. The pose keeps the 22 body joints
(root + 21); hand (12 PCA components in ICON) and face poses are dropped.

THuman scans are whole clothed people, not separated garments: each scan is one sample
whose ``garment()`` and ``scan()`` both return the scan (category ``fullbody``); each scan
is its own subject and garment (no pose pairs).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.data.adapters.base import (
    ReadReport,
    SampleCollection,
    as_array,
    clean_id,
    load_pickle,
    make_row,
)
from dressmeup.data.dataset import GarmentMesh, Sample
from dressmeup.errors import InputError
from dressmeup.io.mesh import load_mesh

CONVENTIONS = ("auto", "icon", "transl")


def thuman_convention(param: dict, source: str = "smplx_param.pkl") -> str:
    """``icon`` when the fit has ``scale`` and ``translation``, else ``transl`` when it has
    ``transl``; raises :class:`InputError` when it has neither."""
    if "scale" in param and "translation" in param:
        return "icon"
    if "transl" in param:
        return "transl"
    raise InputError(f"{source}: neither 'scale'+'translation' (THuman2.0/ICON) nor 'transl' "
                     "(THuman2.1): cannot place the body on the scan")


def thuman_body(param: dict, source: str = "smplx_param.pkl", gender: str = "male",
                convention: str = "auto"):
    """Convert a THuman SMPL-X parameter dict into :class:`~dressmeup.body.BodyParams`.

    Parameters
    ----------
    param : the fit's arrays (``betas (1, 10)``, ``global_orient (1, 3)``, ``body_pose
        (1, 63)``, and ``scale``/``translation`` or ``transl``).
    gender : SMPL-X gender the fit was made with (ICON's THuman2.0 fits: ``male``).
    convention : ``auto``, ``icon`` or ``transl`` (see the module docstring).
    """

    if convention not in CONVENTIONS:
        raise InputError(f"convention: expected one of {CONVENTIONS}, got {convention!r}")
    for k in ("betas", "global_orient", "body_pose"):
        if k not in param:
            raise InputError(f"{source}: missing field {k!r}")
    betas = as_array(param["betas"], "betas", source).reshape(-1)
    pose = np.concatenate([as_array(param["global_orient"], "global_orient", source).reshape(-1),
                           as_array(param["body_pose"], "body_pose", source).reshape(-1)])
    if pose.size % 3:
        raise InputError(f"{source}: pose size {pose.size} is not a multiple of 3")
    conv = thuman_convention(param, source) if convention == "auto" else convention
    if conv == "icon":
        for k in ("scale", "translation"):
            if k not in param:
                raise InputError(f"{source}: convention 'icon' needs field {k!r}")
        scale = float(as_array(param["scale"], "scale", source).reshape(-1)[0])
        transl = as_array(param["translation"], "translation", source).reshape(3)
    else:
        if "transl" not in param:
            raise InputError(f"{source}: convention 'transl' needs field 'transl'")
        scale = 1.0
        transl = as_array(param["transl"], "transl", source).reshape(3)
    return BodyParams(model="smplx", gender=gender, shape=betas, pose=pose.reshape(-1, 3),
                      transl=transl, scale=scale)


def read_thuman(scans: str | os.PathLike, smplx: str | os.PathLike | None = None,
                split: str = "test", gender: str = "male", convention: str = "auto"
                ) -> SampleCollection:
    """Read THuman2.x scans (and their SMPL-X fits when ``smplx`` is given).

    Parameters
    ----------
    scans : folder of ``<id>/<id>.obj``.
    smplx : folder of ``<id>/smplx_param.pkl`` (optional).
    split : split given to every sample.
    gender : SMPL-X gender of the fits (default ``male``, ICON's THuman2.0 convention).
    convention : ``auto``, ``icon`` or ``transl``: how the fit is placed on the scan.
    """
    scans = Path(scans)
    objs = sorted(p for p in scans.glob("*/*.obj") if p.stem == p.parent.name)
    if not objs:
        raise FileNotFoundError(f"{scans}: no THuman scans (<id>/<id>.obj)")
    if convention not in CONVENTIONS:
        raise InputError(f"convention: expected one of {CONVENTIONS}, got {convention!r}")
    report = ReadReport("thuman", str(scans))
    report.note(f"SMPL-X gender {gender!r} for every fit"
                + (" (ICON's THuman2.0 convention)" if gender == "male" else ""))
    samples = []
    for obj in objs:
        sid = clean_id(obj.stem)
        pkl = Path(smplx) / obj.stem / "smplx_param.pkl" if smplx is not None else None
        if pkl is not None and not pkl.is_file():
            report.note(f"{obj.stem}: no smplx_param.pkl, the sample has no body")
        row = make_row(sample_id=sid, subject_id=sid, garment_id=sid, pose_id="P1",
                       category="fullbody", garment_type="scan", split=split,
                       scan_path=str(obj), body_path=str(pkl) if pkl else None,
                       topology_shared=False)

        def g_loader(obj=obj):
            m = load_mesh(obj)
            return GarmentMesh(m.vertices, m.faces, m.uv, m.uv_faces, m.texture_path)

        def s_loader(obj=obj):
            m = load_mesh(obj)
            return m.vertices, m.faces

        def b_loader(pkl=pkl):
            if pkl is None or not pkl.is_file():
                return None
            return thuman_body(load_pickle(pkl), str(pkl), gender=gender,
                               convention=convention)

        samples.append(Sample(row, None, {"garment": g_loader, "scan": s_loader,
                                          "body": b_loader}))
    return SampleCollection(samples, str(scans), report)
