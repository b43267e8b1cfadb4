"""What the synthetic generators 2.x, 3.x and 4 share: stored precision, the plan, the
subjects' bodies, the dataset record, the plausibility figures and the writer.

- **Precision**: bodies are rounded to 1e-9 m before use (:data:`BODY_DECIMALS`) and every
  stored vertex to 1e-6 m (:data:`STORE_DECIMALS`, :func:`quantize`), so the data do not
  depend on the last bits of a machine's float arithmetic (docs/synthetic-data.md,
  "Reproducibility").
- **Plan** of generators 2.x and 3.x (:func:`plan_2x`): the subject table :data:`SUBJECTS`,
  the same pose arrays for every subject, garments per category and split, each designed on
  one subject; :func:`wearers` says who wears a garment.
- **Bodies**: :class:`PlanJob`, the settings a garment job of generators 2.x and 3.x shares,
  builds the body model, the subjects' rest bodies and the pose arrays once a process
  (:func:`plan_bodies`).
- **Results and writing**: a garment job returns a :class:`GarmentResult`;
  :func:`write_plan` computes every garment of a plan with
  :func:`dressmeup.data.synth.jobs.run_jobs` and writes the results in plan order (test
  garments first).
- :class:`BodyAnchors`: the body surface points that hold a garment's waistband or
  shoulders (generators 3.x and 4).
"""

from __future__ import annotations

import functools
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.body import BodyParams, get_body_model
from dressmeup.data.synth.garments import BodyFrame, RestGarment, build_garment, sample_params
from dressmeup.data.synth.jobs import run_jobs
from dressmeup.data.synth.poses import pose_axis_angle, pose_names
from dressmeup.data.synth.scans import SCAN_BODY
from dressmeup.data.synth.texture import procedural_texture
from dressmeup.data.writer import DatasetWriter
from dressmeup.executors import LocalExecutor
from dressmeup.geometry.mesh import edges, face_areas, face_normals
from dressmeup.geometry.proximity import barycentric, closest_points
from dressmeup.geometry.winding import winding_number
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.mesh import save_mesh
from dressmeup.progress import progress

BODY_DECIMALS = 9  # body vertices, metres
STORE_DECIMALS = 6  # stored vertices, metres (1 micrometre)
POSE_DECIMALS = 9  # stored pose arrays (body.npz), radians

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
#: Pose order of generators 2.x and 3.x (the first ``poses`` are used): legs and arms
#: alternate so that even two or three poses load both (sitting is the hardest for skirts
#: and dresses).
POSE_ORDER = ("sitting", "arms-raised", "walking", "one-arm-up", "bent-knees", "arms-forward",
              "twist-side", "bent-elbows", "a-pose", "arms-down")
#: pose sets of the library a plan may draw from (:func:`dressmeup.data.synth.poses.pose_names`)
POSE_SETS = ("generator", "registration", "registration-tuning", "all")
#: who wears what (:func:`plan_2x`): every garment on everyone, or one garment per sample
WEAR_MODES = ("all", "rotate")
DEFAULT_EDGE_LENGTH = {"anny": 0.02, "procedural": 0.025}


def quantize(a: np.ndarray, decimals: int) -> np.ndarray:
    """``a`` as float64 rounded to ``decimals`` decimals (metres), without negative zeros."""
    return np.round(np.asarray(a, np.float64), decimals) + 0.0  # + 0.0: no negative zeros


def plan_2x(subjects: int, poses: int, garments_per_split: tuple[int, int, int], seed: int,
            categories: list[str] | None = None, pose_set: str = "generator",
            wear: str = "all") -> dict[str, Any]:
    """Deterministic plan of generators 2.x and 3.x: subjects, pose names, garments (type,
    parameters, split, designer).

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
    names, cats, counts = _check_plan(subjects, poses, garments_per_split, categories,
                                      pose_set, wear)
    n_train, n_val, n_test = counts
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
        _rotate_wearers(plan)
    return plan


def _check_plan(subjects: int, poses: int, garments_per_split: tuple[int, int, int],
                categories: list[str] | None, pose_set: str, wear: str
                ) -> tuple[list[str], list[str], tuple[int, int, int]]:
    """:func:`plan_2x`'s arguments checked (``ValueError``): the pose set's names, the
    categories and the (train, val, test) counts."""
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
    return names, cats, (n_train, n_val, n_test)


def _rotate_wearers(plan: dict[str, Any]) -> None:
    """Add ``wear="rotate"``'s ``"wearers"`` to every garment of ``plan`` (:func:`plan_2x`)."""
    sids, pids = list(plan["subjects"]), list(plan["poses"])
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


def dataset_arguments(garments_per_split: tuple[int, int, int] | list[int], scan_body: str,
                      body_model: str, edge_length: float | None
                      ) -> tuple[tuple[int, int, int], float]:
    """The (train, val, test) garment counts and the garment edge length (metres; default
    :data:`DEFAULT_EDGE_LENGTH` of the body model) of a generator-2.x or -3.x dataset,
    checked before anything is written (``ValueError``)."""
    gps = tuple(int(x) for x in garments_per_split)
    if len(gps) != 3:
        raise ValueError(f"garments_per_split: expected (train, val, test), got {gps!r}")
    if scan_body not in SCAN_BODY:
        raise ValueError(f"scan_body: expected one of {SCAN_BODY}, got {scan_body!r}")
    return gps, float(edge_length or DEFAULT_EDGE_LENGTH.get(body_model, 0.02))


def wearers(plan: dict[str, Any], gid: str) -> list[tuple[str, str]]:
    """The (subject id, pose id) samples garment ``gid`` of ``plan`` is draped in."""
    g = plan["garments"][gid]
    if "wearers" in g:
        return [(s, p) for s, p in g["wearers"]]
    return [(s, p) for s in plan["subjects"] for p in plan["poses"]]


#: generator parameters recorded in ``dataset.json`` only when they differ from these
#: defaults (added after the first pinned 2.0.0 datasets, whose bytes must not change)
OPTIONAL_PARAMS = {"pose_set": "generator", "wear": "all", "scan_body": "whole"}


def generator_params(version: str, **params: Any) -> dict[str, Any]:
    """``dataset.json``'s generator parameters: ``version`` first, then ``params`` in the
    given order, leaving out :data:`OPTIONAL_PARAMS` that have their default value."""
    return {"version": version, **{k: v for k, v in params.items()
                                   if k not in OPTIONAL_PARAMS or v != OPTIONAL_PARAMS[k]}}


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


class BodyAnchors:
    """Points of the body surface that hold the garment's supported vertices.

    Each supported vertex is tied to its closest point on the design body at rest (face and
    barycentric coordinates) and its offset along that face's normal; on any body of the same
    topology the anchor is the same barycentric point pushed out by the same offset.

    Parameters
    ----------
    garment_V : (n, 3) float64 garment on the design body at rest.
    support : (n,) float64 in [0, 1], how firmly each vertex is held (0: free).
    body_V : (b, 3) float64 design body at rest; body_F : (c, 3) int64.
    gap : None (the vertex's own offset, generator 3.x) or a distance in metres: every anchor
        is its closest body point pushed out along the face normal by ``gap`` (the band
        grips the body; generator 4).
    """

    def __init__(self, garment_V: np.ndarray, support: np.ndarray, body_V: np.ndarray,
                 body_F: np.ndarray, gap: float | None = None) -> None:
        self.F = np.asarray(body_F, np.int64)
        self.weight = np.asarray(support, np.float64)
        body_V = np.asarray(body_V, np.float64)
        _, p, self.face = closest_points(body_V, self.F, garment_V, exact_faces=True)
        self.bary = barycentric(p, body_V[self.F[self.face]])
        # the offset in the face's own frame, so the anchor is the vertex on the design body
        self.offset = np.einsum("pij,pj->pi", self._frames(body_V),
                                np.asarray(garment_V, np.float64) - p)
        if gap is not None:
            self.offset = np.zeros_like(self.offset)
            self.offset[:, 2] = float(gap)

    def _frames(self, body_V: np.ndarray) -> np.ndarray:
        """Orthonormal frames ``(n, 3, 3)`` (rows: first edge, its normal in the face plane,
        face normal) of the anchor faces of ``body_V``."""
        tri = body_V[self.F[self.face]]
        n = face_normals(body_V, self.F)[self.face]
        e1 = tri[:, 1] - tri[:, 0]
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        return np.stack([e1, np.cross(n, e1), n], axis=1)

    def points(self, body_V: np.ndarray) -> np.ndarray:
        """Anchor points ``(n, 3)`` on the body ``body_V (b, 3)``."""
        on = np.einsum("pk,pkd->pd", self.bary, body_V[self.F[self.face]])
        return on + np.einsum("pij,pi->pj", self._frames(body_V), self.offset)


@dataclass
class Body:
    """One subject's rest body: skin vertices ``(n, 3)``, frame, and its phenotype."""

    sid: str
    shape: np.ndarray
    rest_V: np.ndarray
    frame: BodyFrame


@dataclass
class PlanBodies:
    """The body model, the subjects' rest bodies and the pose arrays of a plan."""

    model: Any
    keep: np.ndarray  # skin vertex indices of the model's vertices
    skin_F: np.ndarray  # skin faces
    names: tuple[str, ...]  # joint names
    body_W: np.ndarray  # skinning weights of the skin vertices
    labels: np.ndarray  # dominant joint name of each skin vertex
    bodies: dict[str, Body]  # subject id -> rest body
    poses: dict[str, np.ndarray]  # pose id -> axis-angle pose array

    def params(self, shape: np.ndarray, pose: np.ndarray) -> BodyParams:
        """The model's parameters of phenotype ``shape`` in ``pose``."""
        return BodyParams(model=self.model.name, shape=shape, pose=pose)

    def rest_body(self, shape: np.ndarray) -> np.ndarray:
        """Skin vertices ``(b, 3)`` of the body of phenotype ``shape`` at rest (rounded)."""
        out = self.model.posed(self.params(shape, np.zeros((len(self.names), 3))))
        return quantize(np.asarray(out.rest_vertices)[self.keep], BODY_DECIMALS)

    def posed_body(self, shape: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Skin vertices ``(b, 3)`` of the body ``shape`` in ``pose`` (rounded)."""
        out = self.model.posed(self.params(shape, pose))
        return quantize(np.asarray(out.vertices)[self.keep], BODY_DECIMALS)


@functools.lru_cache(maxsize=1)  # one plan's bodies a process: a worker runs one generation
def plan_bodies(body_model: str, subjects: tuple[tuple[str, tuple[float, ...]], ...],
                poses: tuple[tuple[str, str], ...]) -> PlanBodies:
    """Load the body model, the subjects' rest bodies (``subjects``: (id, phenotype) pairs)
    and the pose arrays (``poses``: (id, library name) pairs, on the model's default body,
    without jitter), rounded to :data:`BODY_DECIMALS`."""
    model = get_body_model(body_model)
    keep, skin_F = model.skin()
    names = tuple(model.joint_names)
    body_W = np.asarray(model.skinning_weights)[keep]
    frame0 = BodyFrame.from_joints(model.posed(model.default_params()).rest_joints, names)
    bodies = {}
    for sid, s in subjects:
        shape = np.asarray(s, np.float64)
        rest = model.posed(BodyParams(model=model.name, shape=shape,
                                      pose=np.zeros((len(names), 3))))
        bodies[sid] = Body(sid, shape, quantize(rest.rest_vertices[keep], BODY_DECIMALS),
                           BodyFrame.from_joints(quantize(rest.rest_joints, BODY_DECIMALS), names))
    return PlanBodies(model=model, keep=keep, skin_F=skin_F, names=names, body_W=body_W,
                      labels=np.array(names)[body_W.argmax(1)], bodies=bodies,
                      poses={pid: pose_axis_angle(name, names, frame0, rng=None)
                             for pid, name in poses})


@dataclass(frozen=True)
class GarmentItem:
    """One garment of a plan to compute: its id, its plan entry and the (subject id, pose id)
    samples of it not yet written."""

    gid: str
    garment: dict[str, Any]
    missing: tuple[tuple[str, str], ...]

    def subjects(self) -> list[str]:
        """The subjects of :attr:`missing`, each once, in order."""
        return list(dict.fromkeys(s for s, _ in self.missing))

    def poses_of(self, sid: str) -> list[str]:
        """The poses of :attr:`missing` of subject ``sid``, in order."""
        return [p for s, p in self.missing if s == sid]


@dataclass(frozen=True)
class PlanJob:
    """What a garment job of generators 2.x and 3.x shares: the bodies of its plan (built
    once a process, :meth:`bodies`), the garments' edge length, textures and scans."""

    body_model: str
    subjects: tuple[tuple[str, tuple[float, ...]], ...]  # (id, phenotype) of the plan
    poses: tuple[tuple[str, str], ...]  # (id, library pose name) of the plan
    edge: float  # garment edge length, metres
    seed: int
    texture_size: int
    write_scan: bool
    scan_body: str

    @staticmethod
    def of_plan(plan: dict[str, Any]) -> dict[str, Any]:
        """The ``subjects`` and ``poses`` fields of a job of ``plan``."""
        return {"subjects": tuple((sid, tuple(s["shape"])) for sid, s in
                                  plan["subjects"].items()),
                "poses": tuple(plan["poses"].items())}

    def bodies(self) -> PlanBodies:
        """The plan's bodies, built on the first call in a process."""
        return plan_bodies(self.body_model, self.subjects, self.poses)

    def build(self, item: GarmentItem) -> tuple[RestGarment, Body]:
        """``item``'s garment built on its design body, and that body."""
        b = self.bodies()
        g = item.garment
        design = b.bodies[g["design_subject"]]
        return build_garment(g["type"], g["params"], design.rest_V, b.skin_F, b.labels,
                             design.frame, edge_length=self.edge), design

    def texture(self, gid: str) -> tuple[np.ndarray, str]:
        """Garment ``gid``'s texture image and its pattern's name."""
        return procedural_texture(np.random.default_rng([self.seed, 7919, int(gid[1:])]),
                                  self.texture_size)


@dataclass
class SampleResult:
    """One computed sample: garment vertices ``V`` as stored, the optional scan
    ``(vertices, faces)``, the body's phenotype and pose, the sample's statistics."""

    sid: str
    pid: str
    V: np.ndarray
    scan: tuple[np.ndarray, np.ndarray] | None
    shape: np.ndarray
    pose: np.ndarray
    stats: dict[str, Any]
    model: str  # body model name


@dataclass
class GarmentResult:
    """Everything a garment job computed for one garment, to be written in plan order: the
    rest garment (``V0``, faces ``F``, UVs), its texture, the garment fitted to each subject
    and its samples."""

    gid: str
    garment: dict[str, Any]  # plan entry
    V0: np.ndarray
    F: np.ndarray
    uv: np.ndarray
    uv_faces: np.ndarray
    category: str
    garment_type: str
    tex: np.ndarray
    build_cpu_s: float
    fitted: dict[str, np.ndarray] = field(default_factory=dict)
    samples: list[SampleResult] = field(default_factory=list)


def write_plan(out: str | os.PathLike, info: dict[str, Any], plan: dict[str, Any],
               job: Any, workers: int, executor: Any, desc: str, report_fn: Any) -> Path:
    """Compute with ``job`` (``job(GarmentItem) -> GarmentResult``) and write every sample of
    ``plan`` not yet in ``out`` (test garments first, so a long run gives the benchmark's
    data first; then train, then val), then finalize the dataset with ``report_fn(out)`` as
    its report.

    ``workers`` / ``executor`` as in :func:`dressmeup.data.synth.jobs.run_jobs` (this
    process only writes). Returns the dataset root.
    """
    t_start, cpu_start = time.perf_counter(), time.process_time()
    out = Path(out)
    writer = DatasetWriter(out, info)
    total = sum(len(wearers(plan, gid)) for gid in plan["garments"])
    todo = []
    rank = {"test": 0, "train": 1, "val": 2}
    for gid, g in sorted(plan["garments"].items(), key=lambda kv: (rank[kv[1]["split"]], kv[0])):
        missing = [(s, p) for s, p in wearers(plan, gid)
                   if not writer.has_sample(f"{s}-{gid}-{p}")]
        if missing:
            todo.append(GarmentItem(gid, g, tuple(missing)))
    left = sum(len(item.missing) for item in todo)
    bar = progress(range(left), desc=desc, total=total, initial=total - left)
    for res in run_jobs(job, todo, workers, executor):
        _write_garment(writer, out, res, bar)
    for _ in bar:
        pass
    if isinstance(executor, LocalExecutor):  # run_jobs runs it as a pool of its size
        workers = executor.workers
    return writer.finalize(report=report_fn(out), timings={
        "last_run_s": round(time.perf_counter() - t_start, 2),
        "last_run_main_cpu_s": round(time.process_time() - cpu_start, 2), "workers": workers})


def _write_garment(writer: DatasetWriter, out: Path, res: GarmentResult, bar) -> None:
    """Write one garment's files (rest, fitted, stats, then each sample) in plan order."""

    gid, F = res.gid, res.F
    save_mesh(out / "generator" / "rest" / f"{gid}.ply", res.V0, F, uv=res.uv,
              uv_faces=res.uv_faces)
    for sid, fitted in res.fitted.items():
        save_mesh(out / "generator" / "fitted" / f"{gid}-{sid}.ply", fitted, F)
    for smp in res.samples:
        sid, pid = smp.sid, smp.pid
        sample_id = f"{sid}-{gid}-{pid}"
        next(bar, None)
        # the stats before the manifest row (a resumed run skips samples in the manifest)
        atomic_write_text(out / "generator" / "stats" / f"{sample_id}.json",
                          json.dumps(smp.stats, indent=1, sort_keys=True) + "\n")
        writer.add_sample(subject_id=sid, garment_id=gid, pose_id=pid,
                          category=res.category, garment_type=res.garment_type,
                          split=res.garment["split"],
                          garment=(smp.V, F, res.uv, res.uv_faces),
                          # the pose arrays carry anny's float noise (its per-machine first
                          # build): stored rounded to 1e-9 rad, like the stored coordinates
                          body=BodyParams(model=smp.model, shape=smp.shape,
                                          pose=quantize(smp.pose, POSE_DECIMALS)),
                          scan=smp.scan, texture=res.tex)
