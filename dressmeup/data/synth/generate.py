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
from dataclasses import dataclass
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
    workers : processes of generators 2.x, 3.x and 4.x (the output does not depend on it).
    executor : a :mod:`dressmeup.executors` executor (e.g. Dask) running one job per garment
        for generators 2.x and 3.x, per target for 4.x, instead of ``workers`` processes;
        same output.
    **settings : fields of ``SynthConfig`` replacing those of ``config``, e.g.
        ``generate_dataset(out, version="2.1.0", subjects=4, poses=3)``.

    ``version="4.0.0"`` runs generator 4.0.0 (:func:`dressmeup.data.synth.dataset4.generate_gen4`:
    sampled bodies, poses and garments, each sample the end of a defined motion simulated in
    time; the test split seeded by ``secret``); ``version="3.0.0"`` runs generator 3.0.0
    (:func:`dressmeup.data.synth.generator3.generate_3x`:
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
    if str(c.version).startswith("4."):
        return _generate_4x(out, c, workers, executor)
    if c.plan or c.motion or c.dynamics:
        raise InputError("plan, motion, dynamics: settings of generator 4.x; this version does "
                         "not read them")
    if str(c.version).startswith("3."):
        return _generate_3x(out, c, workers, executor)
    if c.dress:
        raise InputError("dress: settings of generator 3.x; this version does not read them")
    if str(c.version).startswith("2."):
        return _generate_2x(out, c, workers, executor)
    return _generate_1x(out, c)


def _generate_4x(out: str | os.PathLike, c: SynthConfig, workers: int, executor: Any) -> Path:
    """Generator 4.x with the settings it reads."""
    # heavy: ipctk (generator 4's contact model)
    from dressmeup.data.synth.dataset4 import generate_gen4
    from dressmeup.data.synth.generator4 import VERSION as V4

    if c.version != V4:
        raise InputError(f"version: this toolkit generates 4.x as {V4}, got {c.version!r}")
    ignored = [n for n, v, d in (("dress", c.dress, None), ("drape_settings", c.drape_settings,
                                                            None),
                                 ("pose_set", c.pose_set, "generator"), ("wear", c.wear, "all"))
               if v != d]
    if ignored:
        raise InputError(f"{', '.join(ignored)}: not read by generator {V4} (its plan draws "
                         "bodies, poses and targets; see SynthConfig)")
    return generate_gen4(out, c, workers, executor)


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
    types = _check_1x(c)
    edge = float(c.edge_length or DEFAULT_EDGE_LENGTH.get(c.body_model, 0.015))
    settings = c.drape_settings or DrapeSettings()
    t_start = time.perf_counter()
    model = get_body_model(c.body_model)
    keep, skin_F = _skin(model)
    names = tuple(model.joint_names)
    labels = np.array(names)[np.asarray(model.skinning_weights)[keep].argmax(1)]
    rest0 = model.posed(model.default_params())
    frame0 = BodyFrame.from_joints(rest0.rest_joints, names)
    plan = plan_dataset(c.subjects, c.garments, c.poses, c.seed, types, model, frame0)
    categories = {g: v["category"] for g, v in plan["garments"].items()}
    splits = split_by_garment(list(plan["garments"]), c.split_fractions, seed=c.seed,
                              categories=categories, strategy=c.split_strategy)
    out = Path(out)
    run = _Run1x(c=c, model=model, keep=keep, skin_F=skin_F, names=names, labels=labels,
                 edge=edge, settings=settings, splits=splits, out=out,
                 writer=DatasetWriter(out, _info_1x(c, plan, splits, types, edge, settings)))
    n_samples = len(plan["garments"]) * c.poses
    bar = progress(range(n_samples), desc="synth", total=n_samples)
    body_cache: dict[str, Any] = {}
    for gid, g in plan["garments"].items():
        sid = g["subject"]
        sample_ids = [f"{sid}-{gid}-P{k + 1}" for k in range(c.poses)]
        if all(run.writer.has_sample(x) for x in sample_ids):
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
        run.garment(gid, g, subj, shape, body_cache[sid], bar)
    for _ in bar:
        pass
    report = summarize_stats(out, sample_ids=[r["sample_id"] for r in run.writer.rows])
    return run.writer.finalize(report=report,
                               timings={"last_run_s": round(time.perf_counter() - t_start, 2)})


def _check_1x(c: SynthConfig) -> list[str]:
    """The settings of generator 1.1.0 checked (``InputError``); the garment types to make."""
    if c.version != GENERATOR_VERSION:
        raise InputError(f"version: expected {GENERATOR_VERSION!r}, '2.1.0' or '3.0.0', got "
                         f"{c.version!r}")
    if (c.pose_set, c.wear, c.scan_body) != ("generator", "all", "whole"):
        raise InputError(f"pose_set={c.pose_set!r}, wear={c.wear!r}, "
                         f"scan_body={c.scan_body!r}: generator {GENERATOR_VERSION} draws "
                         f"generator poses for every garment and writes whole-body scans; use "
                         f"version='2.1.0'")
    for v, n in ((c.subjects, "subjects"), (c.garments, "garments"), (c.poses, "poses")):
        if not isinstance(v, (int, np.integer)) or v < 1:
            raise InputError(f"{n}: expected a positive integer, got {v!r}")
    if c.poses < 2:
        log.warning("poses=1 gives no retargeting pairs")
    if c.registration_noise < 0:
        raise InputError(f"registration_noise: expected >= 0, got {c.registration_noise}")
    all_types = sorted(garment_types())
    types = sorted(c.types) if c.types else all_types
    bad = [t for t in types if t not in all_types]
    if bad:
        raise InputError(f"types: unknown {bad}; known {all_types}")
    return types


def _info_1x(c: SynthConfig, plan: dict[str, Any], splits: dict[str, str], types: list[str],
             edge: float, settings: DrapeSettings) -> dict[str, Any]:
    """The ``dataset.json`` record of a generator-1.1.0 dataset (keys in written order)."""
    params = {"subjects": c.subjects, "garments": c.garments, "poses": c.poses, "seed": c.seed,
              "body_model": c.body_model, "registration_noise": c.registration_noise,
              "edge_length": edge, "write_scan": c.write_scan, "types": types,
              "split_fractions": list(c.split_fractions), "split_strategy": c.split_strategy,
              "texture_size": c.texture_size,
              "drape": settings.to_dict()}
    return {
        "name": "dressmeup-synthetic",
        "version": GENERATOR_VERSION,
        "licence": "CC0-1.0 (generated data; anny body model data is CC0)",
        "description": "Synthetic DressMeUp-style dataset: parametric garments draped by "
                       "skinning + quasi-static cloth relaxation on posed bodies.",
        "body_model": c.body_model,
        "categories": sorted({garment_types()[t]["category"] for t in types}),
        "citation": "dressmeup toolkit, synthetic generator " + GENERATOR_VERSION,
        "generator": {"name": "dressmeup.data.synth", "version": GENERATOR_VERSION,
                      "seed": c.seed, "params": params},
        "subjects": plan["subjects"],
        "garments": {g: {**v, "split": splits[g]} for g, v in plan["garments"].items()},
    }


@dataclass
class _Run1x:
    """One run of generator 1.1.0: its settings, the body model's skin and the writer."""

    c: SynthConfig
    model: Any
    keep: np.ndarray  # skin vertex indices
    skin_F: np.ndarray
    names: tuple[str, ...]  # joint names
    labels: np.ndarray  # dominant joint of each skin vertex
    edge: float
    settings: DrapeSettings
    splits: dict[str, str]
    writer: DatasetWriter
    out: Path

    def garment(self, gid: str, g: dict[str, Any], subj: dict[str, Any], shape: np.ndarray,
                rest: Any, bar: Any) -> None:
        """Build garment ``gid`` on its subject's ``rest`` body, write it and its missing
        samples."""
        keep, skin_F, names = self.keep, self.skin_F, self.names
        frame = BodyFrame.from_joints(rest.rest_joints, names)
        rest_V = rest.rest_vertices[keep]
        garment = build_garment(g["type"], g["params"], rest_V, skin_F, self.labels, frame,
                                edge_length=self.edge)
        W = garment_weights(garment, rest_V, skin_F,
                             np.asarray(self.model.skinning_weights)[keep], names, frame)

        save_mesh(self.out / "generator" / "rest" / f"{gid}.ply", garment.vertices,
                  garment.faces, uv=garment.uv, uv_faces=garment.uv_faces)
        tex, pattern = procedural_texture(np.random.default_rng([self.c.seed, 7919,
                                                                 int(gid[1:])]),
                                          self.c.texture_size)
        for k in range(self.c.poses):
            next(bar, None)
            if self.writer.has_sample(f"{g['subject']}-{gid}-P{k + 1}"):
                continue
            self.sample(gid, g, subj, shape, frame, garment, W, (tex, pattern), k)

    def sample(self, gid: str, g: dict[str, Any], subj: dict[str, Any], shape: np.ndarray,
               frame: BodyFrame, garment: Any, W: np.ndarray, texture: tuple[np.ndarray, str],
               k: int) -> None:
        """Drape ``garment`` (skinning weights ``W``) on its subject in pose ``k`` and write
        the sample."""
        c, model, sid, pid = self.c, self.model, g["subject"], f"P{k + 1}"
        prng = np.random.default_rng([c.seed, int(sid[1:]), k, 1])
        pose = pose_axis_angle(subj["poses"][pid], self.names, frame, rng=prng)
        bp = BodyParams(model=model.name, shape=shape, pose=pose,
                        gender=getattr(model, "gender", "neutral"))
        posed = model.posed(bp)

        skinned = lbs(garment.vertices, W, posed.transforms)
        res = drape(garment.vertices, garment.faces, skinned, garment.support,
                    posed.vertices[self.keep], self.skin_F, frame.up, self.settings)
        stored = bp
        if c.registration_noise > 0:
            nrng = np.random.default_rng([c.seed, int(sid[1:]), k, 2])
            stored = BodyParams(
                model=model.name, gender=bp.gender,
                shape=np.clip(shape + nrng.normal(0, c.registration_noise, shape.shape), 0, 1),
                pose=pose + nrng.normal(0, c.registration_noise, pose.shape))
        scan = None
        if c.write_scan:
            BV = posed.vertices
            scan = (np.vstack([BV, res.vertices]),
                    np.vstack([np.asarray(model.faces, np.int64), garment.faces + len(BV)]))
        # the stats file first: a sample is skipped on resume once its manifest row
        # exists, so everything else of the sample must be on disk before that row
        st = {**res.stats, "pose": subj["poses"][pid], "garment_type": g["type"],
              "texture": texture[1]}
        atomic_write_text(self.out / "generator" / "stats" / f"{sid}-{gid}-{pid}.json",
                          json.dumps(st, indent=1) + "\n")
        self.writer.add_sample(subject_id=sid, garment_id=gid, pose_id=pid,
                               category=garment.category, garment_type=garment.garment_type,
                               split=self.splits[gid],
                               garment=(res.vertices, garment.faces, garment.uv,
                                        garment.uv_faces),
                               body=stored, scan=scan, texture=texture[0])
