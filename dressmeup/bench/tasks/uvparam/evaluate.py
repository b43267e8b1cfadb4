"""UV parameterisation task: score one UV map (QCE, ASE, flips, overlap, seams, time)."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.tasks.base import STATUS_OK, Item
from dressmeup.bench.tasks.uvparam.data import read_prediction
from dressmeup.errors import InputError
from dressmeup.io.mesh import load_mesh
from dressmeup.metrics.uv import ase_details, qce_details, uv_seams, uv_validity


def jobs(edition: Any, data_root: Path, files: Mapping[str, Path], items: Sequence[Item],
         show_progress: bool | None = None) -> list[dict[str, Any]]:
    """One job per mesh; in editions with tracks each row also gets the submission's
    ``track`` (from ``submission.json``)."""
    meta_extra: dict[str, Any] = {}
    if getattr(edition, "tracks", None) and files:
        meta_extra["track"] = submission_track(Path(next(iter(files.values()))).parent,
                                               edition.tracks)
    return [{"item_id": it.item_id, "category": it.category, "meta": {**it.meta, **meta_extra},
             "pred_path": str(files[it.item_id]), "metrics": list(edition.metrics),
             "options": dict(edition.options)} for it in items]


def submission_track(folder: Path, tracks: Sequence[str]) -> str:
    """The track a submission declares in ``submission.json`` (``"track"``).

    A submission that declares none is ranked in ``per-mesh`` (it may have optimised on the
    test meshes); ``pretrained`` is a claim that the method never saw them.

    Raises
    ------
    InputError
        The declared track is not one of the edition's.
    """

    path = Path(folder) / "submission.json"
    try:
        info = json.loads(path.read_text())
    except (OSError, ValueError):
        info = {}
    track = info.get("track", "per-mesh") if isinstance(info, dict) else "per-mesh"
    if track not in tracks:
        raise InputError(f"{path}: field 'track' is {track!r}; expected one of "
                         f"{', '.join(tracks)} (declare 'pretrained' only when the method "
                         "never trained or optimised on the test meshes)")
    return str(track)


def evaluate_uv(V: np.ndarray, F: np.ndarray, uv: np.ndarray, uv_faces: np.ndarray | None,
                metrics: Sequence[str], options: Mapping[str, Any]) -> dict[str, float]:
    """QCE (mean, max), ASE (|log| mean), flipped/overlap fractions, zero-area share, seam
    length, chart count and packing efficiency (each only when ``metrics`` names it).

    Parameters
    ----------
    V : (n, 3) float64, F : (m, 3) int64 the mesh.
    uv : (n, 2) per vertex or (k, 2) per corner with ``uv_faces (m, 3)``.
    """

    out: dict[str, float] = {}
    if {"qce", "qce_max", "zero_area"} & set(metrics):
        q = qce_details(V, F, uv, uv_faces)
        out.update(qce=float(q.mean), qce_max=float(q.max),
                   zero_area=float(q.zero_uv_area_fraction))
    if "ase" in metrics:
        out["ase"] = float(ase_details(V, F, uv, uv_faces).abs_mean)
    if {"seam_length", "charts", "packing"} & set(metrics):
        out.update(uv_seams(V, F, uv, uv_faces).as_dict())
    if {"flip", "overlap"} & set(metrics):
        v = uv_validity(V, F, uv, uv_faces,
                        resolution=int(options.get("overlap_resolution", 1024)))
        out.update(flip=float(v.flipped_fraction), overlap=float(v.overlap_fraction))
    return out


def score_job(job: Mapping[str, Any]) -> dict[str, Any]:
    """Score one UV map job."""

    t0 = time.perf_counter()
    mesh = load_mesh(job["meta"]["mesh_path"])
    a = read_prediction(Path(job["pred_path"]))
    values = evaluate_uv(mesh.vertices, mesh.faces, np.asarray(a["uv"], np.float64),
                         a.get("uv_faces"), job["metrics"], job["options"])
    if "time" in job["metrics"]:
        values["time"] = float(a["seconds"].reshape(-1)[0]) if "seconds" in a else math.nan
    row = {"sample_id": job["item_id"], "category": job["category"],
           **{k: values.get(k, math.nan) for k in job["metrics"]}}
    row["n_charts"] = float(len(np.unique(a["chart_ids"]))) if "chart_ids" in a else math.nan
    row["status"] = STATUS_OK
    row["error"] = ""
    row["note"] = "" if "seconds" in a or "time" not in job["metrics"] else \
        "time: the file has no 'seconds'"
    row["seconds"] = time.perf_counter() - t0
    return row
