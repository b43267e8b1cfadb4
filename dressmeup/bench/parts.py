"""Withheld answers: which files of an edition's data a participant may see.

Every edition's data split into a **public** part (train and val complete, and of the scored
split only what a method receives) and a **private** part (everything scoring needs); the
mechanism is :mod:`dressmeup.data.parts`, the rule per task is here:

- ``retarget``: the source samples of the scored pairs keep garment, texture and body; every
  other sample of the split (targets, unused) keeps its body only; every scan of the split,
  and the generator's files of the split's garments and samples (``generator/fitted``,
  ``generator/rest``, ``generator/stats``, ``generator/garments``, ``generator/failed``) are
  withheld. A sample that is both a source and a
  target must publish its garment: the pairs targeting it have public answers
  (:attr:`Export.public_answers`; v3 editions drew their pairs that way, v4 ones do not);
- ``registration``: scans public; true bodies, garments (whose inner surface hugs the body)
  and textures withheld;
- ``fusion``: scans, garments and bodies withheld; the public part carries one rendered
  capture session per item instead (``captures/<sample_id>/``, its ground truth removed,
  with ``sample_to_world.json``: submit meshes in sample coordinates);
- ``correspondence``: the split's garments are the inputs; nothing else is needed;
- ``uvparam``: nothing to withhold (the metrics need only the mesh): both parts are the
  mesh set.

:func:`leaks` is the check that no withheld answer is equal, or a rigid or vertex-order copy,
of a public file.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.tasks import get_task
from dressmeup.bench.tasks.common import open_dataset, other_data_reason
from dressmeup.bench.tasks.retarget.data import edition_pairs
from dressmeup.capture.rig import ring_rig
from dressmeup.capture.synthetic import NoiseModel, subject_from_sample, synth_capture
from dressmeup.capture.synthetic.ground_truth import load_ground_truth
from dressmeup.data import layout
from dressmeup.data.manifest import read_manifest
from dressmeup.data.parts import VOLATILE_KEYS, PartsReport, Withheld, write_parts
from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_dir, atomic_write_text
from dressmeup.io.hashing import sha256_file
from dressmeup.io.jsonio import parse_json_file
from dressmeup.io.mesh import load_mesh

#: generator files of the scored split are withheld when their name is one of its ids
GENERATOR_DIR = "generator"
CAPTURES_DIR = "captures"


@dataclass
class Export:
    """The result of :func:`export_parts`.

    Attributes
    ----------
    edition : the edition's name.
    parts : what was written (:class:`~dressmeup.data.parts.PartsReport`).
    public_answers : scored item ids whose answer is in the public part (another item's
        input), with the reason; empty for editions drawn to withhold every answer.
    """

    edition: str
    parts: PartsReport
    public_answers: dict[str, str] = field(default_factory=dict)


def _rows(root: Path) -> list[dict[str, Any]]:
    return read_manifest(root / layout.MANIFEST).to_pylist()


def _generator_files(root: Path, ids: set[str]) -> tuple[str, ...]:
    """Files under ``generator/`` named after one of ``ids`` (``G07.ply``, ``G07-S02.ply``,
    ``S01-G07-P2.json``), or with one of them between dashes (``S05-G07-P3.json``: a failed
    target of a garment, which has no manifest row)."""
    gen = root / GENERATOR_DIR
    if not gen.is_dir():
        return ()
    out = []
    for p in sorted(gen.rglob("*")):
        if not p.is_file() or p.name.startswith("."):
            continue
        stem = p.name.split(".")[0]
        if (stem in ids or any(stem.startswith(i + "-") for i in ids)
                or any(part in ids for part in stem.split("-"))):
            out.append(p.relative_to(root).as_posix())
    return tuple(out)


def _split_ids(rows: list[dict[str, Any]], split: str) -> tuple[list[dict[str, Any]], set[str]]:
    scored = [r for r in rows if r.get("split") == split]
    ids = {r["sample_id"] for r in scored} | {r["garment_id"] for r in scored}
    return scored, ids


def retarget_withheld(edition: Edition, root: Path) -> tuple[Withheld, dict[str, str]]:
    """The retargeting rule (module docstring): what is withheld, and the pairs whose answer
    is public because their target is also a source."""
    rows = _rows(root)
    scored, ids = _split_ids(rows, edition.split)
    pairs = edition_pairs(edition, open_dataset(str(root.resolve())))
    sources = {p.source.sample_id for p in pairs}
    fields = {r["sample_id"]: (("scan",) if r["sample_id"] in sources
                               else ("garment", "texture", "scan")) for r in scored}
    public = {p.pair_id: (f"its target {p.target.sample_id} is the source of another pair, "
                          "so its garment is an input")
              for p in pairs if p.target.sample_id in sources}
    return Withheld(fields=fields, files=_generator_files(root, ids),
                    private_splits=(edition.split,)), public


def registration_withheld(edition: Edition, root: Path) -> Withheld:
    """The registration rule: scans public; bodies, garments and textures withheld."""
    scored, ids = _split_ids(_rows(root), edition.split)
    return Withheld(fields={r["sample_id"]: ("garment", "texture", "body") for r in scored},
                    files=_generator_files(root, ids), private_splits=(edition.split,))


def fusion_withheld(edition: Edition, root: Path, seed: int = 0) -> Withheld:
    """The fusion rule: every file of the scored samples withheld; one rendered capture
    session per item in the public part instead."""
    scored, ids = _split_ids(_rows(root), edition.split)
    items = sorted(r["sample_id"] for r in scored if r.get("scan_path"))

    def captures(public_root: Path) -> list[str]:
        return render_captures(root, items, public_root / CAPTURES_DIR, seed=seed)

    return Withheld(fields={r["sample_id"]: ("garment", "texture", "scan", "body")
                            for r in scored},
                    files=_generator_files(root, ids), private_splits=(edition.split,),
                    public_extra=captures)


def render_captures(root: Path, sample_ids: list[str], out: Path, seed: int = 0) -> list[str]:
    """Render one synthetic capture session per sample (the default ring rig, Kinect-like
    noise) into ``out/<sample_id>/``, without its ground truth, plus
    ``sample_to_world.json`` (the 4 x 4 placement of the sample's scan in the rig's world, in
    metres). Returns the written files relative to ``out.parent``."""
    written = []
    for sid in sample_ids:
        sample = open_dataset(str(root.resolve()))[sid]
        session = out / sid
        synth_capture(subject_from_sample(sample.path("scan").parent), ring_rig(), session,
                      noise=NoiseModel(), seed=seed)
        T = load_ground_truth(session).subject_to_world
        shutil.rmtree(session / "ground_truth")
        atomic_write_text(session / "sample_to_world.json",
                          json.dumps({"sample_to_world": np.asarray(T).tolist(),
                                      "units": "m"}, indent=1) + "\n")
        written += [p.relative_to(out.parent).as_posix()
                    for p in sorted(session.rglob("*")) if p.is_file()]
    return written


def withheld_for(edition: Edition, root: Path) -> tuple[Withheld, dict[str, str]]:
    """The task's rule for ``edition`` on the full data at ``root``."""
    task = edition.task
    if task == "retarget":
        return retarget_withheld(edition, root)
    if task == "registration":
        return registration_withheld(edition, root), {}
    if task == "fusion":
        return fusion_withheld(edition, root), {}
    if task == "correspondence":
        scored, ids = _split_ids(_rows(root), edition.split)
        return Withheld(fields={r["sample_id"]: ("scan", "body") for r in scored},
                        files=_generator_files(root, ids),
                        private_splits=(edition.split,)), {}
    raise InputError(f"no withheld-answer rule for task {task!r}")


def export_parts(edition: str | Edition, root: str | Path, public_out: str | Path | None,
                 private_out: str | Path | None, allow_other_data: bool = False) -> Export:
    """Split the full data of ``edition`` at ``root`` into its public and private parts.

    Parameters
    ----------
    edition : the edition (name, path or object) whose data ``root`` holds.
    root : the full data (as generated, or as pinned for a real dataset).
    public_out, private_out : new folders (None: skip that part).

    Raises
    ------
    InputError
        ``root`` is not the edition's data (its pin), is a part already, or an output
        folder is not empty.
    """
    ed = load_edition(edition)
    root = Path(root)
    info, problems = get_task(ed.task).dataset_problems(ed, root)
    other = other_data_reason(ed, info, root)
    if other and not allow_other_data:
        problems.append(other + " (pass allow_other_data to export them anyway)")
    if problems:
        raise InputError(f"{root} is not the data of edition {ed.name}:\n  - "
                         + "\n  - ".join(problems))
    label = {"edition": ed.name, "edition_hash": ed.hash}
    if ed.task == "uvparam":
        return Export(ed.name, _copy_meshset(root, public_out, private_out, label))
    withheld, public = withheld_for(ed, root)
    return Export(ed.name, write_parts(root, withheld, public_out, private_out, label), public)


def _copy_meshset(root: Path, public_out, private_out, label: dict[str, Any]) -> PartsReport:
    """uvparam: both parts are the mesh set (nothing is withheld)."""
    report = PartsReport(public=Path(public_out or ""), private=Path(private_out or ""))
    raw = parse_json_file(root / layout.DATASET_JSON)
    if not isinstance(raw, dict):
        raise InputError(f"{root / layout.DATASET_JSON}: expected a JSON object")
    info = {k: v for k, v in raw.items() if k not in VOLATILE_KEYS}
    for name, out in (("public", public_out), ("private", private_out)):
        if out is None:
            continue
        with atomic_dir(out) as tmp:
            shutil.copytree(root, tmp, dirs_exist_ok=True,
                            ignore=shutil.ignore_patterns(".*", layout.DATASET_JSON))
            atomic_write_text(tmp / layout.DATASET_JSON, json.dumps(
                {**info, "part": {"part": name, **label}}, indent=2) + "\n")
        files = [p for p in Path(out).rglob("*") if p.is_file()]
        setattr(report, f"{name}_files", len(files))
        setattr(report, f"{name}_bytes", sum(p.stat().st_size for p in files))
    return report


# ------------------------------------------------------------------------------ leak check
#: answers the leak check compares: meshes and the generator's per-sample statistics
ANSWER_SUFFIXES = (".ply", ".obj", ".json")


def _signature(V: np.ndarray) -> np.ndarray:
    """Sorted distances of the vertices to their centroid: the same for a rigid motion or
    a reordering of the vertices."""
    return np.sort(np.linalg.norm(V - V.mean(axis=0), axis=1))


def leaks(public: str | Path, private: str | Path, tol: float = 1e-7) -> list[str]:
    """Withheld answers of ``private`` that the public part carries anyway.

    A withheld file (in the private part, absent from the public one) leaks when a public
    file has the same bytes, or, for meshes, the same vertex count and the same
    rigid-and-reordering invariant signature (sorted centroid distances, within ``tol``
    metres): a copy moved rigidly or with its vertices permuted. Textures (``.png``) are
    not answers (every sample of a garment shares its image) and are not compared.

    Returns
    -------
    One line per leak (empty: none).
    """
    public, private = Path(public), Path(private)
    pub = {p.relative_to(public).as_posix(): p for p in public.rglob("*")
           if p.is_file() and p.suffix.lower() != ".png"}
    priv = {p.relative_to(private).as_posix(): p for p in private.rglob("*")
            if p.is_file() and p.suffix.lower() in ANSWER_SUFFIXES
            and p.name not in (layout.DATASET_JSON,)}
    withheld = {rel: p for rel, p in priv.items() if rel not in pub}
    by_hash: dict[str, list[str]] = {}
    for rel, p in pub.items():
        by_hash.setdefault(sha256_file(p), []).append(rel)
    sigs: dict[int, list[tuple[str, np.ndarray]]] = {}
    for rel, p in pub.items():
        if p.suffix.lower() in (".ply", ".obj"):
            V = _vertices(p)
            if V is not None:
                sigs.setdefault(len(V), []).append((rel, _signature(V)))
    out = []
    for rel, p in sorted(withheld.items()):
        same = by_hash.get(sha256_file(p))
        if same:
            out.append(f"{rel}: the same bytes as public {same[0]}")
            continue
        if p.suffix.lower() not in (".ply", ".obj"):
            continue
        V = _vertices(p)
        if V is None:
            continue
        sig = _signature(V)
        for prel, psig in sigs.get(len(V), ()):
            if np.allclose(sig, psig, rtol=0.0, atol=tol):
                out.append(f"{rel}: a rigid or reordered copy of public {prel}")
                break
    return out


def _vertices(path: Path) -> np.ndarray | None:
    try:
        return np.asarray(load_mesh(path).vertices, dtype=np.float64)
    except (InputError, OSError, ValueError):
        return None


