"""Generator 4.0.0's datasets (the v5 retargeting editions): the plan of
:mod:`dressmeup.data.synth.plan4`, every sample dressed by the defined motion of
:mod:`dressmeup.data.synth.generator4`, written as a dataset.

One job per garment: build it on its design body at rest, then simulate the motion to each
of its targets (the source first). Jobs run in spawned worker processes (or on a
:mod:`dressmeup.executors` executor) with the canonical numerics of
:mod:`dressmeup.data.synth.jobs`; this process writes the results in plan order (train
garments first, then val, then test, so that training can start on a full edition's train
split while its test split is generated), each sample's statistics before its manifest row,
so an interrupted run resumes where it stopped.

Files besides the dataset layout:

- ``generator/garments/<garment>.json``: the garment's type, fit, design parameters, design
  subject and targets (the plan);
- ``generator/rest/<garment>.ply``: the garment as designed, on its design body at rest;
- ``generator/stats/<sample>.json``: the motion, the solver's figures of every frame and
  the plausibility figures (:func:`dressmeup.data.synth.generator4.dress`);
- ``generator/failed/<sample>.json``: a planned target whose motion the cloth could not
  follow within the sub-step budget (:class:`~dressmeup.data.synth.generator4.SimulationFailed`):
  it is not in the dataset, the reason and the CPU spent are.

**A garment's source** is the first of its targets on its design body (the planned source,
then its re-pose targets, in plan order) whose motion succeeds; ``dataset.json`` declares it
(``garments.<id>.source``) and every track is the relation of a target to it
(:func:`track_of`: a re-shape target planned in a failed source's pose is then a cross
target). A target on another body waits for the source: when every motion on the design
body fails, the garment has no sample (its other targets are recorded as failed, not
simulated). While every planned source succeeds the rule changes nothing.

The public part of a test split withholds all three for its garments and samples (their
names start with the garment's or the sample's id); ``dataset.json`` lists garments by
split, type and category only, never their parameters. With a secret
(:mod:`dressmeup.data.synth.secret`) ``dataset.json`` records its commitment, never the
secret.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.body import BodyParams
from dressmeup.data import layout
from dressmeup.data.synth.config import SynthConfig
from dressmeup.data.synth.dynamics import DynamicsSettings
from dressmeup.data.synth.generator4 import (
    VERSION,
    Gen4Settings,
    SimulationFailed,
    build,
    dress,
    load_body_kit,
)
from dressmeup.data.synth.jobs import run_jobs
from dressmeup.data.synth.motion import MotionSpec
from dressmeup.data.synth.plan4 import SPLITS, PlanDesign, plan_split
from dressmeup.data.synth.sampling import SelfIntersectionCheck
from dressmeup.data.synth.scans import SCAN_BODY, clothed_scan
from dressmeup.data.synth.secret import commitment, derive_seed
from dressmeup.data.synth.texture import procedural_texture
from dressmeup.data.writer import DatasetWriter
from dressmeup.errors import InputError
from dressmeup.hyperparameters import resolve_config
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.jsonio import parse_json_file
from dressmeup.io.mesh import save_mesh
from dressmeup.progress import progress

#: stored pose arrays (body.npz) are rounded to this many decimals (radians)
POSE_DECIMALS = 9
#: garment edge length (m) when the configuration gives none
DEFAULT_EDGE = 0.015


@dataclass(frozen=True)
class Gen4Config:
    """What a generator-4 dataset is a function of besides its seed and secret."""

    design: PlanDesign = field(default_factory=PlanDesign)
    sim: Gen4Settings = field(default_factory=Gen4Settings)
    body_model: str = "anny"
    write_scan: bool = True
    scan_body: str = "whole"
    texture_size: int = 256

    @classmethod
    def from_synth(cls, c: SynthConfig) -> Gen4Config:
        """The generator-4 settings of a :class:`SynthConfig` (``plan``, ``motion``,
        ``dynamics``, ``edge_length``, ``body_model``, ``write_scan``, ``scan_body``,
        ``texture_size``)."""
        if c.scan_body not in SCAN_BODY:
            raise InputError(f"scan_body: expected one of {SCAN_BODY}, got {c.scan_body!r}")
        dynamics = resolve_config({"default": DynamicsSettings()}, "default",
                                  dict(c.dynamics or {}), "dynamics")
        sim = Gen4Settings(motion=MotionSpec.from_dict(c.motion), dynamics=dynamics,
                           edge_length=float(c.edge_length or DEFAULT_EDGE))
        return cls(PlanDesign.from_dict(c.plan), sim, c.body_model, c.write_scan, c.scan_body,
                   c.texture_size)

    def params(self, seed: int) -> dict[str, Any]:
        """The generator parameters written in ``dataset.json``."""
        return {"version": VERSION, "seed": int(seed), "plan": self.design.to_dict(),
                "motion": self.sim.motion.to_dict(), "dynamics": self.sim.dynamics.to_dict(),
                "edge_length": self.sim.edge_length, "anchor_gap": self.sim.anchor_gap,
                "body_model": self.body_model, "write_scan": self.write_scan,
                "scan_body": self.scan_body, "texture_size": self.texture_size}


@dataclass(frozen=True)
class GarmentWork:
    """One garment's job: its plan record, the design body's phenotype ``(s,)``, its
    targets still to dress as ``(sid, pid, track, shape (s,), pose (j, 3))`` (plan order),
    its texture's seed words and its source's ``(sid, pid)`` when already written (None:
    the source is the first target on the design body that this job dresses)."""

    gid: str
    garment: dict[str, Any]
    design_shape: np.ndarray
    targets: tuple[tuple[str, str, str, np.ndarray, np.ndarray], ...]
    texture_seed: tuple[int, ...]
    source: tuple[str, str] | None = None


@dataclass
class DressedTarget:
    """One simulated sample: ids, garment ``V (n, 3)`` (1 µm grid; None when the simulation
    failed: :class:`~dressmeup.data.synth.generator4.SimulationFailed`, the reason in
    ``stats["failed"]``), the body's ``shape`` and ``pose``, its statistics and the scan
    ``(V, F)`` or None."""

    sid: str
    pid: str
    V: np.ndarray | None
    shape: np.ndarray
    pose: np.ndarray
    stats: dict[str, Any]
    scan: tuple[np.ndarray, np.ndarray] | None


@dataclass
class GarmentResult:
    """A garment's job done: the garment as designed (``V0 (n, 3)``, ``F (m, 3)``, ``uv``,
    ``uv_faces``), its names, its texture (PNG-able array) and every dressed target."""

    gid: str
    V0: np.ndarray
    F: np.ndarray
    uv: np.ndarray | None
    uv_faces: np.ndarray | None
    category: str
    garment_type: str
    texture: Any
    pattern: str
    samples: list[DressedTarget]


@lru_cache(maxsize=2)
def _kit(body_model: str):
    """The body kit of this process (built once per process and body model)."""
    return load_body_kit(body_model)


@dataclass(frozen=True)
class DressJob:
    """The job of one garment (``DressJob(config)(work) -> GarmentResult``); picklable."""

    config: Gen4Config

    __name__ = "synth_gen4_garment"

    def __call__(self, work: GarmentWork) -> GarmentResult:
        c = self.config
        kit = _kit(c.body_model)
        g = work.garment
        built = build(kit, g["type"], g["params"], work.design_shape, c.sim.edge_length)
        tex, pattern = procedural_texture(np.random.default_rng(list(work.texture_seed)),
                                          c.texture_size)
        samples: list[DressedTarget] = []
        source, home = work.source, g["design_subject"]
        home_failed: list[str] = []
        for sid, pid, planned, shape, pose in work.targets:
            if source is None and sid != home:
                samples.append(DressedTarget(sid, pid, None, shape, pose, {
                    "failed": "the garment has no source: every motion on its design body "
                              f"failed ({'; '.join(home_failed)})", "track": planned}, None))
                continue
            track = planned if source is None else track_of((sid, pid), source)
            t0 = time.process_time()
            try:
                res = dress(kit, built, shape, pose, c.sim)
            except SimulationFailed as exc:
                samples.append(DressedTarget(sid, pid, None, shape, pose, {
                    "failed": str(exc), "track": track,
                    "cpu_s": round(time.process_time() - t0, 2)}, None))
                if source is None:
                    home_failed.append(f"{pid}: {exc}")
                continue
            if source is None:
                source, track = (sid, pid), "source"
            scan = (clothed_scan(res.body_vertices, kit.faces, res.vertices, built.faces,
                                 c.scan_body) if c.write_scan else None)
            stats = {**res.stats, "track": track, "pose": pid, "subject": sid,
                     "design_subject": g["design_subject"], "garment_type": g["type"],
                     "fit": g["fit"], "texture": pattern}
            samples.append(DressedTarget(sid, pid, res.vertices, shape, pose, stats, scan))
        return GarmentResult(work.gid, built.vertices, built.faces, built.uv, built.uv_faces,
                             built.category, built.garment_type, tex, pattern, samples)


def texture_seed(split: str, seed: int, secret: bytes | None, gid: str) -> tuple[int, ...]:
    """Seed words of a garment's texture (the test split's from the secret)."""
    if split == "test":
        return tuple(derive_seed(secret, "test", "texture", gid))
    return (int(seed), SPLITS.index(split), 7919, int(gid[1:]))


class _PoseCheck:
    """``(shape, pose) -> bool``: the body does not cut through itself in the pose (one
    :class:`SelfIntersectionCheck` per body, answers cached)."""

    def __init__(self, model) -> None:
        self.model = model
        self.checks: dict[bytes, SelfIntersectionCheck] = {}
        self.answers: dict[tuple[bytes, bytes], bool] = {}

    def __call__(self, shape: np.ndarray, pose: np.ndarray) -> bool:
        key = (np.asarray(shape, np.float64).tobytes(), np.asarray(pose, np.float64).tobytes())
        if key not in self.answers:
            if key[0] not in self.checks:
                self.checks[key[0]] = SelfIntersectionCheck(self.model, shape)
            self.answers[key] = bool(self.checks[key[0]](pose))
        return self.answers[key]


def make_plan(c: SynthConfig, g4: Gen4Config) -> dict[str, Any]:
    """The plan of the splits ``c.splits`` (:func:`dressmeup.data.synth.plan4.plan_split`),
    merged: ``subjects``, ``poses``, ``garments``."""
    kit = _kit(g4.body_model)
    check = _PoseCheck(kit.model)
    plan: dict[str, Any] = {"subjects": {}, "poses": {}, "garments": {}}
    for split in SPLITS:
        if split not in c.splits:
            continue
        part = plan_split(split, g4.design, kit, c.seed, c.secret, check)
        for key in plan:
            plan[key].update(part[key])
    return plan


def dataset_info(c: SynthConfig, g4: Gen4Config, plan: dict[str, Any],
                 sources: dict[str, str] | None = None) -> dict[str, Any]:
    """The ``dataset.json`` record (no garment parameter, no secret); ``sources`` garment id
    -> source sample id (:func:`declared_sources`; default: the planned sources)."""
    if sources is None:
        sources = declared_sources(plan)
    params = g4.params(c.seed)
    params["splits"] = [s for s in SPLITS if s in c.splits]
    if c.secret is not None:
        params["test_split_commitment"] = commitment(c.secret)
    return {
        "name": "dressmeup-synthetic",
        "version": VERSION,
        "licence": "CC0-1.0 (generated data; anny body model data is CC0)",
        "description": f"Synthetic DressMeUp-style dataset, generator {VERSION}: each "
                       "parametric garment is dressed by a defined motion simulated in time "
                       "(from its design body at rest: shape blended, pose grown, settled; "
                       "implicit dynamics with barrier contact against the body and itself) "
                       "onto sampled bodies in sampled poses.",
        "body_model": g4.body_model,
        "categories": sorted({g["category"] for g in plan["garments"].values()}),
        "citation": "dressmeup toolkit, synthetic generator " + VERSION,
        "generator": {"name": "dressmeup.data.synth", "version": VERSION, "seed": int(c.seed),
                      "params": params},
        "subjects": plan["subjects"],
        "poses": {p: {"family": v["family"], "split": v["split"]}
                  for p, v in plan["poses"].items()},
        "garments": {g: {"split": v["split"], "type": v["type"], "category": v["category"],
                         "source": sources[g]}
                     for g, v in plan["garments"].items()},
    }


def track_of(target: tuple[str, str], source: tuple[str, str]) -> str:
    """The track of a ``(subject, pose)`` target relative to its garment's source ``(subject,
    pose)``: ``source`` (itself), ``re-pose`` (same subject), ``re-shape`` (same pose) or
    ``cross``."""
    if target == source:
        return "source"
    if target[0] == source[0]:
        return "re-pose"
    return "re-shape" if target[1] == source[1] else "cross"


def declared_sources(plan: dict[str, Any], failed_dir: Path | None = None) -> dict[str, str]:
    """Garment id -> the sample id of its source (module docstring): its first target on the
    design body in plan order not recorded in ``failed_dir``; the planned source when all
    are (or without ``failed_dir``)."""
    out = {}
    for gid, g in plan["garments"].items():
        home = [t for t in g["targets"] if t.sid == g["design_subject"]]
        ok = [t for t in home if failed_dir is None
              or not (failed_dir / f"{t.sid}-{gid}-{t.pid}.json").is_file()]
        t = (ok or home)[0]
        out[gid] = f"{t.sid}-{gid}-{t.pid}"
    return out


def generate_gen4(out: str | os.PathLike, c: SynthConfig, workers: int = 1,
                  executor: Any = None) -> Path:
    """Generate (or resume) a generator-4 dataset in ``out`` (module docstring).

    Parameters
    ----------
    out : output folder.
    c : the configuration (:class:`SynthConfig`, ``version="4.0.0"``); ``c.splits`` the
        splits to build (the test split needs ``c.secret``).
    workers, executor : where the garments' jobs run (the output does not depend on it).

    Returns
    -------
    Path of the dataset root.
    """
    t_start, cpu_start = time.perf_counter(), time.process_time()
    g4 = Gen4Config.from_synth(c)
    if "test" in c.splits and c.secret is None:
        raise InputError("generator 4 seeds the test split from a secret: give one "
                         "(SynthConfig.secret; dressmeup synth --edition E --secret FILE), or "
                         "build train and val only (splits)")
    plan = make_plan(c, g4)
    out = Path(out)
    failed_dir = out / "generator" / "failed"
    sources = declared_sources(plan, failed_dir)
    info = dataset_info(c, g4, plan, sources)
    _sync_sources(out, info["garments"])
    writer = DatasetWriter(out, info)
    todo = _todo(c, plan, writer)
    total = sum(len(g["targets"]) for g in plan["garments"].values())
    bar = progress(range(total), desc="synth v5", total=total)
    for _ in range(total - sum(len(w.targets) for w in todo)):
        next(bar, None)
    for res in run_jobs(DressJob(g4), todo, workers=workers, executor=executor):
        _write(writer, out, plan, res, g4.body_model, bar)
        now = declared_sources(plan, failed_dir)
        if now != sources:  # a source failed: dataset.json declares the next one
            sources = now
            writer.update_info(garments=dataset_info(c, g4, plan, sources)["garments"])
    for _ in bar:
        pass
    return writer.finalize(report=summarize(out), timings={
        "last_run_s": round(time.perf_counter() - t_start, 2),
        "last_run_main_cpu_s": round(time.process_time() - cpu_start, 2), "workers": workers})


def _sync_sources(out: Path, garments: dict[str, Any]) -> None:
    """Bring the declared sources of an interrupted run's ``dataset.json`` up to date with
    its failed records (a run killed between a failed source's record and the declaration
    of the next one); any other difference is left for the writer to report."""
    path = out / layout.DATASET_JSON
    if not path.is_file():
        return
    old = parse_json_file(path)
    was = old.get("garments") if isinstance(old, dict) else None

    def rest(g: dict[str, Any]) -> dict[str, Any]:
        return {k: v for k, v in g.items() if k != "source"}

    if (isinstance(was, dict) and was != garments and set(was) == set(garments)
            and all(isinstance(was[g], dict) and rest(was[g]) == rest(garments[g])
                    for g in garments)):
        old["garments"] = garments
        atomic_write_text(path, json.dumps(old, indent=2, sort_keys=True) + "\n")


def _todo(c: SynthConfig, plan: dict[str, Any], writer: DatasetWriter) -> list[GarmentWork]:
    """The jobs of the garments with a sample not yet written (train, then val, then test:
    networks can start training while the test split is generated); writes each garment's
    plan file."""
    rank = {"train": 0, "val": 1, "test": 2}
    out_dir = writer.root / "generator" / "garments"
    failed = writer.root / "generator" / "failed"
    todo = []
    for gid, g in sorted(plan["garments"].items(), key=lambda kv: (rank[kv[1]["split"]], kv[0])):
        if not (out_dir / f"{gid}.json").is_file():  # a resumed run has written it already
            record = {**g, "targets": [[t.sid, t.pid, t.track] for t in g["targets"]]}
            atomic_write_text(out_dir / f"{gid}.json", json.dumps(record, indent=1) + "\n")
        missing = tuple(
            (t.sid, t.pid, t.track, np.asarray(plan["subjects"][t.sid]["shape"], np.float64),
             np.asarray(plan["poses"][t.pid]["pose"], np.float64))
            for t in g["targets"] if not writer.has_sample(f"{t.sid}-{gid}-{t.pid}")
            and not (failed / f"{t.sid}-{gid}-{t.pid}.json").is_file())
        if missing:
            design = np.asarray(plan["subjects"][g["design_subject"]]["shape"], np.float64)
            written = [(t.sid, t.pid) for t in g["targets"] if t.sid == g["design_subject"]
                       and writer.has_sample(f"{t.sid}-{gid}-{t.pid}")]
            todo.append(GarmentWork(gid, g, design, missing,
                                    texture_seed(g["split"], c.seed, c.secret, gid),
                                    written[0] if written else None))
    return todo


def _write(writer: DatasetWriter, out: Path, plan: dict[str, Any], res: GarmentResult,
           body_model: str, bar) -> None:
    """Write one garment's files (rest mesh, then per sample its stats and its row)."""
    g = plan["garments"][res.gid]
    save_mesh(out / "generator" / "rest" / f"{res.gid}.ply", res.V0, res.F, uv=res.uv,
              uv_faces=res.uv_faces)
    for s in res.samples:
        sample_id = f"{s.sid}-{res.gid}-{s.pid}"
        next(bar, None)
        if s.V is None:  # recorded, so that a resumed run does not simulate it again
            atomic_write_text(out / "generator" / "failed" / f"{sample_id}.json",
                              json.dumps(s.stats, indent=1, sort_keys=True) + "\n")
            continue
        # the stats before the manifest row (a resumed run skips samples in the manifest)
        atomic_write_text(out / "generator" / "stats" / f"{sample_id}.json",
                          json.dumps(s.stats, indent=1, sort_keys=True) + "\n")
        writer.add_sample(subject_id=s.sid, garment_id=res.gid, pose_id=s.pid,
                          category=res.category, garment_type=res.garment_type,
                          split=g["split"], garment=(s.V, res.F, res.uv, res.uv_faces),
                          body=BodyParams(model=body_model, shape=s.shape,
                                          pose=np.round(s.pose, POSE_DECIMALS)),
                          scan=s.scan, texture=res.texture)


def summarize(root: str | os.PathLike) -> dict[str, Any]:
    """Summary of the samples' statistics (``generator/stats``): per figure median and max,
    unconverged frames, samples not intersection-free, CPU seconds."""
    rows = [json.loads(p.read_text()) for p in sorted(Path(root, "generator",
                                                            "stats").glob("*.json"))]
    if not rows:
        return {}

    def two(key: str) -> dict[str, float]:
        a = np.array([r[key] for r in rows], float)
        return {"median": round(float(np.median(a)), 4), "max": round(float(a.max()), 4)}

    failed = len(list(Path(root, "generator", "failed").glob("*.json")))
    return {"n": len(rows), "failed": failed, "inside_area_pct": two("inside_area_pct"),
            "self_intersecting_faces": two("self_intersecting_faces"),
            "unconverged_frames": int(sum(r["unconverged_frames"] for r in rows)),
            "not_intersection_free": int(sum(not r["intersection_free"] for r in rows)),
            "cpu_s": two("cpu_s")}
