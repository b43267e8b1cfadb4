"""Running a UV parameterisation baseline over an edition's meshes into a submission."""

from __future__ import annotations

import inspect
import os
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.scoring.provenance import hardware
from dressmeup.bench.scoring.submission import write_submission
from dressmeup.data.uvmeshes import meshes
from dressmeup.executors import LocalExecutor, in_order, require_shared
from dressmeup.io.mesh import load_mesh
from dressmeup.methods.uvparam import get_method
from dressmeup.progress import progress
from dressmeup.runs.common import BASELINE_AUTHORS, Log, _quiet


class UVMeshJob:
    """One mesh's job for an executor: ``job(mesh_record) -> UVResult`` (picklable when the
    method is; runs on a pool or Dask worker)."""

    __name__ = "uvparam_mesh"

    def __init__(self, method: Any) -> None:
        self.method = method
        self.takes_category = "category" in inspect.signature(method.parameterize).parameters

    def __call__(self, m: Any) -> Any:
        mesh = load_mesh(m.path)
        kw = {"category": m.category} if self.takes_category else {}
        return self.method.parameterize(mesh.vertices, mesh.faces, **kw)


def run_uvparam_baseline(method_name: str, edition: str | Edition, data_root: str | os.PathLike,
                         out: str | os.PathLike, *, log: Log = _quiet, executor: Any = None,
                         overwrite: bool = False, **hyperparameters: Any) -> Path:
    """Run one UV baseline over the edition's meshes into a submission folder.

    The one path from a UV method to a submission of an edition's mesh set
    (``dressmeup baseline uvparam --data``, ``dressmeup demo``, ``benchmarks/run_baselines.py``).
    ``executor`` (:mod:`dressmeup.executors`) runs one job per mesh (default: in this
    process); the first mesh that fails fails the run, as in the loop. Hyperparameters, when
    given, are recorded in ``submission.json`` with ``repr``; ``overwrite`` writes into a
    non-empty ``out``."""
    ed = load_edition(edition)
    method = get_method(method_name, **hyperparameters)
    records = list(meshes(data_root, ed.split))
    executor = executor or LocalExecutor(1)
    require_shared(executor, data_root)
    preds, secs, tracks = {}, [], set()
    done = progress(executor.run(UVMeshJob(method), records), desc=f"uvparam {method_name}",
                    total=len(records))
    for i, res in in_order(done):
        if isinstance(res, BaseException):
            raise res
        m = records[i]
        preds[m.mesh_id] = {"uv": res.uv, "uv_faces": res.uv_faces,
                            "chart_ids": res.chart_ids, "seconds": np.float64(res.seconds)}
        secs.append(res.seconds)
        # methods that optimise on the mesh report nothing: they are per-mesh
        tracks.add(res.info.get("track", "per-mesh"))
    runtime = float(np.mean(secs)) if secs else 0.0
    # the pretrained track only when every mesh was unseen by the method (checked, not declared)
    extra = {"track": "pretrained" if tracks == {"pretrained"} else "per-mesh"} \
        if getattr(ed, "tracks", None) else {}
    if hyperparameters:
        extra["hyperparameters"] = {k: repr(v) for k, v in hyperparameters.items()}
    path = write_submission(out, preds, edition=ed, method=method_name,
                            authors=BASELINE_AUTHORS, url="",
                            hardware=hardware(), runtime_per_sample_s=runtime, extra=extra or None,
                            overwrite=overwrite)
    log(f"  {method_name}: {len(preds)} meshes, {runtime:.2f} s/mesh")
    return path
