"""One synthetic capture of a dataset sample, fused and scored: the capture stage end to end on
known ground truth (``dressmeup demo`` step 4 and a quick health check of a dataset's scans)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from dressmeup.capture.rig import ring_rig
from dressmeup.capture.synthetic import (
    NoiseModel,
    load_ground_truth,
    subject_from_sample,
    synth_capture,
)
from dressmeup.data.dataset import Dataset
from dressmeup.errors import InputError
from dressmeup.fusion.pipeline import fuse_session
from dressmeup.io.ply import write_ply
from dressmeup.metrics import fusion_quality

__all__ = ["fuse_synthetic_sample"]


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

    t0 = time.perf_counter()
    ds = Dataset(data_root)
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
