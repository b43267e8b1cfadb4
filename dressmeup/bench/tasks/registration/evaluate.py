"""Registration task: compare fitted body parameters with the known ones."""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.tasks.base import STATUS_OK
from dressmeup.bench.tasks.common import open_dataset
from dressmeup.body import BodyParams, get_body_model
from dressmeup.geometry.sampling import sample_surface
from dressmeup.metrics import p2s


@functools.lru_cache(maxsize=4)
def _model(name: str):
    return get_body_model(name)


def score_job(job: Mapping[str, Any]) -> dict[str, Any]:
    """Score one fitted body."""

    t0 = time.perf_counter()
    sample = open_dataset(job["meta"]["data_root"])[job["item_id"]]
    pred = BodyParams.load(Path(job["pred_path"]))
    gt = sample.body()
    pm = _model(pred.model)
    po = pm.posed(pred)
    Vp = np.asarray(po.vertices, np.float64).reshape(-1, 3)
    values: dict[str, float] = {}
    notes = []
    if pred.model == gt.model:
        go = _model(gt.model).posed(gt)
        values["v2v"] = float(np.linalg.norm(
            Vp - np.asarray(go.vertices, np.float64).reshape(-1, 3), axis=1).mean())
        values["mpjpe"] = float(np.linalg.norm(
            np.asarray(po.joints, np.float64).reshape(-1, 3)
            - np.asarray(go.joints, np.float64).reshape(-1, 3), axis=1).mean())
    else:
        values["v2v"] = values["mpjpe"] = math.nan
        notes.append(f"v2v/mpjpe: fitted model {pred.model} differs from {gt.model}")
    scan = sample.scan()
    if scan is not None and "scan_p2s" in job["metrics"]:
        opts = job["options"]
        pts = sample_surface(scan[0], scan[1], int(opts["n_samples"]), seed=int(opts["seed"]))[0]
        values["scan_p2s"] = float(p2s(pts, (Vp, np.asarray(pm.faces, np.int64))))
    else:
        values["scan_p2s"] = math.nan
    row = {"sample_id": job["item_id"], "category": job["category"],
           **{m: values.get(m, math.nan) for m in job["metrics"]}}
    row.update(status=STATUS_OK, error="", note="; ".join(notes),
               seconds=time.perf_counter() - t0)
    return row
