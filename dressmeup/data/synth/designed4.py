"""A generator-4 plan's garments as designed, without their motions.

What the neural UV models train on (``benchmarks/train_uvparam_pretrained.py
--garments-from``) is each garment on its design body at rest: the ``generator/rest/<G>.ply``
of a generated dataset. :func:`write_designed` writes exactly those files (built by the
same job in the same canonical worker processes, :mod:`dressmeup.data.synth.jobs`, so the
bytes are those of a full generation) for the splits it is given, in seconds a garment
instead of the hours of simulation of their targets:

- ``generator/designed.json``: the generator's parameters and, per garment, its split,
  type and category (the keys of ``dataset.json``'s ``garments`` that training reads);
- ``generator/garments/<G>.json``: the plan record (as a generated dataset writes it);
- ``generator/rest/<G>.ply``: the garment as designed, with its UV layout.

Like the generator, it builds the test split only with the secret.
:func:`designed_garments` lists the garments of a split of either kind of folder (designed
garments, or a generated dataset).
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dressmeup.data.synth.config import SynthConfig
from dressmeup.data.synth.dataset4 import (
    VERSION,
    GarmentFiles,
    Gen4Config,
    TargetWork,
    built_garment,
    garment_order,
    make_plan,
    target_work,
    write_garment_record,
)
from dressmeup.data.synth.jobs import run_jobs
from dressmeup.data.synth.plan4 import SPLITS
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_text
from dressmeup.io.jsonio import parse_json_file
from dressmeup.io.mesh import save_mesh
from dressmeup.progress import progress

#: the record that marks a folder of designed garments
DESIGNED_JSON = "generator/designed.json"


@dataclass(frozen=True)
class BuildJob:
    """``BuildJob(config)(work) -> GarmentFiles``: the garment of ``work`` built on its
    design body at rest (what a :class:`~dressmeup.data.synth.dataset4.DressJob` builds
    before its motion); picklable."""

    config: Gen4Config

    __name__ = "synth_gen4_designed"

    def __call__(self, work: TargetWork) -> GarmentFiles:
        return built_garment(self.config, work)[1]


def write_designed(out: str | os.PathLike, c: SynthConfig, workers: int = 1,
                   executor: Any = None) -> Path:
    """Write the garments of ``c.splits`` as designed into ``out`` (module docstring).

    Parameters
    ----------
    out : output folder (created; files already there are written again, same bytes).
    c : the configuration (:class:`SynthConfig`, ``version="4.0.0"``); the test split needs
        ``c.secret``.
    workers, executor : where the garments are built (:func:`~dressmeup.data.synth.jobs.
        run_jobs`; the files do not depend on it).

    Returns
    -------
    ``out``.
    """
    if "test" in c.splits and c.secret is None:
        raise InputError("generator 4 seeds the test split from a secret: give one, or build "
                         "the train and val garments only (splits)")
    g4 = Gen4Config.from_synth(c)
    plan = make_plan(c, g4)
    out = Path(out)
    for sub in ("garments", "rest"):
        (out / "generator" / sub).mkdir(parents=True, exist_ok=True)
    gids = garment_order(plan)
    for gid in gids:
        write_garment_record(out / "generator" / "garments", gid, plan["garments"][gid])
    # any target's work names the garment: the build does not depend on the target
    works = [target_work(c, plan, gid, plan["garments"][gid]["targets"][0]) for gid in gids]
    bar = progress(range(len(works)), desc="designed garments", total=len(works))
    for work, files in zip(works, run_jobs(BuildJob(g4), works, workers=workers,
                                           executor=executor), strict=True):
        save_mesh(out / "generator" / "rest" / f"{work.gid}.ply", files.V0, files.F,
                  uv=files.uv, uv_faces=files.uv_faces)
        next(bar, None)
    for _ in bar:
        pass
    params = g4.params(c.seed)
    params["splits"] = [s for s in SPLITS if s in c.splits]
    atomic_write_text(out / DESIGNED_JSON, json.dumps({
        "generator": {"name": "dressmeup.data.synth", "version": VERSION, "params": params},
        "garments": {g: {k: plan["garments"][g][k] for k in ("split", "type", "category")}
                     for g in gids}}, indent=1, sort_keys=True) + "\n")
    return out


def garment_record(root: str | os.PathLike) -> Path:
    """The file that lists a generator-4 folder's garments: ``dataset.json`` of a generated
    dataset, else the :data:`DESIGNED_JSON` of designed garments.

    Raises
    ------
    InputError
        Neither exists, or the folder is not generator 4's.
    """
    root = Path(root)
    for path in (root / "dataset.json", root / DESIGNED_JSON):
        if path.is_file():
            version = str((parse_json_file(path).get("generator") or {}).get("version", ""))
            if not version.startswith("4."):
                raise InputError(f"{path}: generator {version or '?'}, not generator 4 (a "
                                 "...-v5 edition's data or designed garments)")
            return path
    raise InputError(f"{root}: neither dataset.json nor {DESIGNED_JSON}: not a generator-4 "
                     "dataset or designed garments ('dressmeup synth --edition E "
                     "--designed-garments')")


def designed_garments(root: str | os.PathLike, split: str,
                      categories: Sequence[str] | None = None
                      ) -> list[tuple[str, dict[str, Any], Path]]:
    """``[(garment id, {split, type, category, ...}, rest mesh path), ...]`` of ``split`` (in
    ``categories`` when given), sorted by id, from :func:`garment_record`'s file."""
    root = Path(root)
    garments = parse_json_file(garment_record(root))["garments"]
    return [(g, v, root / "generator" / "rest" / f"{g}.ply") for g, v in sorted(garments.items())
            if v["split"] == split and (categories is None or v["category"] in categories)]
