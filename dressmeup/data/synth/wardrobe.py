"""Generator 2.1.0: each garment is one pattern worn by several bodies (the v3 retargeting data).

A garment (one rest mesh: vertices, faces, UVs) is made around its *design* body, then
**fitted** to every subject of the dataset and draped in every pose:

1. **Subjects** come from a fixed table of phenotypes that spreads the body model's range
   (:data:`SUBJECTS`: gender, age, muscle, weight, height at their extremes; adults only,
   since the model's lowest ages are children). Subject ``k`` is ``SUBJECTS[k]``.
2. **Poses** are the same pose arrays for every subject: the first ``poses`` library poses
   of :data:`POSE_ORDER` (:mod:`dressmeup.data.synth.poses`) turned into axis-angle once, on
   the model's default body, without jitter. ``P1`` of one subject is exactly ``P1`` of
   another.
3. **Garments**: per category (topwear, bottomwear, dress), ``test + val + train``
   garments cycling through the category's types with parameters drawn per garment (seeded),
   so no two garments are alike. Garment ``k`` is designed on subject ``k mod subjects``.
4. **Fit**: each garment vertex moves by the body's shape displacement at its closest
   point on the design body (same body topology, so the same face and barycentric
   coordinates on the other body), then is relaxed in the rest pose with the garment's own rest edge lengths
   (:func:`dressmeup.data.synth.drape.drape`): a garment made for a slim body fitted to a heavy
   one stretches, one made for a heavy body stands off a slim one; a final projection keeps
   every vertex outside the body (it never sinks in).
5. **Drape per pose**: skinning weights transferred from the subject's rest body to the
   fitted garment, then a pose-continuation path (``pose_steps`` steps from the rest pose to
   the target pose; each step starts from the previous drape moved by the change of the
   skinned garment) so the cloth is carried over the thighs when sitting instead of being
   cut through by them; each step is a quasi-static relaxation with body collision and cloth
   self-collision.

Reproducibility: the numbers are computed in worker processes started with
:data:`CANONICAL_ENV` (one thread, the portable kernels of torch, MKL, OpenBLAS and numpy);
body vertices and LBS matrices are rounded (1e-9 m, 1e-12) before use; every closest body
face (fit, drape, displacement transfer) is chosen in float64 among the faces around
open3d's float32 pick (``closest_points(..., exact_faces=True)``, new in 2.1.0: 2.0.0 let
the float32 pick decide, and another CPU's rounding changed the drapes); and every stored
garment, body and scan vertex is rounded to 1e-6 m (one micrometre), so the data and their
manifest do not depend on the thread count, the CPU's vector extensions or its float32
rounding (see docs/synthetic-data.md, "Reproducibility"). They still depend on the CPU's
maker: two AMD EPYC machines write the pinned data, an Intel Xeon other data, and there
MKL's code branch (which torch calls for float64 matmuls and elementwise functions even
with its portable kernels) changes them; not fixed in 2.1.0.
"""

from __future__ import annotations

import json
import logging
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.body import BodyParams, get_body_model
from dressmeup.body.skinning import lbs
from dressmeup.data.synth.drape import DrapeSettings, drape
from dressmeup.data.synth.dressing import garment_weights
from dressmeup.data.synth.garments import BodyFrame, build_garment, sample_params
from dressmeup.data.synth.jobs import CANONICAL_ENV, canonical_numerics, init_worker
from dressmeup.data.synth.poses import pose_axis_angle, pose_names
from dressmeup.data.synth.scans import SCAN_BODY, clothed_scan
from dressmeup.data.synth.stats import summarize_stats
from dressmeup.data.synth.texture import procedural_texture
from dressmeup.data.writer import DatasetWriter
from dressmeup.executors import LocalExecutor, in_order
from dressmeup.geometry.mesh import edges, face_areas
from dressmeup.geometry.proximity import barycentric, closest_points
from dressmeup.geometry.winding import winding_number
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.mesh import save_mesh
from dressmeup.progress import progress

log = logging.getLogger(__name__)

VERSION = "2.1.0"
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
#: Pose order of generator 2.x (the first ``poses`` are used): legs and arms alternate so
#: that even two or three poses load both (sitting is the hardest for skirts and dresses).
POSE_ORDER = ("sitting", "arms-raised", "walking", "one-arm-up", "bent-knees", "arms-forward",
              "twist-side", "bent-elbows", "a-pose", "arms-down")
#: pose sets of the library a plan may draw from (:func:`dressmeup.data.synth.poses.pose_names`)
POSE_SETS = ("generator", "registration", "registration-tuning", "all")
#: who wears what (:func:`plan_v3`): every garment on everyone, or one garment per sample
WEAR_MODES = ("all", "rotate")
DEFAULT_EDGE_LENGTH = {"anny": 0.02, "procedural": 0.025}
BODY_DECIMALS = 9  # body vertices, metres
TRANSFORM_DECIMALS = 12  # LBS matrices
STORE_DECIMALS = 6  # stored vertices, metres (1 micrometre)
POSE_DECIMALS = 9  # stored pose arrays (body.npz), radians


def v3_drape_settings() -> DrapeSettings:
    """Drape settings of generator 2.x: 1.x's material, cloth self-collision on, and a
    3 mm final clearance (1 mm let 20 mm triangles of a garment stretched over a heavier body
    cut into its curved surface between their vertices)."""
    return DrapeSettings(self_stiffness=2.0e5, self_thickness=0.010, margin=0.006,
                         clearance=0.003)


@dataclass
class Body:
    """One subject's rest body: skin vertices ``(n, 3)``, frame, and its phenotype."""

    sid: str
    shape: np.ndarray
    rest_V: np.ndarray
    frame: BodyFrame


def quantize(a: np.ndarray, decimals: int) -> np.ndarray:
    """``a`` as float64 rounded to ``decimals`` decimals (metres), without negative zeros."""
    return np.round(np.asarray(a, np.float64), decimals) + 0.0  # + 0.0: no negative zeros


def plan_v3(subjects: int, poses: int, garments_per_split: tuple[int, int, int], seed: int,
            categories: list[str] | None = None, pose_set: str = "generator",
            wear: str = "all") -> dict[str, Any]:
    """Deterministic plan: subjects, pose names, garments (type, parameters, split, designer).

    Parameters
    ----------
    subjects : number of subjects (1 .. len(SUBJECTS)).
    poses : number of poses (1 .. size of the pose set), the same for every subject.
    garments_per_split : (train, val, test) garments per category.
    seed : random seed (garment parameters, textures).
    categories : categories to make (default all of :data:`CATEGORY_TYPES`).
    pose_set : library pose set the poses come from (:data:`POSE_SETS`): ``"generator"``
        (default), ``"registration"`` (the registration benchmark's hard poses),
        ``"registration-tuning"`` (bent and raised-knee poses for choosing registration
        defaults) or ``"all"``;
        generator poses come in the order :data:`POSE_ORDER`, the others in library order.
    wear : ``"all"`` (default: every garment on every subject in every pose) or
        ``"rotate"``: each (subject, pose) wears one garment, subject ``i`` in pose ``k``
        garment ``(i + k) mod n_garments`` of the categories taken in turns (the first
        garment of each category, then the second, ...), listed per garment under
        ``"wearers"``: with as many garments as poses every subject wears each garment
        once, and (with as many garments in every category) any ``n_categories``
        consecutive subjects in one pose wear every category.
    """
    if pose_set not in POSE_SETS:
        raise ValueError(f"pose_set: expected one of {POSE_SETS}, got {pose_set!r}")
    if wear not in WEAR_MODES:
        raise ValueError(f"wear: expected one of {WEAR_MODES}, got {wear!r}")
    names = pose_names(pose_set)
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
    # generator poses in POSE_ORDER, then the others (the registration sets) in library order
    order = [n for n in POSE_ORDER if n in names] + [n for n in names if n not in POSE_ORDER]
    plan: dict[str, Any] = {
        "subjects": {f"S{i + 1:02d}": {"name": SUBJECTS[i][0], "shape": list(SUBJECTS[i][1])}
                     for i in range(subjects)},
        "poses": {f"P{k + 1}": order[k] for k in range(poses)},
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
    if wear == "rotate":
        pids = list(plan["poses"])
        nth: dict[str, int] = {}  # rank of a garment within its category
        seen: dict[str, int] = {}
        for gid, g in plan["garments"].items():
            nth[gid] = seen.get(g["category"], 0)
            seen[g["category"]] = nth[gid] + 1
        gids = sorted(plan["garments"], key=lambda gid: (nth[gid], gid))
        for gid in gids:
            plan["garments"][gid]["wearers"] = []
        for i, sid in enumerate(sids):
            for k, pid in enumerate(pids):
                plan["garments"][gids[(i + k) % len(gids)]]["wearers"].append([sid, pid])
        idle = [gid for gid in gids if not plan["garments"][gid]["wearers"]]
        if idle:
            raise ValueError(f"wear='rotate': garments {idle} are worn by no (subject, pose): "
                             f"{len(gids)} garments for {len(sids) * len(pids)} samples")
    return plan


def wearers(plan: dict[str, Any], gid: str) -> list[tuple[str, str]]:
    """The (subject id, pose id) samples garment ``gid`` of ``plan`` is draped in."""
    g = plan["garments"][gid]
    if "wearers" in g:
        return [(s, p) for s, p in g["wearers"]]
    return [(s, p) for s in plan["subjects"] for p in plan["poses"]]


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


def drape_stats(V: np.ndarray, F: np.ndarray, rest_V: np.ndarray, body_V: np.ndarray,
                body_F: np.ndarray) -> dict[str, float]:
    """Plausibility figures of one draped garment (the simulator comparison's criteria).

    Returns
    -------
    dict: ``deepest_mm`` (deepest vertex inside the body, >= 0), ``inside_area_pct`` (share of
    the garment's area whose face centroid is inside the body, by the winding number),
    ``strain_mean`` / ``strain_p99`` (|l / L - 1| over edges), ``self_intersecting_faces``
    (pymeshlab).
    """
    # heavy: pymeshlab (~0.3 s to import)
    import pymeshlab

    d, _, _ = closest_points(body_V, body_F, V, exact_faces=True)
    inside = winding_number(body_V, body_F, V) > 0.5
    area = face_areas(V, F)
    inside_f = winding_number(body_V, body_F, V[F].mean(1)) > 0.5
    E = edges(F)
    L = np.linalg.norm(rest_V[E[:, 1]] - rest_V[E[:, 0]], axis=1)
    le = np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1)
    strain = np.abs(le / L - 1.0)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.asarray(V, np.float64), np.asarray(F, np.int32)))
    ms.compute_selection_by_self_intersections_per_face()
    return {"deepest_mm": float(d[inside].max() * 1000) if inside.any() else 0.0,
            "inside_area_pct": float(area[inside_f].sum() / area.sum() * 100),
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


#: generator parameters recorded in ``dataset.json`` only when they differ from these
#: defaults (added after the first pinned 2.0.0 datasets, whose bytes must not change)
OPTIONAL_PARAMS = {"pose_set": "generator", "wear": "all", "scan_body": "whole"}


def generator_params(**params: Any) -> dict[str, Any]:
    """``dataset.json``'s generator parameters: ``version`` first, then ``params`` in the
    given order, leaving out :data:`OPTIONAL_PARAMS` that have their default value."""
    return {"version": VERSION, **{k: v for k, v in params.items()
                                   if k not in OPTIONAL_PARAMS or v != OPTIONAL_PARAMS[k]}}


def generate_v3(out: str | os.PathLike, subjects: int = 4, poses: int = 4,
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
    subjects : subjects 1..6 (rows of :data:`SUBJECTS`); every garment is worn by each.
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
    drape_settings : material and solver settings (default :func:`v3_drape_settings`).
    workers : processes computing garments in parallel (one thread each; at least one is
        always started, see :data:`CANONICAL_ENV`); the files and the manifest are the same for
        any number (this process writes them in plan order).
    executor : instead, a :mod:`dressmeup.executors` executor running one job per garment
        (:class:`GarmentJob`): a Dask one starts its workers with :data:`CANONICAL_ENV`; a
        ``LocalExecutor`` means the spawned pool above with its number of workers.
    pose_set : library pose set the poses come from (``"generator"``, ``"registration"``,
        ``"registration-tuning"``, ``"all"``; see :func:`plan_v3`).
    wear : ``"all"`` (every garment on every subject in every pose) or ``"rotate"`` (one
        garment per subject and pose, rotating; see :func:`plan_v3`).
    scan_body : ``"whole"`` (the entire body mesh in ``scan.ply``, also under the garment) or
        ``"uncovered"`` (the body faces under the garment left out, as a scanner sees a
        clothed person; :mod:`dressmeup.data.synth.scans`).
    These three are recorded in ``dataset.json``'s generator parameters only when not the default,
    so datasets made before they existed keep their bytes and manifest.

    Returns
    -------
    Path of the dataset root.
    """

    plan, info, setup = prepare_v3(
        subjects=subjects, poses=poses, garments_per_split=garments_per_split, seed=seed,
        body_model=body_model, categories=categories, edge_length=edge_length,
        write_scan=write_scan, texture_size=texture_size, pose_steps=pose_steps,
        drape_settings=drape_settings, pose_set=pose_set, wear=wear, scan_body=scan_body)
    return write_plan(out, info, plan, _garment_job, setup, workers, executor, "synth v3",
                      summarize_stats)


def prepare_v3(subjects: int = 4, poses: int = 4,
               garments_per_split: tuple[int, int, int] | list[int] = (6, 2, 4), seed: int = 0,
               body_model: str = "anny", categories: list[str] | None = None,
               edge_length: float | None = None, write_scan: bool = True,
               texture_size: int = 256, pose_steps: int = 3,
               drape_settings: DrapeSettings | None = None, pose_set: str = "generator",
               wear: str = "all", scan_body: str = "whole"
               ) -> tuple[dict[str, Any], dict[str, Any], tuple]:
    """What :func:`generate_v3` computes before any garment (arguments as there): the plan,
    the ``dataset.json`` record and the argument tuple of :func:`_setup` that every worker
    runs once. Nothing is written; bad arguments raise ``ValueError``."""
    gps = tuple(int(x) for x in garments_per_split)
    if len(gps) != 3:
        raise ValueError(f"garments_per_split: expected (train, val, test), got {gps!r}")
    if scan_body not in SCAN_BODY:  # before anything is written
        raise ValueError(f"scan_body: expected one of {SCAN_BODY}, got {scan_body!r}")
    plan = plan_v3(subjects, poses, gps, seed, categories, pose_set=pose_set, wear=wear)
    edge = float(edge_length or DEFAULT_EDGE_LENGTH.get(body_model, 0.02))
    settings = drape_settings or v3_drape_settings()
    params = generator_params(subjects=subjects, poses=poses, garments_per_split=list(gps),
                              seed=seed, body_model=body_model,
                              categories=list(categories or CATEGORY_TYPES), edge_length=edge,
                              write_scan=write_scan, texture_size=texture_size,
                              pose_steps=pose_steps, drape=settings.to_dict(),
                              pose_set=pose_set, wear=wear, scan_body=scan_body)
    info = dataset_info(VERSION, f"Synthetic DressMeUp-style dataset, generator {VERSION}: each "
                        "parametric garment is fitted to several bodies of different shape and "
                        "draped in identical poses (quasi-static cloth relaxation with body and "
                        "self collision along a pose path).", body_model, plan, seed, params)
    setup = (body_model, plan, edge, settings, pose_steps, seed, texture_size, write_scan,
             scan_body)
    return plan, info, setup


def dataset_info(version: str, description: str, body_model: str, plan: dict[str, Any],
                 seed: int, params: dict[str, Any]) -> dict[str, Any]:
    """The ``dataset.json`` record of a generator-2.x or -3.x dataset (keys in written order)."""
    return {
        "name": "dressmeup-synthetic",
        "version": version,
        "licence": "CC0-1.0 (generated data; anny body model data is CC0)",
        "description": description,
        "body_model": body_model,
        "categories": sorted({g["category"] for g in plan["garments"].values()}),
        "citation": "dressmeup toolkit, synthetic generator " + version,
        "generator": {"name": "dressmeup.data.synth", "version": version, "seed": seed,
                      "params": params},
        "subjects": plan["subjects"],
        "poses": plan["poses"],
        "garments": plan["garments"],
    }


def write_plan(out: str | os.PathLike, info: dict[str, Any], plan: dict[str, Any],
               job_fn: Any, setup: tuple, workers: int, executor: Any, desc: str,
               report_fn: Any) -> Path:
    """Compute with ``job_fn`` and write every sample of ``plan`` not yet in ``out`` (test
    garments first, so a long run gives the benchmark's data first; then train, then val),
    then finalize the dataset with ``report_fn(out)`` as its report.

    ``setup`` is the argument tuple of :func:`_setup` every worker runs once; ``workers`` /
    ``executor`` as in :func:`generate_v3` (a ``LocalExecutor`` means a spawned pool of its
    size). Returns the dataset root.
    """
    t_start, cpu_start = time.perf_counter(), time.process_time()
    out = Path(out)
    writer = DatasetWriter(out, info)
    total = sum(len(wearers(plan, gid)) for gid in plan["garments"])
    bar = progress(range(total), desc=desc, total=total)
    todo = []
    rank = {"test": 0, "train": 1, "val": 2}
    for gid, g in sorted(plan["garments"].items(), key=lambda kv: (rank[kv[1]["split"]], kv[0])):
        worn = wearers(plan, gid)
        missing = [(s, p) for s, p in worn if not writer.has_sample(f"{s}-{gid}-{p}")]
        for _ in range(len(worn) - len(missing)):
            next(bar, None)
        if missing:
            todo.append((gid, g, missing))
    if isinstance(executor, LocalExecutor):
        # its one-worker mode runs jobs in THIS process, whose libraries did not load with
        # CANONICAL_ENV: the spawned pool (same size) always starts fresh workers
        workers, executor = executor.workers, None
    _run_garment_jobs(job_fn, setup, todo, writer, out, bar, workers, executor)
    for _ in bar:
        pass
    return writer.finalize(report=report_fn(out), timings={
        "last_run_s": round(time.perf_counter() - t_start, 2),
        "last_run_main_cpu_s": round(time.process_time() - cpu_start, 2), "workers": workers})


def _run_garment_jobs(job_fn: Any, setup: tuple, todo: list, writer: Any, out: Path, bar: Any,
                      workers: int, executor: Any) -> None:
    """Compute the garments of ``todo`` with ``job_fn`` (a module-level function of one
    garment's job, run after :func:`_setup` of ``setup``) and write them here, in plan order.

    The numbers are computed in fresh worker processes whose libraries load with the
    canonical numerics (:data:`CANONICAL_ENV`): ``executor``'s (a Dask cluster's workers
    start with them) or, without one, a spawned pool of ``workers`` processes; this process
    only writes.
    """
    if not todo:
        return
    if executor is not None:
        _run_on(executor, setup, todo, writer, out, bar, job_fn)
        return
    ctx = multiprocessing.get_context("spawn")
    with canonical_numerics(), ProcessPoolExecutor(
            max(1, min(workers, len(todo))), mp_context=ctx, initializer=_init_worker,
            initargs=(os.getpid(), *setup)) as pool:
        for res in pool.map(job_fn, todo):
            _write_garment(writer, out, res, bar)


#: per-process state of the garment jobs (body model, subjects, poses), set by :func:`_setup`
_STATE: dict[str, Any] = {}


def _setup(body_model, plan, edge, settings, pose_steps, seed, texture_size, write_scan,
           scan_body="whole"):
    """Load the body model, the subjects' rest bodies and the pose arrays (once a process)."""
    key = json.dumps([body_model, plan, edge, settings.to_dict(), pose_steps, seed,
                      texture_size, write_scan, scan_body], sort_keys=True, default=str)
    if _STATE.get("key") == key:
        return
    model = get_body_model(body_model)
    keep, skin_F = model.skin()
    names = tuple(model.joint_names)
    body_W = np.asarray(model.skinning_weights)[keep]
    frame0 = BodyFrame.from_joints(model.posed(model.default_params()).rest_joints, names)
    bodies = {}
    for sid, s in plan["subjects"].items():
        shape = np.asarray(s["shape"], np.float64)
        rest = model.posed(BodyParams(model=model.name, shape=shape,
                                      pose=np.zeros((len(names), 3))))
        bodies[sid] = Body(sid, shape, quantize(rest.rest_vertices[keep], BODY_DECIMALS),
                           BodyFrame.from_joints(quantize(rest.rest_joints, BODY_DECIMALS), names))
    _STATE.clear()
    _STATE.update(key=key, model=model, keep=keep, skin_F=skin_F, names=names, body_W=body_W,
                  labels=np.array(names)[body_W.argmax(1)], bodies=bodies,
                  poses={pid: pose_axis_angle(name, names, frame0, rng=None)
                         for pid, name in plan["poses"].items()},
                  edge=edge, settings=settings, pose_steps=pose_steps, seed=seed,
                  texture_size=texture_size, write_scan=write_scan, scan_body=scan_body)


class GarmentJob:
    """One garment's job for an executor (:mod:`dressmeup.executors`):
    ``GarmentJob(setup)(job) -> result of _garment_job(job)``; the worker sets up its state
    once (:func:`_setup`, cached by its key) and holds torch and BLAS at one thread."""

    __name__ = "synth_garment"

    def __init__(self, setup: tuple, job_fn: Any = None) -> None:
        self.setup = setup
        self.job_fn = job_fn or _garment_job

    def __call__(self, job) -> dict[str, Any]:
        # heavy: torch (~1.1 s to import)
        import torch

        torch.set_num_threads(1)
        _setup(*self.setup)
        return self.job_fn(job)


def _run_on(executor: Any, setup: tuple, todo: list, writer: Any, out: Path, bar: Any,
            job_fn: Any = None) -> None:
    """Compute the garments of ``todo`` on ``executor`` (one job per garment; a Dask cluster's
    workers start with :data:`CANONICAL_ENV`) and write them here, in plan order."""

    if hasattr(executor, "worker_env"):  # Dask: the numerics are set at worker start
        executor.worker_env = {**CANONICAL_ENV, **executor.worker_env}
        if getattr(executor, "_client", None) is not None:
            executor.check_worker_env()
    with canonical_numerics():  # inherited by local pool workers started inside
        for _i, res in in_order(executor.run(GarmentJob(setup, job_fn), todo)):
            if isinstance(res, BaseException):
                raise res
            _write_garment(writer, out, res, bar)


def _init_worker(parent_pid: int, *setup) -> None:
    init_worker(parent_pid)
    _setup(*setup)


def _garment_job(job) -> dict[str, Any]:
    """Build one garment on its design body, fit it to the subjects, drape the missing
    samples; returns every array to write (computed in a worker or in the main process)."""

    gid, g, missing = job
    S = _STATE
    t_cpu = time.process_time()
    model, skin_F, bodies = S["model"], S["skin_F"], S["bodies"]
    design = bodies[g["design_subject"]]
    garment = build_garment(g["type"], g["params"], design.rest_V, skin_F, S["labels"],
                            design.frame, edge_length=S["edge"])
    V0, F = quantize(garment.vertices, STORE_DECIMALS), garment.faces
    tex, pattern = procedural_texture(np.random.default_rng([S["seed"], 7919, int(gid[1:])]),
                                      S["texture_size"])
    res: dict[str, Any] = {"gid": gid, "g": g, "V0": V0, "F": F, "uv": garment.uv,
                           "uv_faces": garment.uv_faces, "category": garment.category,
                           "garment_type": garment.garment_type, "tex": tex, "fitted": {},
                           "samples": [], "build_cpu_s": time.process_time() - t_cpu}
    for sid in dict.fromkeys(s for s, _ in missing):
        body = bodies[sid]
        t_fit = time.process_time()
        if sid == design.sid:
            fitted, fit_stats = V0, {"fit": "design body"}
        else:
            start = transfer_to_body(V0, design.rest_V, body.rest_V, skin_F)
            fit = drape(V0, F, start, garment.support, body.rest_V, skin_F, body.frame.up,
                        S["settings"], exact_faces=True)
            fitted = quantize(fit.vertices, STORE_DECIMALS)
            fit_stats = {"fit": "fitted", **{f"fit_{k}": v for k, v in fit.stats.items()}}
        res["fitted"][sid] = fitted
        W = garment_weights(FittedGarment(fitted, F, garment.garment_type), body.rest_V, skin_F,
                             S["body_W"], S["names"], body.frame)
        draper = PoseDraper(model, S["keep"], skin_F, V0, F, garment.support, fitted, W,
                            body.shape, S["settings"], S["pose_steps"])
        fit_stats["fit_cpu_s"] = time.process_time() - t_fit
        for pid in [p for s, p in missing if s == sid]:
            t0 = time.process_time()
            pose = S["poses"][pid]
            out, body_V = draper(pose, body.frame.up)
            Vd = quantize(out.vertices, STORE_DECIMALS)
            scan = None
            if S["write_scan"]:
                BV = quantize(model.posed(BodyParams(model=model.name, shape=body.shape,
                                               pose=pose)).vertices, STORE_DECIMALS)
                scan = clothed_scan(BV, model.faces, Vd, F, S["scan_body"])
            drape_cpu = time.process_time() - t0
            st = {**out.stats, **drape_stats(Vd, F, V0, body_V, skin_F), **fit_stats,
                  "pose": pid, "garment_type": g["type"],
                  "texture": pattern, "subject": sid, "design_subject": design.sid,
                  "drape_cpu_s": drape_cpu}
            res["samples"].append({"sid": sid, "pid": pid, "V": Vd, "scan": scan,
                                   "shape": body.shape, "pose": pose, "stats": st,
                                   "model": model.name})
    return res


def _write_garment(writer, out: Path, res: dict[str, Any], bar) -> None:
    """Write one garment's files (rest, fitted, stats, then each sample) in plan order."""

    gid, g, F = res["gid"], res["g"], res["F"]
    save_mesh(out / "generator" / "rest" / f"{gid}.ply", res["V0"], F, uv=res["uv"],
              uv_faces=res["uv_faces"])
    for sid, fitted in res["fitted"].items():
        save_mesh(out / "generator" / "fitted" / f"{gid}-{sid}.ply", fitted, F)
    for smp in res["samples"]:
        sid, pid = smp["sid"], smp["pid"]
        sample_id = f"{sid}-{gid}-{pid}"
        next(bar, None)
        # the stats before the manifest row (a resumed run skips samples in the manifest)
        atomic_write_text(out / "generator" / "stats" / f"{sample_id}.json",
                          json.dumps(smp["stats"], indent=1, sort_keys=True) + "\n")
        writer.add_sample(subject_id=sid, garment_id=gid, pose_id=pid,
                          category=res["category"], garment_type=res["garment_type"],
                          split=g["split"], garment=(smp["V"], F, res["uv"], res["uv_faces"]),
                          # the pose arrays carry anny's float noise (its per-machine first
                          # build): stored rounded to 1e-9 rad, like the stored coordinates
                          body=BodyParams(model=smp["model"], shape=smp["shape"],
                                          pose=quantize(smp["pose"], POSE_DECIMALS)),
                          scan=smp["scan"], texture=res["tex"])


@dataclass
class FittedGarment:
    """A fitted garment for :func:`garment_weights`: vertices ``(n, 3)``, faces, type."""

    vertices: np.ndarray
    faces: np.ndarray
    garment_type: str
