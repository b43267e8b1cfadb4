"""Generator 4.0.0's datasets (the v5 retargeting editions): the plan of
:mod:`dressmeup.data.synth.plan4`, every sample dressed by the defined motion of
:mod:`dressmeup.data.synth.generator4`, written as a dataset.

One job per target: build the garment on its design body at rest (once per worker
process), then simulate the motion to the target. Jobs run in spawned worker processes (or
on a :mod:`dressmeup.executors` executor) with the canonical numerics of
:mod:`dressmeup.data.synth.jobs`, train garments first, then val, then test (training can
start on a full edition's train split while its test split is generated), each garment's
targets in plan order. This process writes each result as it comes, each sample's
statistics before its manifest row, so an interrupted run resumes where it stopped and
loses only the targets that were running; the manifest's rows are put in plan order at
the end, so the dataset does not depend on the workers or on how often it was resumed.

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
from dressmeup.data.synth.jobs import run_ready_jobs
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
from dressmeup.io.jsonable import json_default
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
class TargetWork:
    """One target's job: its garment's id, plan record, design body's phenotype ``(s,)`` and
    texture seed words, and the target ``(sid, pid)`` with its body's ``shape (s,)`` and
    ``pose (j, 3)``."""

    gid: str
    garment: dict[str, Any]
    design_shape: np.ndarray
    texture_seed: tuple[int, ...]
    sid: str
    pid: str
    shape: np.ndarray
    pose: np.ndarray


@dataclass
class DressedTarget:
    """One simulated sample: ids, garment ``V (n, 3)`` (1 µm grid; None when the simulation
    failed: :class:`~dressmeup.data.synth.generator4.SimulationFailed`), the body's
    ``shape`` and ``pose``, the motion's statistics (failed: ``failed``, the reason, and
    ``cpu_s``) and the scan ``(V, F)`` or None."""

    sid: str
    pid: str
    V: np.ndarray | None
    shape: np.ndarray
    pose: np.ndarray
    stats: dict[str, Any]
    scan: tuple[np.ndarray, np.ndarray] | None


@dataclass
class GarmentFiles:
    """A garment as designed (``V0 (n, 3)``, ``F (m, 3)``, ``uv``, ``uv_faces``), its names
    and its texture (PNG-able array) and pattern name."""

    V0: np.ndarray
    F: np.ndarray
    uv: np.ndarray | None
    uv_faces: np.ndarray | None
    category: str
    garment_type: str
    texture: Any
    pattern: str


@dataclass
class TargetResult:
    """A target's job done: the garment's files and the dressed sample."""

    gid: str
    garment: GarmentFiles
    sample: DressedTarget


@lru_cache(maxsize=2)
def _kit(body_model: str):
    """The body kit of this process (built once per process and body model)."""
    return load_body_kit(body_model)


#: garments built in this process, newest last (:func:`built_garment`)
_BUILT: dict[tuple, tuple[Any, GarmentFiles]] = {}


def built_garment(c: Gen4Config, work: TargetWork) -> tuple[Any, GarmentFiles]:
    """The garment of ``work`` built on its design body, and its files (once per process
    and garment, the last 4 kept: a garment's targets mostly run one after the other)."""
    key = (c.body_model, float(c.sim.edge_length), int(c.texture_size), work.gid,
           json.dumps(work.garment["params"], sort_keys=True, default=json_default),
           np.asarray(work.design_shape, np.float64).tobytes(), tuple(work.texture_seed))
    if key not in _BUILT:
        g = work.garment
        built = build(_kit(c.body_model), g["type"], g["params"], work.design_shape,
                      c.sim.edge_length)
        tex, pattern = procedural_texture(np.random.default_rng(list(work.texture_seed)),
                                          c.texture_size)
        while len(_BUILT) >= 4:
            _BUILT.pop(next(iter(_BUILT)))
        _BUILT[key] = built, GarmentFiles(built.vertices, built.faces, built.uv,
                                          built.uv_faces, built.category, built.garment_type,
                                          tex, pattern)
    return _BUILT[key]


@dataclass(frozen=True)
class DressJob:
    """The job of one target (``DressJob(config)(work) -> TargetResult``); picklable. The
    garment is built once per worker process; the motion from its design body to the
    target is simulated (:func:`~dressmeup.data.synth.generator4.dress`)."""

    config: Gen4Config

    __name__ = "synth_gen4_target"

    def __call__(self, work: TargetWork) -> TargetResult:
        c = self.config
        kit = _kit(c.body_model)
        built, files = built_garment(c, work)
        t0 = time.process_time()
        try:
            res = dress(kit, built, work.shape, work.pose, c.sim)
        except SimulationFailed as exc:
            return TargetResult(work.gid, files, DressedTarget(
                work.sid, work.pid, None, work.shape, work.pose,
                {"failed": str(exc), "cpu_s": round(time.process_time() - t0, 2)}, None))
        scan = (clothed_scan(res.body_vertices, kit.faces, res.vertices, built.faces,
                             c.scan_body) if c.write_scan else None)
        return TargetResult(work.gid, files, DressedTarget(
            work.sid, work.pid, res.vertices, work.shape, work.pose, dict(res.stats), scan))


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
    workers, executor : where the targets' jobs run (the output does not depend on it).

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
    ids = [f"{t.sid}-{gid}-{t.pid}" for gid, g in plan["garments"].items()
           for t in g["targets"]]
    done = sum(_resolved(writer, i) for i in ids)
    bar = progress(range(len(ids) - done), desc="synth v5", total=len(ids), initial=done)
    book = _Book(c, g4, plan, writer, bar)
    for work, res in run_ready_jobs(DressJob(g4), book.ready, workers=workers,
                                    executor=executor):
        book.add(work, res)
        now = declared_sources(plan, failed_dir)
        if now != sources:  # a source failed: dataset.json declares the next one
            sources = now
            writer.update_info(garments=dataset_info(c, g4, plan, sources)["garments"])
    for _ in bar:
        pass
    return writer.finalize(report=summarize(out), row_order=book.position, timings={
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


def _resolved(writer: DatasetWriter, sample_id: str) -> bool:
    """The target is done: its sample is written or its failure recorded."""
    return (writer.has_sample(sample_id)
            or (writer.root / "generator" / "failed" / f"{sample_id}.json").is_file())


def garment_order(plan: dict[str, Any]) -> list[str]:
    """The plan's garment ids in the generator's priority: train, then val, then test."""
    rank = {split: k for k, split in enumerate(SPLITS)}
    return sorted(plan["garments"], key=lambda g: (rank[plan["garments"][g]["split"]], g))


def target_work(c: SynthConfig, plan: dict[str, Any], gid: str, t: Any) -> TargetWork:
    """The job of garment ``gid``'s planned target ``t``."""
    g = plan["garments"][gid]
    return TargetWork(
        gid, g, np.asarray(plan["subjects"][g["design_subject"]]["shape"], np.float64),
        texture_seed(g["split"], c.seed, c.secret, gid), t.sid, t.pid,
        np.asarray(plan["subjects"][t.sid]["shape"], np.float64),
        np.asarray(plan["poses"][t.pid]["pose"], np.float64))


def write_garment_record(folder: Path, gid: str, g: dict[str, Any]) -> None:
    """Write ``folder/<gid>.json``: the garment's plan record (its targets as
    ``[subject, pose, track]``)."""
    record = {**g, "targets": [[t.sid, t.pid, t.track] for t in g["targets"]]}
    atomic_write_text(folder / f"{gid}.json", json.dumps(record, indent=1) + "\n")


class _Book:
    """What is done, running and ready of a generator-4 dataset, and its writing.

    The targets on a garment's design body (its source candidates, first in plan order) are
    ready at once; the garment's other targets once its source is known (the first of those
    that succeeded) -- or recorded as failed without a simulation when all of them failed.
    Results are written as they come (a killed run loses only the targets still running),
    each once every earlier target on the design body is resolved, since its track depends
    on them. Priority: train, then val, then test; garments and targets in plan order.
    """

    def __init__(self, c: SynthConfig, g4: Gen4Config, plan: dict[str, Any],
                 writer: DatasetWriter, bar) -> None:
        self.c, self.g4, self.plan, self.writer = c, g4, plan, writer
        self.bar = bar  # advanced once per target resolved in this run
        self.root = writer.root
        self.handed: set[str] = set()
        self.results: dict[str, dict[str, TargetResult]] = {}
        self.rest_written: set[str] = set()
        self.source: dict[str, tuple[str, str] | None] = {}  # absent: not known yet
        self.order = garment_order(plan)
        self.position: dict[str, tuple[int, int]] = {}
        out_dir = self.root / "generator" / "garments"
        for n, gid in enumerate(self.order):
            g = plan["garments"][gid]
            if not (out_dir / f"{gid}.json").is_file():  # a resumed run has written it
                write_garment_record(out_dir, gid, g)
            for k, t in enumerate(g["targets"]):
                self.position[f"{t.sid}-{gid}-{t.pid}"] = (n, k)
        for gid in self.order:
            self._drain(gid)

    def _on_disk(self, sample_id: str) -> bool:
        return _resolved(self.writer, sample_id)

    def ready(self) -> list[tuple[tuple[int, int], TargetWork]]:
        """The targets that may run now and were not handed out before (priority, work)."""
        out = []
        for gid in self.order:
            g = self.plan["garments"][gid]
            for t in g["targets"]:
                sample_id = f"{t.sid}-{gid}-{t.pid}"
                if sample_id in self.handed or self._on_disk(sample_id):
                    continue
                if t.sid != g["design_subject"] and self.source.get(gid) is None:
                    continue  # waits for its source (or is recorded without one)
                self.handed.add(sample_id)
                out.append((self.position[sample_id], target_work(self.c, self.plan, gid, t)))
        return out

    def add(self, work: TargetWork, res: TargetResult) -> None:
        """Take a job's result and write what it resolves."""
        self.results.setdefault(work.gid, {})[f"{work.sid}-{work.gid}-{work.pid}"] = res
        self._drain(work.gid)

    def _drain(self, gid: str) -> None:
        """Write the garment's results whose track is known, in plan order; decide its
        source; record its other targets as failed when every design-body motion failed."""
        g = self.plan["garments"][gid]
        held = self.results.get(gid, {})
        failed_dir = self.root / "generator" / "failed"
        source: tuple[str, str] | None = None
        home_failed: list[str] = []
        for t in g["targets"]:
            sample_id = f"{t.sid}-{gid}-{t.pid}"
            home = t.sid == g["design_subject"]
            if not home:
                self.source[gid] = source
            if self.writer.has_sample(sample_id):
                source = source or ((t.sid, t.pid) if home else None)
            elif (failed_dir / f"{sample_id}.json").is_file():
                if home and source is None:
                    reason = parse_json_file(failed_dir / f"{sample_id}.json").get("failed")
                    home_failed.append(f"{t.pid}: {reason}")
            elif sample_id in held:
                res = held.pop(sample_id)
                ok = res.sample.V is not None
                track = (t.track if source is None and not ok
                         else "source" if source is None else track_of((t.sid, t.pid), source))
                self._write(gid, res, track)
                if source is None and home:
                    if ok:
                        source = (t.sid, t.pid)
                    else:
                        home_failed.append(f"{t.pid}: {res.sample.stats['failed']}")
            elif home:
                return  # the later targets' tracks wait for this one
            elif source is None:
                atomic_write_text(failed_dir / f"{sample_id}.json", json.dumps({
                    "failed": "the garment has no source: every motion on its design body "
                              f"failed ({'; '.join(home_failed)})", "track": t.track},
                    indent=1, sort_keys=True) + "\n")
                next(self.bar, None)
        self.source[gid] = source

    def _write(self, gid: str, res: TargetResult, track: str) -> None:
        """Write one target's files (the garment's rest mesh first, once a run; a sample's
        statistics before its manifest row: a resumed run skips samples in the manifest)."""
        g, files, s = self.plan["garments"][gid], res.garment, res.sample
        out = self.root
        if gid not in self.rest_written:
            save_mesh(out / "generator" / "rest" / f"{gid}.ply", files.V0, files.F,
                      uv=files.uv, uv_faces=files.uv_faces)
            self.rest_written.add(gid)
        sample_id = f"{s.sid}-{gid}-{s.pid}"
        next(self.bar, None)
        if s.V is None:  # recorded, so that a resumed run does not simulate it again
            atomic_write_text(out / "generator" / "failed" / f"{sample_id}.json",
                              json.dumps({**s.stats, "track": track}, indent=1,
                                         sort_keys=True) + "\n")
            return
        stats = {**s.stats, "track": track, "pose": s.pid, "subject": s.sid,
                 "design_subject": g["design_subject"], "garment_type": g["type"],
                 "fit": g["fit"], "texture": files.pattern}
        atomic_write_text(out / "generator" / "stats" / f"{sample_id}.json",
                          json.dumps(stats, indent=1, sort_keys=True) + "\n")
        self.writer.add_sample(subject_id=s.sid, garment_id=gid, pose_id=s.pid,
                               category=files.category, garment_type=files.garment_type,
                               split=g["split"], garment=(s.V, files.F, files.uv, files.uv_faces),
                               body=BodyParams(model=self.g4.body_model, shape=s.shape,
                                               pose=np.round(s.pose, POSE_DECIMALS)),
                               scan=s.scan, texture=files.texture)


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
