"""`generate_dataset`: the built-in synthetic DressMeUp-style dataset.

Subjects are bodies of varied shape (phenotype drawn per subject); each wears ``garments``
garments (types from ``garment_types.json``) in ``poses`` poses (from ``poses.json``, jittered
per subject). Each garment is built once around the subject's rest body, then for every
pose: skinned, relaxed (:mod:`dressmeup.data.synth.drape`) and written with the posed body's
true parameters and a clothed "scan" (body + garment merged). Splits go by garment,
stratified by garment category.
Deterministic for a seed; re-running on the same folder resumes.

Besides the dataset layout, the generator writes ``generator/rest/<garment>.ply`` (each
garment on its subject's rest body, the shape that defines its rest edge lengths) and
``generator/stats/<sample>.json`` (drape statistics, summarised in ``dataset.json``
under ``report``).
"""

from __future__ import annotations

import json
import logging
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.skinning import lbs
from dressmeup.data.splits import split_by_garment
from dressmeup.data.synth.config import (
    GENERATOR_VERSION,
    SynthConfig,
    check_secret_support,
    synth_config,
)
from dressmeup.data.synth.drape import DrapeSettings, drape
from dressmeup.data.synth.dressing import garment_weights
from dressmeup.data.synth.garments import (
    BodyFrame,
    build_garment,
    garment_types,
    sample_params,
)
from dressmeup.data.synth.generator2 import VERSION, generate_2x
from dressmeup.data.synth.generator3 import VERSION as V3
from dressmeup.data.synth.generator3 import generate_3x
from dressmeup.data.synth.poses import pose_axis_angle, pose_names
from dressmeup.data.synth.quasistatic import DressSettings
from dressmeup.data.synth.stats import summarize_stats
from dressmeup.data.synth.texture import procedural_texture
from dressmeup.data.writer import DatasetWriter
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.mesh import save_mesh
from dressmeup.progress import progress

log = logging.getLogger(__name__)

# GENERATOR_VERSION 1.1.0: splits stratified by garment category (1.0.0: plain seeded
# shuffle); garments and drapes are unchanged
DEFAULT_EDGE_LENGTH = {"anny": 0.02, "procedural": 0.025}

def _skin(model) -> tuple[np.ndarray, np.ndarray]:
    """Vertex indices and faces (re-indexed) of the body model's skin."""
    return model.skin()


def plan_dataset(subjects: int, garments: int, poses: int, seed: int, types: Sequence[str],
                 model: Any = None, frame0: Any = None) -> dict[str, Any]:
    """Deterministic plan of generator 1.x: subject shapes and poses, garment types and
    parameters, without building anything (cheap; ``model`` and ``frame0`` are unused).

    Returns
    -------
    dict with ``subjects`` (id -> ``shape`` list, ``poses`` pose id -> pose name) and
    ``garments`` (id -> ``subject``, ``type``, ``category``, ``params``).
    """
    rng = np.random.default_rng(seed)
    names = pose_names()
    plan: dict[str, Any] = {"subjects": {}, "garments": {}}
    width = max(2, len(str(subjects * garments)))
    gcount = 0
    for si in range(subjects):
        sid = f"S{si + 1:02d}"
        shape = np.array([rng.uniform(0, 1), rng.uniform(0.3, 0.7), rng.uniform(0.3, 0.7),
                          rng.uniform(0.25, 0.75), rng.uniform(0.3, 0.7), rng.uniform(0.4, 0.6)])
        pick = rng.permutation(len(names))
        chosen = [names[pick[k % len(names)]] for k in range(poses)]
        plan["subjects"][sid] = {"shape": shape.round(6).tolist(), "poses": {
            f"P{k + 1}": chosen[k] for k in range(poses)}}
        tperm = rng.permutation(len(types))
        for k in range(garments):
            gcount += 1
            gid = f"G{gcount:0{width}d}"
            gtype = types[tperm[k % len(types)]]
            grng = np.random.default_rng([seed, si, k])
            params = {kk: (round(v, 6) if isinstance(v, float) else v)
                      for kk, v in sample_params(gtype, grng).items()}
            plan["garments"][gid] = {"subject": sid, "type": gtype,
                                     "category": garment_types()[gtype]["category"],
                                     "params": params}
    return plan


def generate_dataset(out: str | os.PathLike, config: SynthConfig | None = None, *,
                     workers: int = 1, executor: Any = None, **settings: Any) -> Path:
    """Generate (or resume) the synthetic dataset in ``out``.

    Parameters
    ----------
    out : output folder.
    config : the dataset's settings (:class:`~dressmeup.data.synth.config.SynthConfig`;
        default: its defaults, generator 1.1.0).
    workers : processes of generators 2.x and 3.x (the output does not depend on it).
    executor : a :mod:`dressmeup.executors` executor (e.g. Dask) running one job per garment
        for generators 2.x and 3.x instead of ``workers`` processes; same output.
    **settings : fields of ``SynthConfig`` replacing those of ``config``, e.g.
        ``generate_dataset(out, version="2.1.0", subjects=4, poses=3)``.

    ``version="3.0.0"`` runs generator 3.0.0 (:func:`dressmeup.data.synth.generator3.generate_3x`:
    the plan of 2.1.0, every garment dressed by simulation from its design body at rest);
    ``version="2.1.0"`` runs generator 2.1.0 (:func:`dressmeup.data.synth.generator2.generate_2x`:
    every garment worn by every subject, identical poses); ``"1.1.0"`` runs the generator
    below (the ``*-v2`` editions' data): each subject wears its own garments in jittered
    poses, splits by garment (stratified by category or random, recorded in
    ``dataset.json``), and it refuses a ``pose_set``, ``wear`` or ``scan_body`` other than
    the default. Which settings each version reads: ``SynthConfig``; a version that does not
    read ``secret`` and ``splits`` (:data:`~dressmeup.data.synth.config.SECRET_VERSIONS`)
    refuses a secret or fewer than every split before any work.

    Returns
    -------
    Path of the dataset root.
    """
    c = synth_config(config, **settings)
    check_secret_support(c)
    if str(c.version).startswith("3."):
        return _generate_3x(out, c, workers, executor)
    if c.dress:
        raise InputError("dress: settings of generator 3.x; this version does not read them")
    if str(c.version).startswith("2."):
        return _generate_2x(out, c, workers, executor)
    return _generate_1x(out, c)


def _generate_3x(out: str | os.PathLike, c: SynthConfig, workers: int, executor: Any) -> Path:
    """Generator 3.x with the settings it reads."""
    if c.version != V3:
        raise InputError(f"version: this toolkit generates 3.x as {V3}, got {c.version!r}")
    if (c.pose_set, c.wear) != ("generator", "all"):
        raise InputError(f"pose_set={c.pose_set!r}, wear={c.wear!r}: generator {V3} dresses "
                         "every garment on every subject in the generator poses")
    return generate_3x(out, subjects=c.subjects, poses=c.poses,
                       garments_per_split=c.garments_per_split or (6, 2, 4), seed=c.seed,
                       body_model=c.body_model, categories=c.categories,
                       edge_length=c.edge_length, write_scan=c.write_scan,
                       texture_size=c.texture_size,
                       dress_settings=DressSettings.from_dict(c.dress or {}),
                       workers=workers, executor=executor, scan_body=c.scan_body)


def _generate_2x(out: str | os.PathLike, c: SynthConfig, workers: int, executor: Any) -> Path:
    """Generator 2.x with the settings it reads."""
    if c.version != VERSION:
        retired = (" (2.0.0's drapes depended on the CPU's float32 rounding; "
                   "docs/synthetic-data.md, Reproducibility)" if c.version == "2.0.0" else "")
        raise InputError(f"version: this toolkit generates 2.x as {VERSION}, got "
                         f"{c.version!r}{retired}")
    return generate_2x(out, **arguments_2x(c), workers=workers,
                       **({"executor": executor} if executor is not None else {}))


def arguments_2x(c: SynthConfig) -> dict[str, Any]:
    """The keyword arguments of generator 2.x
    (:func:`~dressmeup.data.synth.generator2.generate_2x` and
    :func:`~dressmeup.data.synth.generator2.prepare_2x`) that config ``c`` sets."""
    return dict(subjects=c.subjects, poses=c.poses,
                garments_per_split=c.garments_per_split or (6, 2, 4), seed=c.seed,
                body_model=c.body_model, categories=c.categories, edge_length=c.edge_length,
                write_scan=c.write_scan, texture_size=c.texture_size, pose_steps=c.pose_steps,
                drape_settings=c.drape_settings, pose_set=c.pose_set, wear=c.wear,
                scan_body=c.scan_body)


def _generate_1x(out: str | os.PathLike, c: SynthConfig) -> Path:
    """Generator 1.1.0 (module docstring)."""
    version, subjects, garments, poses, seed = c.version, c.subjects, c.garments, c.poses, c.seed
    body_model, registration_noise, edge_length = c.body_model, c.registration_noise, c.edge_length
    write_scan, types, split_fractions = c.write_scan, c.types, c.split_fractions
    drape_settings, texture_size, split_strategy = c.drape_settings, c.texture_size, c.split_strategy
    pose_set, wear, scan_body = c.pose_set, c.wear, c.scan_body
    if version != GENERATOR_VERSION:
        raise InputError(f"version: expected {GENERATOR_VERSION!r}, '2.1.0' or '3.0.0', got "
                         f"{version!r}")
    if (pose_set, wear, scan_body) != ("generator", "all", "whole"):
        raise InputError(f"pose_set={pose_set!r}, wear={wear!r}, scan_body={scan_body!r}: "
                         f"generator {GENERATOR_VERSION} draws generator poses for every "
                         f"garment and writes whole-body scans; use version='2.1.0'")
    for v, n in ((subjects, "subjects"), (garments, "garments"), (poses, "poses")):
        if not isinstance(v, (int, np.integer)) or v < 1:
            raise InputError(f"{n}: expected a positive integer, got {v!r}")
    if poses < 2:
        log.warning("poses=1 gives no retargeting pairs")
    if registration_noise < 0:
        raise InputError(f"registration_noise: expected >= 0, got {registration_noise}")
    all_types = sorted(garment_types())
    types = sorted(types) if types else all_types
    bad = [t for t in types if t not in all_types]
    if bad:
        raise InputError(f"types: unknown {bad}; known {all_types}")
    edge = float(edge_length or DEFAULT_EDGE_LENGTH.get(body_model, 0.015))
    settings = drape_settings or DrapeSettings()
    t_start = time.perf_counter()
    model = get_body_model(body_model)
    keep, skin_F = _skin(model)
    names = tuple(model.joint_names)
    labels = np.array(names)[np.asarray(model.skinning_weights)[keep].argmax(1)]
    rest0 = model.posed(model.default_params())
    frame0 = BodyFrame.from_joints(rest0.rest_joints, names)
    plan = plan_dataset(subjects, garments, poses, seed, types, model, frame0)
    categories = {g: v["category"] for g, v in plan["garments"].items()}
    splits = split_by_garment(list(plan["garments"]), split_fractions, seed=seed,
                              categories=categories, strategy=split_strategy)
    params = {"subjects": subjects, "garments": garments, "poses": poses, "seed": seed,
              "body_model": body_model, "registration_noise": registration_noise,
              "edge_length": edge, "write_scan": write_scan, "types": types,
              "split_fractions": list(split_fractions), "split_strategy": split_strategy,
              "texture_size": texture_size,
              "drape": settings.to_dict()}
    info = {
        "name": "dressmeup-synthetic",
        "version": GENERATOR_VERSION,
        "licence": "CC0-1.0 (generated data; anny body model data is CC0)",
        "description": "Synthetic DressMeUp-style dataset: parametric garments draped by "
                       "skinning + quasi-static cloth relaxation on posed bodies.",
        "body_model": body_model,
        "categories": sorted({garment_types()[t]["category"] for t in types}),
        "citation": "dressmeup toolkit, synthetic generator " + GENERATOR_VERSION,
        "generator": {"name": "dressmeup.data.synth", "version": GENERATOR_VERSION,
                      "seed": seed, "params": params},
        "subjects": plan["subjects"],
        "garments": {g: {**v, "split": splits[g]} for g, v in plan["garments"].items()},
    }
    out = Path(out)
    writer = DatasetWriter(out, info)
    stats_dir = out / "generator" / "stats"
    todo = [(g, gi) for g, gi in plan["garments"].items()]
    jobs = [(g, f"P{k + 1}") for g, _ in todo for k in range(poses)]
    bar = progress(range(len(jobs)), desc="synth", total=len(jobs))
    body_cache: dict[str, Any] = {}
    for gid, g in todo:
        sid = g["subject"]
        sample_ids = [f"{sid}-{gid}-P{k + 1}" for k in range(poses)]
        if all(writer.has_sample(x) for x in sample_ids):
            for _ in sample_ids:
                next(bar, None)
            continue
        subj = plan["subjects"][sid]
        shape = np.asarray(subj["shape"])
        if sid not in body_cache:
            rest = model.posed(BodyParams(model=model.name, shape=shape,
                                          pose=np.zeros((len(names), 3)), gender=model.gender
                                          if hasattr(model, "gender") else "neutral"))
            body_cache = {sid: rest}
        rest = body_cache[sid]
        frame = BodyFrame.from_joints(rest.rest_joints, names)
        rest_V = rest.rest_vertices[keep]
        garment = build_garment(g["type"], g["params"], rest_V, skin_F, labels, frame,
                                edge_length=edge)
        W = garment_weights(garment, rest_V, skin_F, np.asarray(model.skinning_weights)[keep],
                             names, frame)

        save_mesh(out / "generator" / "rest" / f"{gid}.ply", garment.vertices, garment.faces,
                  uv=garment.uv, uv_faces=garment.uv_faces)
        tex, pattern = procedural_texture(np.random.default_rng([seed, 7919, int(gid[1:])]),
                                          texture_size)
        for k in range(poses):
            pid = f"P{k + 1}"
            sample_id = f"{sid}-{gid}-{pid}"
            next(bar, None)
            if writer.has_sample(sample_id):
                continue
            prng = np.random.default_rng([seed, int(sid[1:]), k, 1])
            pose = pose_axis_angle(subj["poses"][pid], names, frame, rng=prng)
            bp = BodyParams(model=model.name, shape=shape, pose=pose,
                            gender=getattr(model, "gender", "neutral"))
            posed = model.posed(bp)

            skinned = lbs(garment.vertices, W, posed.transforms)
            res = drape(garment.vertices, garment.faces, skinned, garment.support,
                        posed.vertices[keep], skin_F, frame.up, settings)
            stored = bp
            if registration_noise > 0:
                nrng = np.random.default_rng([seed, int(sid[1:]), k, 2])
                stored = BodyParams(
                    model=model.name, gender=bp.gender,
                    shape=np.clip(shape + nrng.normal(0, registration_noise, shape.shape), 0, 1),
                    pose=pose + nrng.normal(0, registration_noise, pose.shape))
            scan = None
            if write_scan:
                BV = posed.vertices
                scan = (np.vstack([BV, res.vertices]),
                        np.vstack([np.asarray(model.faces, np.int64), garment.faces + len(BV)]))
            # the stats file first: a sample is skipped on resume once its manifest row
            # exists, so everything else of the sample must be on disk before that row
            st = {**res.stats, "pose": subj["poses"][pid], "garment_type": g["type"],
                  "texture": pattern}
            atomic_write_text(stats_dir / f"{sample_id}.json", json.dumps(st, indent=1) + "\n")
            writer.add_sample(subject_id=sid, garment_id=gid, pose_id=pid,
                              category=garment.category, garment_type=garment.garment_type,
                              split=splits[gid],
                              garment=(res.vertices, garment.faces, garment.uv, garment.uv_faces),
                              body=stored, scan=scan, texture=tex)
    for _ in bar:
        pass
    report = summarize_stats(out, sample_ids=[r["sample_id"] for r in writer.rows])
    return writer.finalize(report=report,
                           timings={"last_run_s": round(time.perf_counter() - t_start, 2)})
