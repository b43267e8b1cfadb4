"""Generator 3.0.0 writes the v4 editions' data: every garment dressed by simulation.

The plan is generator 2.x's (:func:`dressmeup.data.synth.common.plan_2x`: the subject
table, the same pose arrays for every subject, garments per category and split, each designed
on one subject), and so are the garment build, the textures, the scans and the files
written. What differs is how a garment reaches each subject and pose
(:mod:`dressmeup.data.synth.quasistatic`): it settles under gravity on its design body at
rest, the body changes shape gradually into the wearer's
(``generator/fitted/<garment>-<subject>.ply`` is the result), then the wearer's pose grows
from the rest pose to the target pose, each intermediate body a quasi-static solve with body
contact and cloth self-contact that starts from the previous state and runs to a tolerance.
Nothing starts from skinning or from a transfer of the body's displacement, and there is no
final projection: the written garment is the solver's equilibrium.

``generator/stats/<sample>.json`` records the plausibility figures
(:func:`dressmeup.data.synth.common.drape_stats`) and the solver's end state: ``energy``
(units of the garment's weight x 1 cm), ``grad_norm`` (RMS residual force / mean vertex
weight), ``grad_max``, ``energy_change``, ``converged``, ``iterations`` (settling, shape path
and pose path together) and per stage (``settle``, ``fit``, ``dress``) the same figures.

Reproducibility: the workers start with the canonical numerics
(:data:`dressmeup.data.synth.jobs.CANONICAL_ENV`), and the cloth solver does its
arithmetic in numpy and scipy (no torch, no MKL: the code branch MKL picks by CPU maker does
not reach it); bodies are rounded to 1e-9 m and every stored vertex to 1 micrometre.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.data.synth.common import (
    CATEGORY_TYPES,
    STORE_DECIMALS,
    Body,
    BodyAnchors,
    GarmentItem,
    GarmentResult,
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
from dressmeup.data.synth.garments import welded
from dressmeup.data.synth.quasistatic import Dresser, DressSettings, path_bodies
from dressmeup.data.synth.scans import clothed_scan
from dressmeup.data.synth.stats import summarize_dress_stats

VERSION = "3.0.0"
#: the solver figures copied to the top of every sample's stats (from the pose path's end)
END_STATE = ("energy", "grad_norm", "grad_max", "energy_change", "converged", "self_pairs")


def generate_3x(out: str | os.PathLike, subjects: int = 4, poses: int = 3,
                garments_per_split: tuple[int, int, int] | list[int] = (6, 2, 4), seed: int = 0,
                body_model: str = "anny", categories: list[str] | None = None,
                edge_length: float | None = None, write_scan: bool = True,
                texture_size: int = 256, dress_settings: DressSettings | None = None,
                workers: int = 1, executor: Any = None, scan_body: str = "whole") -> Path:
    """Generate (or resume) a generator-3.0.0 dataset in ``out`` (module docstring).

    Parameters
    ----------
    out : output folder.
    subjects : subjects 1..6 (rows of :data:`dressmeup.data.synth.common.SUBJECTS`).
    poses : poses (the same pose arrays for every subject).
    garments_per_split : (train, val, test) garments per category.
    seed : random seed; the dataset is a deterministic function of all arguments but
        ``workers`` and ``executor``.
    body_model : ``anny`` (default) or ``procedural`` (tests).
    categories : subset of ``topwear``, ``bottomwear``, ``dress`` (default all).
    edge_length : garment edge length in metres (20 mm anny, 25 mm procedural).
    write_scan : write ``scan.ply`` (posed body + garment) per sample.
    texture_size : texture side in pixels.
    dress_settings : path and solver settings (default :class:`DressSettings`).
    workers : processes computing garments in parallel (one thread each).
    executor : instead, a :mod:`dressmeup.executors` executor, one job per garment
        (:class:`DressJob`; see :func:`dressmeup.data.synth.jobs.run_jobs`).
    scan_body : ``"whole"`` or ``"uncovered"`` (see :mod:`dressmeup.data.synth.scans`).

    Returns
    -------
    Path of the dataset root.
    """
    gps, edge = dataset_arguments(garments_per_split, scan_body, body_model, edge_length)
    plan = plan_2x(subjects, poses, gps, seed, categories)
    settings = dress_settings or DressSettings()
    params = generator_params(VERSION, subjects=subjects, poses=poses,
                              garments_per_split=list(gps), seed=seed, body_model=body_model,
                              categories=list(categories or CATEGORY_TYPES), edge_length=edge,
                              write_scan=write_scan, texture_size=texture_size,
                              dress=settings.to_dict(), scan_body=scan_body)
    info = dataset_info(VERSION, f"Synthetic DressMeUp-style dataset, generator {VERSION}: each "
                        "parametric garment is dressed by simulation from its design body at "
                        "rest onto bodies of different shape in identical poses (the body "
                        "changes gradually, shape then pose; quasi-static cloth with body "
                        "contact and self-contact, solved to a tolerance).", body_model, plan,
                        seed, params)
    job = DressJob(body_model=body_model, **PlanJob.of_plan(plan), edge=edge, seed=seed,
                   texture_size=texture_size, write_scan=write_scan, scan_body=scan_body,
                   settings=settings)
    return write_plan(out, info, plan, job, workers, executor, "synth v4",
                      summarize_dress_stats)


@dataclass(frozen=True)
class DressJob(PlanJob):
    """Generator 3.0.0's job of one garment (``job(GarmentItem) -> GarmentResult``): build it,
    settle it on its design body, take it to every subject it is worn by (shape path) and
    into every pose (pose path); the plan's bodies are built once a process."""

    settings: DressSettings

    def __call__(self, item: GarmentItem) -> GarmentResult:
        """Every array to write of ``item``'s garment."""
        t_cpu = time.process_time()
        b = self.bodies()
        garment, design = self.build(item)
        V0, F, uv_faces, support = welded(garment, quantize(garment.vertices, STORE_DECIMALS))
        tex, pattern = self.texture(item.gid)
        res = GarmentResult(gid=item.gid, garment=item.garment, V0=V0, F=F, uv=garment.uv,
                            uv_faces=uv_faces, category=garment.category,
                            garment_type=garment.garment_type, tex=tex,
                            build_cpu_s=time.process_time() - t_cpu)
        dresser = Dresser(V0, F, BodyAnchors(V0, support, design.rest_V, b.skin_F), b.skin_F,
                          design.frame.up, self.settings)
        settled, settle = dresser.follow(self.settings.start(V0), [design.rest_V])
        for sid in item.subjects():
            body = b.bodies[sid]
            fitted, fit = self._fit(dresser, design, body, settled)
            res.fitted[sid] = quantize(fitted, STORE_DECIMALS)
            for pid in item.poses_of(sid):
                smp, dress = self._dress(dresser, body, pid, fitted, res)
                smp.stats = {**smp.stats,
                             **{k: dress[k] for k in END_STATE},
                             "iterations": settle["iterations"] + fit["iterations"]
                             + dress["iterations"],
                             "settle": settle, "fit": fit, "dress": dress, "pose": pid,
                             "garment_type": item.garment["type"], "texture": pattern,
                             "subject": sid, "design_subject": design.sid}
                res.samples.append(smp)
        return res

    def _fit(self, dresser: Dresser, design: Body, body: Body, settled: np.ndarray
             ) -> tuple[np.ndarray, dict[str, Any]]:
        """The settled garment taken from the design body to ``body`` at rest (shape path),
        and the path's solver figures."""
        if body.sid == design.sid:
            return settled, {"steps": 0, "iterations": 0, "cpu_s": 0.0}
        path = path_bodies(
            lambda t, b=body: self.bodies().rest_body((1 - t) * design.shape + t * b.shape),
            design.rest_V, settled, self.settings)
        return dresser.follow(settled, path)

    def _dress(self, dresser: Dresser, body: Body, pid: str, fitted: np.ndarray,
               res: GarmentResult) -> tuple[SampleResult, dict[str, Any]]:
        """The garment fitted to ``body`` taken into pose ``pid`` (pose path): the stored
        sample (its stats: :func:`~dressmeup.data.synth.common.drape_stats`) and the path's
        solver figures."""
        b = self.bodies()
        pose = b.poses[pid]
        path = path_bodies(lambda t: b.posed_body(body.shape, pose * t), body.rest_V, fitted,
                           self.settings)
        dressed, dress = dresser.follow(fitted, path)
        Vd = quantize(dressed, STORE_DECIMALS)
        scan = (clothed_scan(quantize(b.posed_body(body.shape, pose), STORE_DECIMALS),
                             b.model.faces, Vd, res.F, self.scan_body)
                if self.write_scan else None)
        return SampleResult(sid=body.sid, pid=pid, V=Vd, scan=scan, shape=body.shape, pose=pose,
                            stats=drape_stats(Vd, res.F, res.V0, path[-1], b.skin_F),
                            model=b.model.name), dress
