"""Generator 2.1.0 writes the v3 editions' data: each garment is one pattern worn by several
bodies.

A garment (one rest mesh: vertices, faces, UVs) is made around its *design* body, then
**fitted** to every subject of the dataset and draped in every pose:

The plan (steps 1-3) is :func:`dressmeup.data.synth.common.plan_2x`, which generator 3.0.0
takes as well.

1. **Subjects** come from a fixed table of phenotypes that spreads the body model's range
   (:data:`~dressmeup.data.synth.common.SUBJECTS`: gender, age, muscle, weight, height at
   their extremes; adults only, since the model's lowest ages are children). Subject ``k``
   is ``SUBJECTS[k]``.
2. **Poses** are the same pose arrays for every subject: the first ``poses`` library poses
   of :data:`~dressmeup.data.synth.common.POSE_ORDER` (:mod:`dressmeup.data.synth.poses`)
   turned into axis-angle once, on the model's default body, without jitter. ``P1`` of one
   subject is exactly ``P1`` of another.
3. **Garments**: per category (topwear, bottomwear, dress), ``test + val + train``
   garments cycling through the category's types with parameters drawn per garment (seeded),
   so no two garments are alike. Garment ``k`` is designed on subject ``k mod subjects``.
4. **Fit**: each garment vertex moves by the body's shape displacement at its closest
   point on the design body (same body topology, so the same face and barycentric
   coordinates on the other body), then is relaxed in the rest pose with the garment's own
   rest edge lengths (:func:`dressmeup.data.synth.drape.drape`): a garment made for a slim
   body fitted to a heavy one stretches, one made for a heavy body stands off a slim one; a
   final projection keeps every vertex outside the body (it never sinks in).
5. **Drape per pose**: skinning weights transferred from the subject's rest body to the
   fitted garment, then a pose-continuation path (``pose_steps`` steps from the rest pose to
   the target pose; each step starts from the previous drape moved by the change of the
   skinned garment) so the cloth is carried over the thighs when sitting instead of being
   cut through by them; each step is a quasi-static relaxation with body collision and cloth
   self-collision.

Reproducibility: the numbers are computed in worker processes started with
:data:`~dressmeup.data.synth.jobs.CANONICAL_ENV` (one thread, the portable kernels of torch,
MKL, OpenBLAS and numpy); body vertices and LBS matrices are rounded (1e-9 m, 1e-12) before
use; every closest body face (fit, drape, displacement transfer) is chosen in float64 among
the faces around open3d's float32 pick (``closest_points(..., exact_faces=True)``, new in
2.1.0: 2.0.0 let the float32 pick decide, and another CPU's rounding changed the drapes); and
every stored garment, body and scan vertex is rounded to 1e-6 m (one micrometre), so the data
and their manifest do not depend on the thread count, the CPU's vector extensions or its
float32 rounding (see docs/synthetic-data.md, "Reproducibility"). They still depend on the
CPU's maker: two AMD EPYC machines write the pinned data, an Intel Xeon other data, and there
MKL's code branch (which torch calls for float64 matmuls and elementwise functions even
with its portable kernels) changes them; not fixed in 2.1.0.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.body import BodyParams
from dressmeup.body.skinning import lbs
from dressmeup.data.synth.common import (
    BODY_DECIMALS,
    CATEGORY_TYPES,
    STORE_DECIMALS,
    Body,
    GarmentItem,
    GarmentResult,
    PlanBodies,
    PlanJob,
    SampleResult,
    dataset_arguments,
    dataset_info,
    drape_stats,
    generator_params,
    plan_2x,
    quantize,
    write_plan,
)
from dressmeup.data.synth.drape import DrapeResult, DrapeSettings, drape
from dressmeup.data.synth.dressing import garment_weights
from dressmeup.data.synth.garments import RestGarment
from dressmeup.data.synth.scans import clothed_scan
from dressmeup.data.synth.stats import summarize_stats
from dressmeup.geometry.proximity import barycentric, closest_points

VERSION = "2.1.0"
TRANSFORM_DECIMALS = 12  # LBS matrices


def drape_settings_2x() -> DrapeSettings:
    """Drape settings of generator 2.x: 1.x's material, cloth self-collision on, and a
    3 mm final clearance (1 mm let 20 mm triangles of a garment stretched over a heavier body
    cut into its curved surface between their vertices)."""
    return DrapeSettings(self_stiffness=2.0e5, self_thickness=0.010, margin=0.006,
                         clearance=0.003)


def transfer_to_body(points: np.ndarray, from_V: np.ndarray, to_V: np.ndarray,
                     faces: np.ndarray) -> np.ndarray:
    """Carry points from one body to another of the same topology (the fit's start).

    Each point moves by the body's displacement at its closest surface point on ``from_V``
    (barycentric blend of ``to_V - from_V`` over the closest face): a smooth map, since the
    bodies differ by smooth shape blendshapes, so the garment keeps its offset from the body
    and does not fold where the surface is concave (an offset along the normal would).

    Parameters
    ----------
    points : (p, 3) float64 points near the ``from_V`` body.
    from_V, to_V : (n, 3) float64 vertices of the two bodies; faces : (m, 3) int64 shared.

    Returns
    -------
    (p, 3) float64 points near ``to_V``.
    """

    F = np.asarray(faces, np.int64)
    _, p, fid = closest_points(from_V, F, points, exact_faces=True)
    bary = barycentric(p, from_V[F[fid]])
    disp = np.einsum("pk,pkd->pd", bary, (to_V - from_V)[F[fid]])
    return np.asarray(points, np.float64) + disp


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

        out = self.model.posed(BodyParams(model=self.model.name, shape=self.shape, pose=pose))
        return (quantize(np.asarray(out.vertices)[self.keep], BODY_DECIMALS),
                quantize(out.transforms, TRANSFORM_DECIMALS))

    def __call__(self, pose: np.ndarray, up: np.ndarray):
        """Drape at ``pose``; returns ``(DrapeResult of the last step, posed skin vertices)``."""

        prev, prev_skin, res, body_V = self.fitted, self.fitted, None, None
        for k in range(1, self.steps + 1):
            body_V, A = self.posed(pose * (k / self.steps))
            skin = lbs(self.fitted, self.W, A)
            start = prev + (skin - prev_skin)
            res = drape(self.rest_V0, self.faces, skin, self.support, body_V, self.skin_F, up,
                        self.settings, start=start, exact_faces=True)
            prev, prev_skin = res.vertices, skin
        return res, body_V


@dataclass
class FittedGarment:
    """A fitted garment for :func:`garment_weights`: vertices ``(n, 3)``, faces, type."""

    vertices: np.ndarray
    faces: np.ndarray
    garment_type: str


@dataclass(frozen=True)
class GarmentJob(PlanJob):
    """Generator 2.1.0's job of one garment (``job(GarmentItem) -> GarmentResult``): build it
    on its design body, fit it to the subjects, drape the missing samples (computed in a
    worker; the plan's bodies are built once a process)."""

    settings: DrapeSettings
    pose_steps: int

    def __call__(self, item: GarmentItem) -> GarmentResult:
        """Every array to write of ``item``'s garment."""
        t_cpu = time.process_time()
        garment, design = self.build(item)
        V0, F = quantize(garment.vertices, STORE_DECIMALS), garment.faces
        tex, pattern = self.texture(item.gid)
        res = GarmentResult(gid=item.gid, garment=item.garment, V0=V0, F=F, uv=garment.uv,
                            uv_faces=garment.uv_faces, category=garment.category,
                            garment_type=garment.garment_type, tex=tex,
                            build_cpu_s=time.process_time() - t_cpu)
        for sid in item.subjects():
            self._wear(item, res, garment, design, self.bodies().bodies[sid], pattern)
        return res

    def _wear(self, item: GarmentItem, res: GarmentResult, garment: RestGarment, design: Body,
              body: Body, pattern: str) -> None:
        """Fit the garment to ``body`` and drape it in the subject's missing poses (into
        ``res``)."""
        b = self.bodies()
        V0, F = res.V0, res.F
        t_fit = time.process_time()
        if body.sid == design.sid:
            fitted, fit_stats = V0, {"fit": "design body"}
        else:
            start = transfer_to_body(V0, design.rest_V, body.rest_V, b.skin_F)
            fit = drape(V0, F, start, garment.support, body.rest_V, b.skin_F, body.frame.up,
                        self.settings, exact_faces=True)
            fitted = quantize(fit.vertices, STORE_DECIMALS)
            fit_stats = {"fit": "fitted", **{f"fit_{k}": v for k, v in fit.stats.items()}}
        res.fitted[body.sid] = fitted
        W = garment_weights(FittedGarment(fitted, F, garment.garment_type), body.rest_V,
                             b.skin_F, b.body_W, b.names, body.frame)
        draper = PoseDraper(b.model, b.keep, b.skin_F, V0, F, garment.support, fitted, W,
                            body.shape, self.settings, self.pose_steps)
        fit_stats["fit_cpu_s"] = time.process_time() - t_fit
        for pid in item.poses_of(body.sid):
            t0 = time.process_time()
            out, body_V = draper(b.poses[pid], body.frame.up)
            smp = self._sample(b, body, pid, out, res)
            drape_cpu = time.process_time() - t0
            smp.stats = {**out.stats, **drape_stats(smp.V, F, V0, body_V, b.skin_F),
                         **fit_stats, "pose": pid, "garment_type": item.garment["type"],
                         "texture": pattern, "subject": body.sid,
                         "design_subject": design.sid, "drape_cpu_s": drape_cpu}
            res.samples.append(smp)

    def _sample(self, b: PlanBodies, body: Body, pid: str, out: DrapeResult,
                res: GarmentResult) -> SampleResult:
        """The stored sample of one drape (its scan included)."""
        pose = b.poses[pid]
        Vd = quantize(out.vertices, STORE_DECIMALS)
        scan = None
        if self.write_scan:
            BV = quantize(b.model.posed(b.params(body.shape, pose)).vertices, STORE_DECIMALS)
            scan = clothed_scan(BV, b.model.faces, Vd, res.F, self.scan_body)
        return SampleResult(sid=body.sid, pid=pid, V=Vd, scan=scan, shape=body.shape,
                            pose=pose, stats={}, model=b.model.name)


def generate_2x(out: str | os.PathLike, subjects: int = 4, poses: int = 4,
                garments_per_split: tuple[int, int, int] | list[int] = (6, 2, 4), seed: int = 0,
                body_model: str = "anny", categories: list[str] | None = None,
                edge_length: float | None = None, write_scan: bool = True,
                texture_size: int = 256, pose_steps: int = 3,
                drape_settings: DrapeSettings | None = None, workers: int = 1,
                executor: Any = None, pose_set: str = "generator", wear: str = "all",
                scan_body: str = "whole") -> Path:
    """Generate (or resume) a generator-2.1.0 dataset in ``out`` (see the module docstring).

    Parameters
    ----------
    out : output folder.
    subjects : subjects 1..6 (rows of :data:`~dressmeup.data.synth.common.SUBJECTS`); every
        garment is worn by each.
    poses : poses per subject (the same pose arrays for every subject).
    garments_per_split : (train, val, test) garments per category.
    seed : random seed; the dataset is a deterministic function of all arguments but
        ``workers``.
    body_model : ``anny`` (default) or ``procedural`` (tests).
    categories : subset of ``topwear``, ``bottomwear``, ``dress`` (default all).
    edge_length : garment edge length in metres (20 mm anny, 25 mm procedural).
    write_scan : write ``scan.ply`` (posed body + garment) per sample.
    texture_size : texture side in pixels.
    pose_steps : steps of the pose-continuation path (1: drape directly at the pose).
    drape_settings : material and solver settings (default :func:`drape_settings_2x`).
    workers : processes computing garments in parallel (one thread each; at least one is
        always started, see :func:`~dressmeup.data.synth.jobs.run_jobs`); the files and the
        manifest are the same for any number (this process writes them in plan order).
    executor : instead, a :mod:`dressmeup.executors` executor running one job per garment
        (:class:`GarmentJob`): a Dask one starts its workers with the canonical numerics; a
        ``LocalExecutor`` means the spawned pool above with its number of workers.
    pose_set : library pose set the poses come from (``"generator"``, ``"registration"``,
        ``"registration-tuning"``, ``"all"``; see
        :func:`~dressmeup.data.synth.common.plan_2x`).
    wear : ``"all"`` (every garment on every subject in every pose) or ``"rotate"`` (one
        garment per subject and pose, rotating; see
        :func:`~dressmeup.data.synth.common.plan_2x`).
    scan_body : ``"whole"`` (the entire body mesh in ``scan.ply``, also under the garment) or
        ``"uncovered"`` (the body faces under the garment left out, as a scanner sees a
        clothed person; :mod:`dressmeup.data.synth.scans`).
    These three are recorded in ``dataset.json``'s generator parameters only when not the default,
    so datasets made before they existed keep their bytes and manifest.

    Returns
    -------
    Path of the dataset root.
    """

    plan, info, job = prepare_2x(
        subjects=subjects, poses=poses, garments_per_split=garments_per_split, seed=seed,
        body_model=body_model, categories=categories, edge_length=edge_length,
        write_scan=write_scan, texture_size=texture_size, pose_steps=pose_steps,
        drape_settings=drape_settings, pose_set=pose_set, wear=wear, scan_body=scan_body)
    return write_plan(out, info, plan, job, workers, executor, "synth v3", summarize_stats)


def prepare_2x(subjects: int = 4, poses: int = 4,
               garments_per_split: tuple[int, int, int] | list[int] = (6, 2, 4), seed: int = 0,
               body_model: str = "anny", categories: list[str] | None = None,
               edge_length: float | None = None, write_scan: bool = True,
               texture_size: int = 256, pose_steps: int = 3,
               drape_settings: DrapeSettings | None = None, pose_set: str = "generator",
               wear: str = "all", scan_body: str = "whole"
               ) -> tuple[dict[str, Any], dict[str, Any], GarmentJob]:
    """What :func:`generate_2x` computes before any garment (arguments as there): the plan,
    the ``dataset.json`` record and the garment job. Nothing is written; bad arguments raise
    ``ValueError``."""
    gps, edge = dataset_arguments(garments_per_split, scan_body, body_model, edge_length)
    plan = plan_2x(subjects, poses, gps, seed, categories, pose_set=pose_set, wear=wear)
    settings = drape_settings or drape_settings_2x()
    params = generator_params(VERSION, subjects=subjects, poses=poses,
                              garments_per_split=list(gps), seed=seed, body_model=body_model,
                              categories=list(categories or CATEGORY_TYPES), edge_length=edge,
                              write_scan=write_scan, texture_size=texture_size,
                              pose_steps=pose_steps, drape=settings.to_dict(),
                              pose_set=pose_set, wear=wear, scan_body=scan_body)
    info = dataset_info(VERSION, f"Synthetic DressMeUp-style dataset, generator {VERSION}: each "
                        "parametric garment is fitted to several bodies of different shape and "
                        "draped in identical poses (quasi-static cloth relaxation with body and "
                        "self collision along a pose path).", body_model, plan, seed, params)
    job = GarmentJob(body_model=body_model, **PlanJob.of_plan(plan), edge=edge, seed=seed,
                     texture_size=texture_size, write_scan=write_scan, scan_body=scan_body,
                     settings=settings, pose_steps=pose_steps)
    return plan, info, job
