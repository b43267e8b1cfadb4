"""4D-DRESS reader (Wang et al., CVPR 2024): per-frame scans with segmented garments.

Layout read, as the official repository (eth-ait/4d-dress, ``dataset/README.md``) gives it::

    <root>/<subject>/<Inner|Outer>/<Take>/
        basic_info.pkl                       {"scan_frames", "rotation", "offset", ...}
        Meshes_pkl/mesh-f<frame>.pkl         {"vertices", "faces", "colors"?, "normals", "uvs"}
        Meshes_pkl/atlas-f<frame>.pkl        (1024, 1024, 3) uint8 texture, stored bottom row
                                             first (the official code flips it top to bottom)
        SMPL/mesh-f<frame>_smpl.pkl          {"global_orient" (3,), "body_pose" (69,),
                                              "transl" (3,), "betas" (10,)}
        Semantic/labels/label-f<frame>.pkl   {"scan_labels": (n_vertices,)} label index per
                                             scan vertex: skin 0, hair 1, shoe 2, upper 3,
                                             lower 4, outer 5 (``dataset/utility.py``)
        Semantic/clothes/cloth-f<frame>.pkl  optional, made by the official ``postprocess.py``:
                                             {label: {"vertices", "faces", "colors", "uvs"}}
                                             for the labels present in that frame

Conventions (each from the official code; docs/dataset-format.md names the files):

- A garment is one physical garment: one per (subject, outfit, label) across all takes, so a
  split by garment never puts the same garment in two splits and pose pairs cross takes.
- Garments come from ``Semantic/clothes`` when present, else they are cut from the scan by the
  per-vertex labels the same way (faces whose three vertices carry the label). Skin, hair and
  shoes are not garments. A frame where a garment's label is absent has no sample for it.
- There is no dress label: Graphonomy's *dress* class is grouped into ``upper``
  (``4dhumanparsing/lib/utility/parser.py``); the four dress outfits are the ``dress`` entries
  of the official cloth-simulation benchmark (``dataset/benchmarks.py``), so their ``upper``
  garment gets category ``dress``.
- In Outer outfits the ``upper`` surface is the inner layer covered by the ``outer`` garment
  (the official viewer skips it): it is skipped here too, with a line in the report.
- Gender is not in ``basic_info.pkl``; it comes from the official benchmark list (shipped in
  ``dress4d_meta.json``), unless given.
- Colour: a mesh without ``colors`` takes its texture from ``atlas-f*.pkl``, flipped top to
  bottom as the official viewer does, with the per-vertex ``uvs``.
- Everything stays in the capture frame (``basic_info['rotation']`` is only a viewing
  rotation in the official viewer; scans, garments and SMPL fits share the raw frame).
Every pickle goes through the restricted unpickler (numpy data only).
"""

from __future__ import annotations

import functools
import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.data.adapters.base import (
    ReadReport,
    SampleCollection,
    as_indices,
    as_vector,
    clean_id,
    load_pickle,
    make_row,
    mesh_fields,
    require_fields,
)
from dressmeup.data.dataset import GarmentMesh, Sample
from dressmeup.errors import InputError

META_PATH = Path(__file__).with_name("dress4d_meta.json")
GARMENT_LABELS = ("upper", "lower", "outer")
CATEGORY = {"upper": "topwear", "outer": "topwear", "lower": "bottomwear"}


@functools.lru_cache(maxsize=1)
def dress4d_meta() -> dict[str, Any]:
    """The shipped facts about the release: label order, gender per subject, dress outfits."""
    return json.loads(META_PATH.read_text())


def dress4d_body(param: dict, gender: str = "neutral", source: str = "smpl.pkl"):
    """Convert a 4D-DRESS SMPL parameter dict into :class:`~dressmeup.body.BodyParams`
    (``pose = [global_orient, body_pose]`` as 24 x 3 axis-angles, ``transl``, ``scale = 1``)."""

    require_fields(param, ("global_orient", "body_pose", "betas"), source)
    pose = np.concatenate([as_vector(param["global_orient"], "global_orient", source),
                           as_vector(param["body_pose"], "body_pose", source)])
    if pose.size % 3:
        raise InputError(f"{source}: pose size {pose.size} is not a multiple of 3")
    return BodyParams(model="smpl", gender=gender,
                      shape=as_vector(param["betas"], "betas", source),
                      pose=pose.reshape(-1, 3),
                      transl=as_vector(param.get("transl", np.zeros(3)), "transl", source, 3),
                      scale=1.0)


def _frame_name(frame: Any) -> str:
    """Frames as the file names spell them (``00011``); ints are zero-padded to 5 digits."""
    if isinstance(frame, (int, np.integer)):
        return f"{int(frame):05d}"
    return str(frame)


def _scan_frames(take: Path, info: dict, report: ReadReport) -> list[str]:
    frames = info.get("scan_frames") if isinstance(info, dict) else None
    if frames is None:
        found = []
        for p in sorted((take / "Meshes_pkl").glob("mesh-f*.pkl")):
            m = re.match(r"mesh-f(\d+)\.pkl$", p.name)
            if m:
                found.append(m.group(1))
        report.note("basic_info.pkl without 'scan_frames': frames taken from Meshes_pkl/")
        return found
    return [_frame_name(f) for f in list(np.asarray(frames).ravel())]


def _labels_in_frame(take: Path, frame: str) -> tuple[set[str] | None, str]:
    """The garment labels present in a frame and where they come from (``clothes`` or
    ``labels``); None when the frame has neither file."""
    cloth = take / "Semantic" / "clothes" / f"cloth-f{frame}.pkl"
    if cloth.is_file():
        d = load_pickle(cloth)
        if not isinstance(d, dict):
            raise InputError(f"{cloth}: expected a dict of garment meshes, got {type(d).__name__}")
        return {k for k, v in d.items() if isinstance(v, dict) and len(v.get("faces", [])) > 0}, \
            "clothes"
    lab = take / "Semantic" / "labels" / f"label-f{frame}.pkl"
    if lab.is_file():
        names = dress4d_meta()["surface_labels"]
        ids = np.unique(_scan_labels(lab))
        return {names[i] for i in ids if 0 <= i < len(names)}, "labels"
    return None, ""


def _scan_labels(path: Path) -> np.ndarray:
    d = load_pickle(path)
    if not isinstance(d, dict) or "scan_labels" not in d:
        raise InputError(f"{path}: expected a dict with 'scan_labels' (one label per scan vertex)")
    return as_indices(d["scan_labels"], "scan_labels", str(path)).ravel()


def cut_label_mesh(vertices: np.ndarray, faces: np.ndarray, labels: np.ndarray, label: int
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cut the part of a scan carrying one label, as the official ``extract_label_meshes``:
    the vertices with the label and the faces whose three vertices all carry it.

    Parameters
    ----------
    vertices : (n, 3) float64; faces : (m, 3) int64; labels : (n,) int64 per vertex.
    label : label index.

    Returns
    -------
    vertices (k, 3), faces (f, 3) re-indexed, and the kept vertex ids (k,) into the scan.
    """
    keep = np.flatnonzero(labels == label)
    remap = np.full(len(vertices), -1, np.int64)
    remap[keep] = np.arange(len(keep))
    fmask = np.all(labels[faces] == label, axis=1)
    return vertices[keep], remap[faces[fmask]], keep


def _atlas(mesh_pkl: Path) -> np.ndarray | None:
    """The frame's texture atlas as an image with row 0 on top (flipped, as the official
    viewer and parser do before pairing it with the ``uvs``), or None when absent."""
    p = mesh_pkl.with_name(mesh_pkl.name.replace("mesh-f", "atlas-f"))
    if not p.is_file():
        return None
    img = np.asarray(load_pickle(p))
    if img.ndim != 3 or img.shape[2] < 3:
        raise InputError(f"{p}: expected an (h, w, 3) texture atlas, got shape {img.shape}")
    return np.ascontiguousarray(np.flipud(img[:, :, :3])).astype(np.uint8)


def _load_garment(take: Path, frame: str, label: str) -> GarmentMesh:
    mesh_pkl = take / "Meshes_pkl" / f"mesh-f{frame}.pkl"
    cloth = take / "Semantic" / "clothes" / f"cloth-f{frame}.pkl"
    if cloth.is_file():
        d = load_pickle(cloth)
        if not isinstance(d, dict) or label not in d:
            found = sorted(map(str, d)) if isinstance(d, dict) else type(d).__name__
            raise InputError(f"{cloth}: no garment {label!r} (has {found})")
        g = d[label]
        V, F = mesh_fields(g, f"{cloth} [{label!r}]")
        uv = g.get("uvs")
        has_colors = g.get("colors") is not None
    else:
        names = dress4d_meta()["surface_labels"]
        scan = load_pickle(mesh_pkl)
        labels = _scan_labels(take / "Semantic" / "labels" / f"label-f{frame}.pkl")
        SV, SF = mesh_fields(scan, str(mesh_pkl))
        if len(labels) != len(SV):
            raise InputError(f"{take}/Semantic/labels/label-f{frame}.pkl: {len(labels)} labels "
                             f"for {len(SV)} scan vertices")
        V, F, keep = cut_label_mesh(SV, SF, labels, names.index(label))
        uv = None if scan.get("uvs") is None else np.asarray(scan["uvs"])[keep]
        has_colors = scan.get("colors") is not None
    uv = None if uv is None else np.asarray(uv, np.float64).reshape(-1, 2)
    if uv is not None and len(uv) != len(V):
        uv = None  # per-corner or inconsistent: keep the geometry, drop the UVs
    image = None if has_colors or uv is None else _atlas(mesh_pkl)
    return GarmentMesh(V, F, uv, None, None, image)


def read_4ddress(root: str | os.PathLike, frames: list[str] | None = None,
                 split: str = "test", gender: str | None = None,
                 dress_outfits: list[tuple[str, str]] | None = None) -> SampleCollection:
    """Read 4D-DRESS takes into samples (one per garment and frame).

    Parameters
    ----------
    root : dataset folder (``<subject>/<Inner|Outer>/<Take>/``).
    frames : frame names (as in file names, e.g. ``"00011"``) to keep; default all.
    split : split given to every sample (a later split by garment may replace it).
    gender : SMPL gender for every subject; default the official per-subject gender.
    dress_outfits : ``(subject, outfit)`` pairs whose ``upper`` garment is a dress; default the
        official list.

    Returns
    -------
    SampleCollection with a :class:`ReadReport` (counts; what was skipped and why).

    Raises
    ------
    FileNotFoundError : no take folders under ``root``.
    """
    root = Path(root)
    takes = sorted(p.parent for p in root.glob("*/*/*/basic_info.pkl"))
    if not takes:
        raise FileNotFoundError(f"{root}: no 4D-DRESS takes (<subject>/<Inner|Outer>/<Take>/"
                                "basic_info.pkl)")
    meta = dress4d_meta()
    dresses = {tuple(x) for x in (dress_outfits if dress_outfits is not None
                                  else meta["dress_outfits"])}
    report = ReadReport("4ddress", str(root))
    keep_frames = None if frames is None else {_frame_name(f) for f in frames}
    samples = []
    for take in takes:
        samples += _take_samples(take, gender, meta, dresses, keep_frames, split, report)
    return SampleCollection(samples, str(root), report)


def _take_samples(take: Path, gender: str | None, meta: dict, dresses: set,
                  keep_frames: set | None, split: str, report: ReadReport) -> list[Sample]:
    """The samples of one take: one per garment label present in each kept frame (the inner
    ``upper`` of an Outer outfit skipped), files loaded lazily; skips go to ``report``."""
    samples = []
    subject, outfit = take.parents[1].name, take.parent.name
    tag = f"{subject}/{outfit}/{take.name}"
    info = load_pickle(take / "basic_info.pkl")
    if not isinstance(info, dict):
        raise InputError(f"{take / 'basic_info.pkl'}: expected a dict (scan_frames, "
                         f"rotation, offset), got {type(info).__name__}")
    g = gender or (info.get("gender") if isinstance(info, dict) else None) or \
        meta["gender"].get(subject)
    if g is None:
        g = "neutral"
        report.note(f"subject {subject}: gender unknown (not in the official list): "
                    "neutral SMPL assumed; pass gender= to choose")
    for f in _scan_frames(take, info, report):
        if keep_frames is not None and f not in keep_frames:
            continue
        if not (take / "Meshes_pkl" / f"mesh-f{f}.pkl").is_file():
            report.skip(f"{tag}/f{f}", "scan mesh-f*.pkl missing")
            continue
        present, _src = _labels_in_frame(take, f)
        if present is None:
            report.skip(f"{tag}/f{f}", "no Semantic/clothes nor Semantic/labels file")
            continue
        for label in GARMENT_LABELS:
            if label not in present:
                continue
            if outfit == "Outer" and label == "upper":
                report.skip(f"{tag}/f{f}/upper", "inner layer of an Outer outfit (covered "
                            "by the outer garment; the official viewer skips it)")
                continue
            is_dress = label == "upper" and (subject, outfit) in dresses
            gid = clean_id(f"{subject}_{outfit}_{label}")
            pose_id = clean_id(f"{take.name}-F{f}")
            smpl = take / "SMPL" / f"mesh-f{f}_smpl.pkl"
            mesh = take / "Meshes_pkl" / f"mesh-f{f}.pkl"
            row = make_row(sample_id=f"{gid}-{pose_id}", subject_id=clean_id(subject),
                           garment_id=gid, pose_id=pose_id,
                           category="dress" if is_dress else CATEGORY[label],
                           garment_type="dress" if is_dress else label, split=split,
                           scan_path=str(mesh), body_path=str(smpl), take=take.name,
                           frame=f, outfit=outfit, topology_shared=False)

            def b_loader(smpl=smpl, g=g):
                return dress4d_body(load_pickle(smpl), g, str(smpl)) if smpl.is_file() \
                    else None

            def s_loader(mesh=mesh):
                return mesh_fields(load_pickle(mesh), str(mesh))

            samples.append(Sample(row, None, {
                "garment": functools.partial(_load_garment, take, f, label),
                "scan": s_loader, "body": b_loader}))
    return samples
