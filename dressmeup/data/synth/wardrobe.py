"""Generator 2.0.0: each garment is one pattern worn by several bodies (the v3 retargeting data).

A garment (one rest mesh: vertices, faces, UVs) is made around its *design* body, then
**fitted** to every subject of the dataset and draped in every pose:

1. **Subjects** come from a fixed table of phenotypes that spreads the body model's range
   (:data:`SUBJECTS`: gender, age, muscle, weight, height at their extremes; adults only,
   since the model's lowest ages are children). Subject ``k`` is ``SUBJECTS[k]``.
2. **Poses** are the same pose arrays for every subject: library poses
   (:mod:`dressmeup.data.synth.poses`) turned into axis-angle once, on the model's
   default body, without jitter. ``P1`` of one subject is exactly ``P1`` of another.
3. **Garments**: per category (topwear, bottomwear, dress), ``test + val + train``
   garments cycling through the category's types with parameters drawn per garment (seeded),
   so no two garments are alike. Garment ``k`` is designed on subject ``k mod subjects``.
4. **Fit**: each garment vertex keeps its closest point on the design body (face and
   barycentric coordinates) and its signed offset along the interpolated normal; on another
   body (same body topology) it is placed at the same surface point and offset, then
   relaxed in the rest pose with the garment's own rest edge lengths
   (:func:`dressmeup.data.synth.drape.drape`): a garment made for a slim body fitted to a heavy
   one stretches, one made for a heavy body stands off a slim one; a final projection keeps
   every vertex outside the body (it never sinks in).
5. **Drape per pose**: skinning weights transferred from the subject's rest body to the
   fitted garment, then a pose-continuation path (``pose_steps`` steps from the rest pose to
   the target pose; each step starts from the previous drape moved by the change of the
   skinned garment) so the cloth is carried over the thighs when sitting instead of being
   cut through by them; each step is a quasi-static relaxation with body collision and cloth
   self-collision.

Reproducibility: the solver runs in one torch thread and BLAS is held to one thread while
generating; body vertices and LBS matrices are rounded (1e-9 m, 1e-12) before use, and every
stored garment, body and scan vertex is rounded to 1e-6 m (one micrometre), so the float noise
of a different thread count or SIMD path does not reach the files that the manifest hashes
(see docs/synthetic-data.md, "Reproducibility").
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.data.synth.drape import DrapeSettings, drape
from dressmeup.data.synth.garments import BodyFrame, build_garment, sample_params
from dressmeup.data.synth.poses import pose_axis_angle, pose_names

log = logging.getLogger(__name__)

VERSION = "2.0.0"
CATEGORY_TYPES: dict[str, tuple[str, ...]] = {
    "topwear": ("t-shirt", "long-sleeve", "tank-top"),
    "bottomwear": ("skirt", "trousers", "shorts"),
    "dress": ("dress",),
}
#: Subject table: name and phenotype (gender, age, muscle, weight, height, proportions) in
#: [0, 1]; anny's gender 0 is male and 1 female, age 0.5 is about 25 years and 1.0 about 90
#: (lower ages are children, left out).
SUBJECTS: tuple[tuple[str, tuple[float, ...]], ...] = (
    ("slim-tall-woman", (1.0, 0.5, 0.3, 0.0, 1.0, 0.5)),
    ("heavy-short-older-man", (0.0, 0.9, 0.5, 1.0, 0.0, 0.5)),
    ("muscular-young-man", (0.0, 0.4, 1.0, 0.6, 0.7, 0.5)),
    ("older-heavy-woman", (0.9, 1.0, 0.0, 0.75, 0.3, 0.5)),
    ("average-person", (0.5, 0.5, 0.5, 0.5, 0.5, 0.5)),
    ("slim-short-man", (0.1, 0.45, 0.2, 0.1, 0.15, 0.5)),
)
DEFAULT_EDGE_LENGTH = {"anny": 0.02, "procedural": 0.025}
BODY_DECIMALS = 9  # body vertices, metres
TRANSFORM_DECIMALS = 12  # LBS matrices
STORE_DECIMALS = 6  # stored vertices, metres (1 micrometre)


def v3_drape_settings() -> DrapeSettings:
    """Drape settings of generator 2.0.0: 1.x's material, cloth self-collision on, and a
    3 mm final clearance (1 mm let 20 mm triangles of a garment stretched over a heavier body
    cut into its curved surface between their vertices)."""
    return DrapeSettings(self_stiffness=2.0e5, self_thickness=0.006, margin=0.006,
                         clearance=0.003)


@contextlib.contextmanager
def single_threaded():
    """Hold torch (and numpy's BLAS when threadpoolctl is installed) at one thread."""
    import torch

    try:  # optional: numpy's BLAS pool (its gemm results do not depend on it)
        from threadpoolctl import threadpool_limits
    except ImportError:
        threadpool_limits = None
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with threadpool_limits(limits=1) if threadpool_limits else contextlib.nullcontext():
            yield
    finally:
        torch.set_num_threads(before)


@dataclass
class Body:
    """One subject's rest body: skin vertices ``(n, 3)``, frame, and its phenotype."""

    sid: str
    shape: np.ndarray
    rest_V: np.ndarray
    frame: BodyFrame


def _q(a: np.ndarray, decimals: int) -> np.ndarray:
    return np.round(np.asarray(a, np.float64), decimals) + 0.0  # + 0.0: no negative zeros


def plan_v3(subjects: int, poses: int, garments_per_split: tuple[int, int, int], seed: int,
            categories: list[str] | None = None) -> dict[str, Any]:
    """Deterministic plan: subjects, pose names, garments (type, parameters, split, designer).

    Parameters
    ----------
    subjects : number of subjects (1 .. len(SUBJECTS)).
    poses : number of poses (1 .. library size), the same for every subject.
    garments_per_split : (train, val, test) garments per category.
    seed : random seed (pose choice, garment parameters, textures).
    categories : categories to make (default all of :data:`CATEGORY_TYPES`).
    """
    names = pose_names()
    if not 1 <= subjects <= len(SUBJECTS):
        raise ValueError(f"subjects: expected 1..{len(SUBJECTS)}, got {subjects!r}")
    if not 1 <= poses <= len(names):
        raise ValueError(f"poses: expected 1..{len(names)}, got {poses!r}")
    cats = list(categories or CATEGORY_TYPES)
    bad = [c for c in cats if c not in CATEGORY_TYPES]
    if bad:
        raise ValueError(f"categories: unknown {bad}; known {list(CATEGORY_TYPES)}")
    n_train, n_val, n_test = (int(x) for x in garments_per_split)
    if min(n_train, n_val, n_test) < 0 or n_train + n_val + n_test < 1:
        raise ValueError(f"garments_per_split: expected non-negative counts, got "
                         f"{garments_per_split!r}")
    rng = np.random.default_rng([seed, 2])
    pick = rng.permutation(len(names))[:poses]
    plan: dict[str, Any] = {
        "subjects": {f"S{i + 1:02d}": {"name": SUBJECTS[i][0], "shape": list(SUBJECTS[i][1])}
                     for i in range(subjects)},
        "poses": {f"P{k + 1}": names[i] for k, i in enumerate(pick)},
        "garments": {},
    }
    sids = list(plan["subjects"])
    splits = ["test"] * n_test + ["val"] * n_val + ["train"] * n_train
    g = 0
    for ci, cat in enumerate(cats):
        types = CATEGORY_TYPES[cat]
        for k, split in enumerate(splits):
            g += 1
            gtype = types[k % len(types)]
            params = {kk: (round(v, 6) if isinstance(v, float) else v) for kk, v in
                      sample_params(gtype, np.random.default_rng([seed, 3, ci, k])).items()}
            plan["garments"][f"G{g:02d}"] = {"type": gtype, "category": cat, "split": split,
                                             "design_subject": sids[(g - 1) % len(sids)],
                                             "params": params}
    return plan


def transfer_to_body(points: np.ndarray, from_V: np.ndarray, to_V: np.ndarray,
                     faces: np.ndarray) -> np.ndarray:
    """Carry points from one body to another of the same topology (the fit's start).

    Each point keeps its closest surface point on ``from_V`` (face, barycentric
    coordinates) and its signed offset along the interpolated vertex normal there.

    Parameters
    ----------
    points : (p, 3) float64 points near the ``from_V`` body.
    from_V, to_V : (n, 3) float64 vertices of the two bodies; faces : (m, 3) int64 shared.

    Returns
    -------
    (p, 3) float64 points near ``to_V``.
    """
    from dressmeup.geometry.mesh import vertex_normals
    from dressmeup.geometry.proximity import closest_points

    F = np.asarray(faces, np.int64)
    _, p, fid = closest_points(from_V, F, points)
    tri = from_V[F[fid]]
    bary = _barycentric(p, tri)
    n0 = np.einsum("pk,pkd->pd", bary, vertex_normals(from_V, F)[F[fid]])
    n0 /= np.linalg.norm(n0, axis=1, keepdims=True)
    offset = np.einsum("pd,pd->p", points - p, n0)
    tri1 = to_V[F[fid]]
    p1 = np.einsum("pk,pkd->pd", bary, tri1)
    n1 = np.einsum("pk,pkd->pd", bary, vertex_normals(to_V, F)[F[fid]])
    n1 /= np.linalg.norm(n1, axis=1, keepdims=True)
    return p1 + offset[:, None] * n1


def _barycentric(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    d00 = np.einsum("pd,pd->p", v0, v0)
    d01 = np.einsum("pd,pd->p", v0, v1)
    d11 = np.einsum("pd,pd->p", v1, v1)
    d20 = np.einsum("pd,pd->p", v2, v0)
    d21 = np.einsum("pd,pd->p", v2, v1)
    den = np.maximum(d00 * d11 - d01 * d01, 1e-30)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    out = np.stack([1.0 - v - w, v, w], axis=1)
    return np.clip(out, 0.0, 1.0) / np.clip(out, 0.0, 1.0).sum(1, keepdims=True)


def drape_stats(V: np.ndarray, F: np.ndarray, rest_V: np.ndarray, body_V: np.ndarray,
                body_F: np.ndarray) -> dict[str, float]:
    """Plausibility figures of one draped garment (the simulator comparison's criteria).

    Returns
    -------
    dict: ``deepest_mm`` (deepest vertex inside the body, >= 0), ``inside_area_pct`` (share of
    the garment's area inside the body, winding number on surface samples),
    ``strain_mean`` / ``strain_p99`` (|l / L - 1| over edges), ``self_intersecting_faces``
    (pymeshlab).
    """
    import pymeshlab

    from dressmeup.geometry.mesh import edges
    from dressmeup.geometry.proximity import closest_points
    from dressmeup.geometry.winding import winding_number
    from dressmeup.metrics import interpenetration_ratio

    d, _, _ = closest_points(body_V, body_F, V)
    inside = winding_number(body_V, body_F, V) > 0.5
    E = edges(F)
    L = np.linalg.norm(rest_V[E[:, 1]] - rest_V[E[:, 0]], axis=1)
    le = np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1)
    strain = np.abs(le / L - 1.0)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.asarray(V, np.float64), np.asarray(F, np.int32)))
    ms.compute_selection_by_self_intersections_per_face()
    return {"deepest_mm": float(d[inside].max() * 1000) if inside.any() else 0.0,
            "inside_area_pct": float(interpenetration_ratio((V, F), (body_V, body_F)) * 100),
            "strain_mean": float(strain.mean()), "strain_p99": float(np.quantile(strain, 0.99)),
            "self_intersecting_faces": int(ms.current_mesh().selected_face_number())}


class PoseDraper:
    """Drapes one fitted garment on one subject through the pose-continuation path."""

    def __init__(self, model, keep, skin_F, rest_V0, faces, support, fitted, weights, shape,
                 settings: DrapeSettings, steps: int) -> None:
        self.model, self.keep, self.skin_F = model, keep, skin_F
        self.rest_V0, self.faces, self.support = rest_V0, faces, support
        self.fitted, self.W, self.shape = fitted, weights, shape
        self.settings, self.steps = settings, max(1, int(steps))

    def posed(self, pose: np.ndarray):
        """(posed skin vertices (n, 3) rounded, LBS transforms (j, 4, 4) rounded)."""
        from dressmeup.body import BodyParams

        out = self.model.posed(BodyParams(model=self.model.name, shape=self.shape, pose=pose))
        return (_q(np.asarray(out.vertices)[self.keep], BODY_DECIMALS),
                _q(out.transforms, TRANSFORM_DECIMALS))

    def __call__(self, pose: np.ndarray, up: np.ndarray):
        """Drape at ``pose``; returns ``(DrapeResult of the last step, posed skin vertices)``."""
        from dressmeup.body.skinning import lbs

        prev, prev_skin, res, body_V = self.fitted, self.fitted, None, None
        for k in range(1, self.steps + 1):
            body_V, A = self.posed(pose * (k / self.steps))
            skin = lbs(self.fitted, self.W, A)
            start = prev + (skin - prev_skin)
            res = drape(self.rest_V0, self.faces, skin, self.support, body_V, self.skin_F, up,
                        self.settings, start=start)
            prev, prev_skin = res.vertices, skin
        return res, body_V


def generate_v3(out: str | os.PathLike, subjects: int = 4, poses: int = 4,
                garments_per_split: tuple[int, int, int] | list[int] = (6, 2, 4), seed: int = 0,
                body_model: str = "anny", categories: list[str] | None = None,
                edge_length: float | None = None, write_scan: bool = True,
                texture_size: int = 256, pose_steps: int = 3,
                drape_settings: DrapeSettings | None = None) -> Path:
    """Generate (or resume) a generator-2.0.0 dataset in ``out`` (see the module docstring).

    Parameters
    ----------
    out : output folder.
    subjects : subjects 1..6 (rows of :data:`SUBJECTS`); every garment is worn by each.
    poses : poses per subject (the same pose arrays for every subject).
    garments_per_split : (train, val, test) garments per category.
    seed : random seed; the dataset is a deterministic function of all arguments.
    body_model : ``anny`` (default) or ``procedural`` (tests).
    categories : subset of ``topwear``, ``bottomwear``, ``dress`` (default all).
    edge_length : garment edge length in metres (20 mm anny, 25 mm procedural).
    write_scan : write ``scan.ply`` (posed body + garment) per sample.
    texture_size : texture side in pixels.
    pose_steps : steps of the pose-continuation path (1: drape directly at the pose).
    drape_settings : material and solver settings (default :func:`v3_drape_settings`).

    Returns
    -------
    Path of the dataset root.
    """
    from dressmeup.data.synth.generate import _garment_weights, _skin, summarize_stats
    from dressmeup.data.writer import DatasetWriter
    from dressmeup.io.atomic import atomic_write_text
    from dressmeup.io.mesh import save_mesh
    from dressmeup.progress import progress

    gps = tuple(int(x) for x in garments_per_split)
    if len(gps) != 3:
        raise ValueError(f"garments_per_split: expected (train, val, test), got {gps!r}")
    plan = plan_v3(subjects, poses, gps, seed, categories)
    edge = float(edge_length or DEFAULT_EDGE_LENGTH.get(body_model, 0.02))
    settings = drape_settings or v3_drape_settings()
    params = {"version": VERSION, "subjects": subjects, "poses": poses,
              "garments_per_split": list(gps), "seed": seed, "body_model": body_model,
              "categories": list(categories or CATEGORY_TYPES), "edge_length": edge,
              "write_scan": write_scan, "texture_size": texture_size, "pose_steps": pose_steps,
              "drape": settings.to_dict()}
    info = {
        "name": "dressmeup-synthetic",
        "version": VERSION,
        "licence": "CC0-1.0 (generated data; anny body model data is CC0)",
        "description": "Synthetic DressMeUp-style dataset, generator 2.0.0: each parametric "
                       "garment is fitted to several bodies of different shape and draped "
                       "in identical poses (quasi-static cloth relaxation with body and self "
                       "collision along a pose path).",
        "body_model": body_model,
        "categories": sorted({g["category"] for g in plan["garments"].values()}),
        "citation": "dressmeup toolkit, synthetic generator " + VERSION,
        "generator": {"name": "dressmeup.data.synth", "version": VERSION, "seed": seed,
                      "params": params},
        "subjects": plan["subjects"],
        "poses": plan["poses"],
        "garments": plan["garments"],
    }
    t_start = time.perf_counter()
    out = Path(out)
    writer = DatasetWriter(out, info)
    with single_threaded():
        from dressmeup.body import get_body_model

        model = get_body_model(body_model)
        keep, skin_F = _skin(model)
        names = tuple(model.joint_names)
        body_W = np.asarray(model.skinning_weights)[keep]
        labels = np.array(names)[body_W.argmax(1)]
        frame0 = BodyFrame.from_joints(model.posed(model.default_params()).rest_joints, names)
        pose_arrays = {pid: pose_axis_angle(name, names, frame0, rng=None)
                       for pid, name in plan["poses"].items()}
        bodies: dict[str, Body] = {}
        for sid, s in plan["subjects"].items():
            shape = np.asarray(s["shape"], np.float64)
            from dressmeup.body import BodyParams

            rest = model.posed(BodyParams(model=model.name, shape=shape,
                                          pose=np.zeros((len(names), 3))))
            bodies[sid] = Body(sid, shape, _q(rest.rest_vertices[keep], BODY_DECIMALS),
                               BodyFrame.from_joints(_q(rest.rest_joints, BODY_DECIMALS),
                                                     names))
        sids, pids = list(plan["subjects"]), list(plan["poses"])
        total = len(plan["garments"]) * len(sids) * len(pids)
        bar = progress(range(total), desc="synth v3", total=total)
        for gid, g in plan["garments"].items():
            ids = [f"{s}-{gid}-{p}" for s in sids for p in pids]
            if all(writer.has_sample(x) for x in ids):
                for _ in ids:
                    next(bar, None)
                continue
            _make_garment(writer, out, gid, g, bodies, sids, pids, pose_arrays, model, keep,
                          skin_F, body_W, labels, names, edge, settings, pose_steps, seed,
                          texture_size, write_scan, bar, save_mesh, atomic_write_text,
                          _garment_weights)
        for _ in bar:
            pass
    report = summarize_stats(out)
    return writer.finalize(report=report,
                           timings={"last_run_s": round(time.perf_counter() - t_start, 2)})


def _make_garment(writer, out, gid, g, bodies, sids, pids, pose_arrays, model, keep, skin_F,
                  body_W, labels, names, edge, settings, pose_steps, seed, texture_size,
                  write_scan, bar, save_mesh, atomic_write_text, garment_weights):
    """Build one garment on its design body, fit it to every subject, drape every pose."""
    from dressmeup.body import BodyParams
    from dressmeup.data.synth.texture import procedural_texture

    design = bodies[g["design_subject"]]
    garment = build_garment(g["type"], g["params"], design.rest_V, skin_F, labels,
                            design.frame, edge_length=edge)
    V0, F = _q(garment.vertices, STORE_DECIMALS), garment.faces
    save_mesh(out / "generator" / "rest" / f"{gid}.ply", V0, F, uv=garment.uv,
              uv_faces=garment.uv_faces)
    tex, pattern = procedural_texture(np.random.default_rng([seed, 7919, int(gid[1:])]),
                                      texture_size)
    for sid in sids:
        body = bodies[sid]
        ids = [f"{sid}-{gid}-{p}" for p in pids]
        if all(writer.has_sample(x) for x in ids):
            for _ in ids:
                next(bar, None)
            continue
        if sid == design.sid:
            fitted = V0
            fit_stats: dict[str, Any] = {"fit": "design body"}
        else:
            start = transfer_to_body(V0, design.rest_V, body.rest_V, skin_F)
            fit = drape(V0, F, start, garment.support, body.rest_V, skin_F, body.frame.up,
                        settings)
            fitted = _q(fit.vertices, STORE_DECIMALS)
            fit_stats = {"fit": "fitted", **{f"fit_{k}": v for k, v in fit.stats.items()}}
        save_mesh(out / "generator" / "fitted" / f"{gid}-{sid}.ply", fitted, F)
        fitted_garment = _Fitted(fitted, F, garment.garment_type)
        W = garment_weights(fitted_garment, body.rest_V, skin_F, body_W, names, body.frame)
        draper = PoseDraper(model, keep, skin_F, V0, F, garment.support, fitted, W, body.shape,
                            settings, pose_steps)
        for pid in pids:
            sample_id = f"{sid}-{gid}-{pid}"
            next(bar, None)
            if writer.has_sample(sample_id):
                continue
            pose = pose_arrays[pid]
            res, body_V = draper(pose, body.frame.up)
            Vd = _q(res.vertices, STORE_DECIMALS)
            bp = BodyParams(model=model.name, shape=body.shape, pose=pose)
            scan = None
            if write_scan:
                posed_all = model.posed(bp)
                BV = _q(posed_all.vertices, STORE_DECIMALS)
                scan = (np.vstack([BV, Vd]),
                        np.vstack([np.asarray(model.faces, np.int64), F + len(BV)]))
            st = {**res.stats, **drape_stats(Vd, F, V0, body_V, skin_F), **fit_stats,
                  "pose": pid, "garment_type": g["type"],
                  "texture": pattern, "subject": sid, "design_subject": design.sid}
            atomic_write_text(out / "generator" / "stats" / f"{sample_id}.json",
                              json.dumps(st, indent=1, sort_keys=True) + "\n")
            writer.add_sample(subject_id=sid, garment_id=gid, pose_id=pid,
                              category=garment.category, garment_type=garment.garment_type,
                              split=g["split"], garment=(Vd, F, garment.uv, garment.uv_faces),
                              body=bp, scan=scan, texture=tex)


@dataclass
class _Fitted:
    vertices: np.ndarray
    faces: np.ndarray
    garment_type: str
