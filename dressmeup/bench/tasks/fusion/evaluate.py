"""Fusion task: accuracy, completeness, Chamfer-L1 and F-scores of a reconstruction against
the sample's scan (:func:`dressmeup.metrics.fusion_quality`)."""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.tasks.base import STATUS_OK
from dressmeup.bench.tasks.common import open_dataset
from dressmeup.bench.tasks.fusion.config import THRESHOLDS
from dressmeup.bench.tasks.fusion.data import read_mesh
from dressmeup.metrics import fusion_quality


def score_job(job: Mapping[str, Any]) -> dict[str, Any]:
    """Score one reconstruction."""

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
