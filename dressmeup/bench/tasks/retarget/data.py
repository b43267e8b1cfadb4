"""Retargeting task: the pairs of an edition and the files a submission holds.

A pair ``<source_id>__to__<target_id>`` asks for the source garment moved onto the target
body; the ground truth is the same garment captured on the target subject in the target
pose. Its track (:attr:`dressmeup.data.RetargetPair.track`) is ``re-pose`` (same subject),
``re-shape`` (other subject, same pose) or ``cross`` (other subject and pose). An edition
with a ``pairs`` field scores a seeded sample of each track (:func:`edition_pairs`). A
prediction keeps the source garment's topology: ``<pair_id>.npz`` with ``vertices (n, 3)``
float (or a ``.ply`` / ``.obj`` with the source's faces).
"""

from __future__ import annotations

import functools
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.tasks.base import Item
from dressmeup.bench.tasks.common import (
    array_problems,
    check_pin,
    faces_problems,
    load_npz_arrays,
    open_dataset,
)
from dressmeup.errors import InputError
from dressmeup.io.mesh import load_mesh
from dressmeup.metrics.report import scale_mismatch

FILE_SUFFIXES = (".npz", ".ply", ".obj")


def dataset_problems(edition: Any, data_root: Path) -> tuple[dict[str, Any], list[str]]:
    """Check the dataset root against the edition pin (see :func:`check_pin`)."""
    return check_pin(edition, data_root)


def sample_pairs(pairs: list, pairs_spec: dict[str, Any],
                 declared: dict[str, str] | None = None) -> list:
    """The seeded per-track sample of retargeting pairs an edition scores.

    For every source garment and every track of ``pairs_spec["per_track"]`` (track -> n),
    ``n`` pairs are drawn without replacement (all when fewer) by a generator seeded with
    ``(seed, crc32(garment id), track index)``, so the choice for one garment does not
    depend on the others; tracks not named are dropped, with ``"categories"`` so are
    garments of other categories, and with ``"source_poses"`` every pair whose source is in
    another pose or whose target is in one of those poses (sources and targets then never
    overlap: every answer can be withheld; the thesis protocol: held-out poses).

    With ``"sources": {"pose": P, "subjects": N}`` (the v4 editions) the sources and the
    targets are disjoint, so that every answer can be withheld: per garment, N of its
    subjects, drawn by a generator seeded with ``(seed, crc32(garment id), 99)``, in pose P
    are the sources, and the pairs are those from a source to any sample that is not one
    (other pose of the same subject: re-pose; another subject in P: re-shape; another subject
    in another pose: cross). With ``"sources": "dataset"`` (the v5 editions) each garment's
    source is the sample its dataset declares (``dataset.json`` ``garments.<id>.source``,
    given as ``declared``), and the pairs are those from it to every other sample of the
    garment.

    Parameters
    ----------
    pairs : :class:`dressmeup.data.RetargetPair` list (e.g. ``ds.retarget_pairs(split)``).
    pairs_spec : the edition's ``pairs`` field (``{"seed": int, "per_track": {...}}``); empty:
        every pair is kept.
    declared : garment id -> its source sample id (for ``"sources": "dataset"``).

    Returns
    -------
    list of pairs sorted by pair id.

    Raises
    ------
    InputError
        The data has no pair in a track of ``per_track`` (its column of every table would
        be empty).
    """

    if not pairs_spec:
        return sorted(pairs, key=lambda p: p.pair_id)
    seed = int(pairs_spec.get("seed", 0))
    per = dict(pairs_spec["per_track"])
    cats = pairs_spec.get("categories")
    if cats:
        pairs = [p for p in pairs if p.source.category in cats]
    poses = pairs_spec.get("source_poses")
    if poses:
        pairs = [p for p in pairs if p.source.pose_id in poses
                 and p.target.pose_id not in poses]
    if pairs_spec.get("sources") == "dataset":
        if not declared:
            raise InputError("pairs.sources is \"dataset\", but this data declares no source "
                             "sample per garment (dataset.json garments.<id>.source): score "
                             "the edition on the data it is pinned to")
        pairs = [p for p in pairs if declared.get(p.source.garment_id) == p.source.sample_id]
    elif pairs_spec.get("sources"):
        pairs = disjoint_pairs(pairs, pairs_spec["sources"], seed)
    order = sorted(per)
    groups: dict[tuple[str, str], list] = {}
    for p in pairs:
        if p.track in per:
            groups.setdefault((p.source.garment_id, p.track), []).append(p)
    empty = [t for t in order if not any(track == t for _, track in groups)]
    if empty:
        raise InputError(f"pairs.per_track names track(s) {', '.join(map(repr, empty))}, but "
                         "this data has no pair in them (after the categories, source_poses "
                         "and sources filters): remove them, or score the edition on the data "
                         "it is pinned to")
    out = []
    for (g, track), group in sorted(groups.items()):
        group = sorted(group, key=lambda p: p.pair_id)
        rng = np.random.default_rng([seed, zlib.crc32(g.encode()), order.index(track)])
        n = min(int(per[track]), len(group))
        out += [group[i] for i in sorted(rng.choice(len(group), size=n, replace=False))]
    return sorted(out, key=lambda p: p.pair_id)


def disjoint_pairs(pairs: list, sources: dict[str, Any], seed: int) -> list:
    """The pairs whose source is one of each garment's chosen sources (``sources["subjects"]``
    subjects in pose ``sources["pose"]``, seeded per garment) and whose target is none of
    them (see :func:`sample_pairs`)."""
    subjects: dict[str, set[str]] = {}
    for p in pairs:
        subjects.setdefault(p.source.garment_id, set()).add(p.source.subject_id)
    chosen = {}
    for g, subs in sorted(subjects.items()):
        subs_sorted = sorted(subs)
        rng = np.random.default_rng([seed, zlib.crc32(g.encode()), 99])
        k = min(int(sources["subjects"]), len(subs_sorted))
        chosen[g] = {subs_sorted[i] for i in rng.choice(len(subs_sorted), size=k,
                                                         replace=False)}

    def is_source(s) -> bool:
        return s.pose_id == sources["pose"] and s.subject_id in chosen[s.garment_id]

    return [p for p in pairs if is_source(p.source) and not is_source(p.target)]


def edition_pairs(edition: Any, dataset: Any) -> list:
    """The retargeting pairs an edition scores on ``dataset`` (its split, sampled per track
    when the edition has a ``pairs`` field; see :func:`sample_pairs`, whose errors are
    prefixed with the edition's file)."""
    try:
        garments = dataset.info.get("garments", {})
        declared = {g: v["source"] for g, v in garments.items()
                    if isinstance(v, dict) and isinstance(v.get("source"), str)}
        return sample_pairs(dataset.retarget_pairs(edition.split), getattr(edition, "pairs", {}),
                            declared)
    except InputError as exc:
        raise InputError(f"edition {getattr(edition, 'source', edition.name)}: {exc}") from None


def items(edition: Any, data_root: Path) -> list[Item]:
    """One :class:`Item` per retargeting pair of the edition's split, sorted by pair id.

    ``expect["n_vertices"]`` is the source garment's vertex count (from the manifest);
    ``meta`` carries source/target/garment ids and, for editions with tracks, the track
    and both subjects.
    """
    ds = open_dataset(str(Path(data_root).resolve()))
    manifest = ds.manifest.set_index("sample_id")
    pairs = edition_pairs(edition, ds)
    if not pairs:
        raise InputError(f"dataset {data_root} has no retargeting pairs in split "
                         f"{edition.split!r} (edition {edition.name})")
    out = []
    with_tracks = bool(getattr(edition, "tracks", ()))  # v2 editions: no track column
    for pair in pairs:
        src, tgt = pair.source.sample_id, pair.target.sample_id
        row = manifest.loc[src]
        track = {"track": pair.track, "source_subject": pair.source.subject_id,
                 "target_subject": pair.target.subject_id,
                 "target_pose": pair.target.pose_id} if with_tracks else {}
        out.append(Item(
            item_id=pair.pair_id,
            category=str(row["category"]),
            expect={"n_vertices": int(row["garment_vertices"])},
            meta={"source_id": src, "target_id": tgt, "garment_id": str(row["garment_id"]),
                  **track, "data_root": str(Path(data_root).resolve())},
        ))
    out.sort(key=lambda it: it.item_id)
    return out


@functools.lru_cache(maxsize=64)
def source_garment(root: str, sample_id: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(n, 3) float64`` and faces ``(m, 3) int64`` of a sample's garment
    (cached)."""
    ds = open_dataset(root)
    g = _sample(ds, sample_id).garment()
    return np.asarray(g.vertices, dtype=np.float64), np.asarray(g.faces, dtype=np.int64)


def source_faces(root: str, sample_id: str) -> np.ndarray:
    """Faces ``(m, 3) int64`` of a sample's garment (cached)."""
    return source_garment(root, sample_id)[1]


def _sample(ds, sample_id: str):
    try:
        return ds[sample_id]
    except KeyError:
        raise InputError(f"sample {sample_id!r} not found in dataset {ds.root}") from None


def read_prediction(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Read a prediction file: ``(vertices (n, 3) float64, faces (m, 3) int64 or None)``.

    Raises
    ------
    InputError
        Unreadable file, missing ``vertices`` array.
    """
    if path.suffix.lower() == ".npz":
        arrays = load_npz_arrays(path, ("vertices", "faces"))
        if "vertices" not in arrays:
            raise InputError(f"{path.name}: no 'vertices' array (found keys: "
                             f"{', '.join(_npz_keys(path)) or 'none'})")
        return arrays["vertices"], arrays.get("faces")

    mesh = load_mesh(path)
    return mesh.vertices, mesh.faces


def _npz_keys(path: Path) -> list[str]:
    try:
        with np.load(path, allow_pickle=False) as z:
            return list(z.files)
    except Exception:  # noqa: BLE001 - only used to enrich an error message
        return []


def check_file(path: Path, item: Item, edition: Any) -> list[str]:
    """Problems of one prediction file (empty list when it is valid)."""
    try:
        V, F = read_prediction(path)
    except (InputError, FileNotFoundError, OSError, ValueError) as exc:
        return [f"unreadable: {exc}"]
    n = item.expect["n_vertices"]
    problems = array_problems("vertices", V, 3, n)
    if not problems:
        try:
            src_V = source_garment(item.meta["data_root"], item.meta["source_id"])[0]
        except (InputError, OSError):  # the dataset's own problems are reported elsewhere
            src_V = np.zeros((0, 3))
        mismatch = scale_mismatch(V, src_V, "prediction", "source garment")
        if mismatch:
            problems.append(f"'vertices': {mismatch}")
    if F is not None:
        fp = faces_problems("faces", F, V.shape[0] if V.ndim == 2 else 0)
        if fp:
            problems += fp
        else:
            src_F = source_faces(item.meta["data_root"], item.meta["source_id"])
            if F.shape != src_F.shape or not np.array_equal(F, src_F):
                problems.append("faces differ from the source garment's faces (a prediction "
                                "keeps the source topology; store only 'vertices')")
    return problems
