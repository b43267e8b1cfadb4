"""Generator 3.0.0: every garment dressed by simulation (the v4 retargeting data).

The plan is generator 2.x's (:func:`dressmeup.data.synth.wardrobe.plan_v3`: the subject
table, the same pose arrays for every subject, garments per category and split, each designed
on one subject), and so are the garment build, the textures, the scans and the files
written. What differs is how a garment reaches each subject and pose
(:mod:`dressmeup.data.synth.simulation`): it settles under gravity on its design body at rest,
the body changes shape gradually into the wearer's (``generator/fitted/<garment>-<subject>.ply``
is the result), then the wearer's pose grows from the rest pose to the target pose, each
intermediate body a quasi-static solve with body contact and cloth self-contact that starts
from the previous state and runs to a tolerance. Nothing starts from skinning or from a
transfer of the body's displacement, and there is no final projection: the written garment is
the solver's equilibrium.

``generator/stats/<sample>.json`` records the plausibility figures
(:func:`dressmeup.data.synth.wardrobe.drape_stats`) and the solver's end state: ``energy``
(units of the garment's weight x 1 cm), ``grad_norm`` (RMS residual force / mean vertex
weight), ``grad_max``, ``energy_change``, ``converged``, ``iterations`` (settling, shape path
and pose path together) and per stage (``settle``, ``fit``, ``dress``) the same figures.

Reproducibility: the workers start with the canonical numerics of 2.x
(:data:`dressmeup.data.synth.jobs.CANONICAL_ENV`), and the cloth solver does its
arithmetic in numpy and scipy (no torch, no MKL: the code branch MKL picks by CPU maker does
not reach it); bodies are rounded to 1e-9 m and every stored vertex to 1 micrometre.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.body import BodyParams
from dressmeup.data.synth.garments import build_garment, welded
from dressmeup.data.synth.scans import SCAN_BODY, clothed_scan
from dressmeup.data.synth.simulation import BodyAnchors, Dresser, DressSettings, path_bodies
from dressmeup.data.synth.stats import summarize_dress_stats
from dressmeup.data.synth.texture import procedural_texture
from dressmeup.data.synth.wardrobe import (
    _STATE,
    BODY_DECIMALS,
    CATEGORY_TYPES,
    DEFAULT_EDGE_LENGTH,
    STORE_DECIMALS,
    dataset_info,
    drape_stats,
    generator_params,
    plan_v3,
    quantize,
    write_plan,
)

VERSION = "3.0.0"
#: the solver figures copied to the top of every sample's stats (from the pose path's end)
END_STATE = ("energy", "grad_norm", "grad_max", "energy_change", "converged", "self_pairs")


def generate_v4(out: str | os.PathLike, subjects: int = 4, poses: int = 3,
                garments_per_split: tuple[int, int, int] | list[int] = (6, 2, 4), seed: int = 0,
                body_model: str = "anny", categories: list[str] | None = None,
                edge_length: float | None = None, write_scan: bool = True,
                texture_size: int = 256, dress_settings: DressSettings | None = None,
                workers: int = 1, executor: Any = None, scan_body: str = "whole") -> Path:
    """Generate (or resume) a generator-3.0.0 dataset in ``out`` (module docstring).

    Parameters
    ----------
    out : output folder.
    subjects : subjects 1..6 (rows of :data:`dressmeup.data.synth.wardrobe.SUBJECTS`).
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
    executor : instead, a :mod:`dressmeup.executors` executor, one job per garment.
    scan_body : ``"whole"`` or ``"uncovered"`` (see :mod:`dressmeup.data.synth.scans`).

    Returns
    -------
    Path of the dataset root.
    """
    gps = tuple(int(x) for x in garments_per_split)
    if len(gps) != 3:
        raise ValueError(f"garments_per_split: expected (train, val, test), got {gps!r}")
    if scan_body not in SCAN_BODY:
        raise ValueError(f"scan_body: expected one of {SCAN_BODY}, got {scan_body!r}")
    plan = plan_v3(subjects, poses, gps, seed, categories)
    edge = float(edge_length or DEFAULT_EDGE_LENGTH.get(body_model, 0.02))
    settings = dress_settings or DressSettings()
    params = generator_params(subjects=subjects, poses=poses, garments_per_split=list(gps),
                              seed=seed, body_model=body_model,
                              categories=list(categories or CATEGORY_TYPES), edge_length=edge,
                              write_scan=write_scan, texture_size=texture_size,
                              dress=settings.to_dict(), scan_body=scan_body)
    params["version"] = VERSION
    info = dataset_info(VERSION, f"Synthetic DressMeUp-style dataset, generator {VERSION}: each "
                        "parametric garment is dressed by simulation from its design body at "
                        "rest onto bodies of different shape in identical poses (the body "
                        "changes gradually, shape then pose; quasi-static cloth with body "
                        "contact and self-contact, solved to a tolerance).", body_model, plan,
                        seed, params)
    setup = (body_model, plan, edge, settings, 0, seed, texture_size, write_scan, scan_body)
    return write_plan(out, info, plan, _dress_job, setup, workers, executor, "synth v4",
                      summarize_dress_stats)


def _rest_body(shape: np.ndarray) -> np.ndarray:
    """Skin vertices ``(b, 3)`` of the body of phenotype ``shape`` at rest (rounded)."""
    S = _STATE
    model = S["model"]
    out = model.posed(BodyParams(model=model.name, shape=shape,
                                 pose=np.zeros((len(S["names"]), 3))))
    return quantize(np.asarray(out.rest_vertices)[S["keep"]], BODY_DECIMALS)


def _posed_body(shape: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Skin vertices ``(b, 3)`` of the body ``shape`` in ``pose`` (rounded)."""
    S = _STATE
    model = S["model"]
    out = model.posed(BodyParams(model=model.name, shape=shape, pose=pose))
    return quantize(np.asarray(out.vertices)[S["keep"]], BODY_DECIMALS)


def _dress_job(job) -> dict[str, Any]:
    """Build one garment, settle it on its design body, take it to every subject it is worn
    by (shape path) and into every pose (pose path); every array to write, in the format of
    generator 2.1.0's garment job."""
    gid, g, missing = job
    S = _STATE
    t_cpu = time.process_time()
    settings: DressSettings = S["settings"]
    skin_F, bodies = S["skin_F"], S["bodies"]
    design = bodies[g["design_subject"]]
    garment = build_garment(g["type"], g["params"], design.rest_V, skin_F, S["labels"],
                            design.frame, edge_length=S["edge"])
    V0, F, uv_faces, support = welded(garment, quantize(garment.vertices, STORE_DECIMALS))
    tex, pattern = procedural_texture(np.random.default_rng([S["seed"], 7919, int(gid[1:])]),
                                      S["texture_size"])
    res: dict[str, Any] = {"gid": gid, "g": g, "V0": V0, "F": F, "uv": garment.uv,
                           "uv_faces": uv_faces, "category": garment.category,
                           "garment_type": garment.garment_type, "tex": tex, "fitted": {},
                           "samples": [], "build_cpu_s": time.process_time() - t_cpu}
    dresser = Dresser(V0, F, BodyAnchors(V0, support, design.rest_V, skin_F), skin_F,
                      design.frame.up, settings)
    settled, settle = dresser.follow(settings.start(V0), [design.rest_V])
    for sid in dict.fromkeys(s for s, _ in missing):
        body = bodies[sid]
        if sid == design.sid:
            fitted, fit = settled, {"steps": 0, "iterations": 0, "cpu_s": 0.0}
        else:
            path = path_bodies(
                lambda t, b=body: _rest_body((1 - t) * design.shape + t * b.shape),
                design.rest_V, settled, settings)
            fitted, fit = dresser.follow(settled, path)
        res["fitted"][sid] = quantize(fitted, STORE_DECIMALS)
        for pid in [p for s, p in missing if s == sid]:
            pose = S["poses"][pid]
            path = path_bodies(lambda t, b=body, q=pose: _posed_body(b.shape, q * t),
                               body.rest_V, fitted, settings)
            dressed, dress = dresser.follow(fitted, path)
            Vd = quantize(dressed, STORE_DECIMALS)
            scan = (clothed_scan(quantize(_posed_body(body.shape, pose), STORE_DECIMALS),
                                 S["model"].faces, Vd, F, S["scan_body"])
                    if S["write_scan"] else None)
            st = {**drape_stats(Vd, F, V0, path[-1], skin_F),
                  **{k: dress[k] for k in END_STATE},
                  "iterations": settle["iterations"] + fit["iterations"] + dress["iterations"],
                  "settle": settle, "fit": fit, "dress": dress, "pose": pid,
                  "garment_type": g["type"], "texture": pattern, "subject": sid,
                  "design_subject": design.sid}
            res["samples"].append({"sid": sid, "pid": pid, "V": Vd, "scan": scan,
                                   "shape": body.shape, "pose": pose, "stats": st,
                                   "model": S["model"].name})
    return res
