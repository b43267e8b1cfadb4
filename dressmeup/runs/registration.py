"""Running the registration baseline (the toolkit's registrar) over an edition's scans."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.scoring.provenance import hardware
from dressmeup.bench.scoring.submission import write_submission
from dressmeup.bench.tasks.common import open_dataset
from dressmeup.bench.tasks.registration.data import items
from dressmeup.body import get_body_model
from dressmeup.body.registration import register
from dressmeup.errors import InputError
from dressmeup.executors import LocalExecutor, in_order, require_shared
from dressmeup.progress import progress
from dressmeup.runs.common import BASELINE_AUTHORS, Log, _quiet, registration_methods


class RegisterJob:
    """One registration fit for an executor (:mod:`dressmeup.executors`):
    ``RegisterJob(data_root, options)(sample_id) -> (body-parameter arrays, CPU seconds)``;
    the scan is the sample's ``scan.ply``, the body model the one of its true body."""

    __name__ = "register"

    def __init__(self, data_root: str | os.PathLike, options: dict[str, Any]) -> None:
        self.data_root, self.options = str(data_root), dict(options)

    def __call__(self, sample_id: str) -> tuple[dict[str, np.ndarray], float]:
        sample = open_dataset(self.data_root)[sample_id]
        scan = sample.scan()
        if scan is None:
            raise InputError(f"sample {sample_id} of {self.data_root} has no scan.ply to register")
        t0 = time.process_time()
        # quiet by default: one progress bar per scan inside a job would flood the run's log
        options = {"verbose": False, **self.options}
        p = register(scan, get_body_model(sample.body().model), **options)
        arrays = {"model": np.array(p.model), "gender": np.array(p.gender), "shape": p.shape,
                  "pose": p.pose, "transl": p.transl, "scale": np.array(p.scale, np.float64)}
        return arrays, time.process_time() - t0


def run_registration_baseline(method_name: str, edition: str | Edition,
                              data_root: str | os.PathLike, out: str | os.PathLike, *,
                              log: Log = _quiet, executor: Any = None, overwrite: bool = False,
                              **options: Any) -> Path:
    """Fit the body model to every scan of the edition's split into a submission folder.

    ``method_name`` is ``register`` (:func:`registration_methods`); ``options`` go to
    :func:`dressmeup.body.registration.register` (recorded in ``submission.json``).
    ``executor`` runs one job per scan (default: in this process); ``runtime_per_sample_s``
    is the mean CPU seconds of one fit."""
    if method_name not in registration_methods():
        raise InputError(f"registration baseline {method_name!r}: known "
                         f"{registration_methods()}")
    ed = load_edition(edition)
    ids = [it.item_id for it in items(ed, Path(data_root))]
    executor = executor or LocalExecutor(1)
    require_shared(executor, data_root)
    preds, cpu = {}, []
    done = progress(executor.run(RegisterJob(data_root, options), ids),
                    desc=f"registration {method_name}", total=len(ids))
    for i, res in in_order(done):
        if isinstance(res, BaseException):
            raise res
        preds[ids[i]], sec = res
        cpu.append(sec)
    runtime = float(np.mean(cpu)) if cpu else 0.0
    extra = {"hyperparameters": {k: repr(v) for k, v in options.items()}} if options else None
    path = write_submission(out, preds, edition=ed, method=method_name,
                            authors=BASELINE_AUTHORS, url="", hardware=hardware(),
                            runtime_per_sample_s=runtime, extra=extra, overwrite=overwrite)
    log(f"  {method_name}: {len(preds)} scans, {runtime:.1f} CPU-s/scan")
    return path
