"""Fusion task: accuracy, completeness, Chamfer-L1 and F-scores of a reconstruction against
the sample's scan (:func:`dressmeup.metrics.fusion_quality`)."""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.tasks.base import STATUS_OK
from dressmeup.bench.tasks.sampletask import simple_jobs as jobs  # noqa: F401 - task API


def score_job(job: Mapping[str, Any]) -> dict[str, Any]:
    """Score one reconstruction."""
    from dressmeup.bench.tasks.fusion.config import THRESHOLDS
    from dressmeup.bench.tasks.fusion.data import read_mesh
    from dressmeup.bench.tasks.retarget.data import open_dataset
    from dressmeup.metrics import fusion_quality

    t0 = time.perf_counter()
    V, F = read_mesh(Path(job["pred_path"]))
    scan = open_dataset(job["meta"]["data_root"])[job["item_id"]].scan()
    opts = job["options"]
    q = fusion_quality((np.asarray(V, np.float64), np.asarray(F, np.int64)), scan,
                       thresholds=tuple(THRESHOLDS.values()), n_samples=int(opts["n_samples"]),
                       seed=int(opts["seed"]))
    values = {"accuracy": q.accuracy, "completeness": q.completeness,
              "chamfer_l1": q.chamfer_l1}
    for name, t in THRESHOLDS.items():
        values[name] = q.fscore[t]
    row = {"sample_id": job["item_id"], "category": job["category"],
           **{m: float(values[m]) for m in job["metrics"]}}
    row.update(status=STATUS_OK, error="", note="", seconds=time.perf_counter() - t0)
    return row


def fuse_synthetic_sample(data_root: str | Path, out: str | Path, sample_id: str | None = None,
                          noise: bool = True, n_samples: int = 100_000, seed: int = 0
                          ) -> dict[str, Any]:
    """Render one synthetic capture of a dataset sample, fuse it and score the fused scan.

    The default 7-camera ring rig renders the sample's clothed scan (``scan.ply``) with the
    Kinect-like noise model; the session is fused (filtering, ICP refinement, TSDF) and the
    result is compared with the exact scan of the session's ground truth (accuracy,
    completeness against the whole scan, Chamfer-L1, F-score at 5 mm).

    Parameters
    ----------
    data_root : a dataset with scans (e.g. the synthetic one).
    out : folder for the session and the fused mesh.
    sample_id : the sample (default: the first test sample with a scan).
    noise : use the depth noise model (False: exact depth).
    n_samples, seed : surface samples of the comparison.

    Returns
    -------
    dict with ``sample_id``, ``accuracy``, ``completeness``, ``chamfer_l1`` (metres),
    ``fscore_5mm``, ``seconds`` and ``session`` / ``mesh`` paths.
    """
    from dressmeup.bench.tasks.retarget.data import open_dataset
    from dressmeup.capture.rig import ring_rig
    from dressmeup.capture.synthetic import (
        NoiseModel,
        load_ground_truth,
        subject_from_sample,
        synth_capture,
    )
    from dressmeup.errors import InputError
    from dressmeup.fusion.pipeline import fuse_session, write_ply
    from dressmeup.metrics import fusion_quality

    t0 = time.perf_counter()
    ds = open_dataset(str(Path(data_root).resolve()))
    df = ds.manifest
    df = df[df["scan_path"].notna()]
    if sample_id is None:
        test = df[df["split"] == "test"]
        if not len(test) and not len(df):
            raise InputError(f"dataset {data_root} has no sample with a scan")
        sample_id = str((test if len(test) else df).sort_values("sample_id")["sample_id"].iloc[0])
    row = df[df["sample_id"] == sample_id]
    if not len(row):
        raise InputError(f"sample {sample_id!r} has no scan in {data_root}")
    sample_dir = (Path(data_root) / row["scan_path"].iloc[0]).parent
    out = Path(out)
    subject = subject_from_sample(sample_dir)
    session = synth_capture(subject, ring_rig(), out / "session",
                            noise=NoiseModel() if noise else NoiseModel(enabled=False), seed=seed)
    fused = fuse_session(session)
    mesh_path = out / "fused.ply"
    write_ply(mesh_path, fused.vertices, fused.faces)
    gt = load_ground_truth(session)
    q = fusion_quality((fused.vertices, fused.faces), (gt.vertices, gt.faces),
                       thresholds=(0.005,), n_samples=n_samples, seed=seed)
    return {"sample_id": sample_id, "accuracy": float(q.accuracy),
            "completeness": float(q.completeness), "chamfer_l1": float(q.chamfer_l1),
            "fscore_5mm": float(q.fscore[0.005]), "seconds": time.perf_counter() - t0,
            "session": str(session), "mesh": str(mesh_path)}
