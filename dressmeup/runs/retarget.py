"""Running a retargeting baseline over an edition's pairs into a submission."""

from __future__ import annotations

import inspect
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.scoring.provenance import hardware
from dressmeup.bench.scoring.submission import write_submission
from dressmeup.bench.tasks.retarget.data import edition_pairs
from dressmeup.data import Dataset
from dressmeup.executors import require_shared
from dressmeup.methods.retarget import get_method
from dressmeup.methods.retarget.run import predict_pairs, training_triplets
from dressmeup.runs.common import BASELINE_AUTHORS, Log, SkippedBaseline, _quiet, shipped_weights


def run_retarget_baseline(method_name: str, edition: str | Edition, data_root: str | os.PathLike,
                          out: str | os.PathLike, *, train_steps: int = 150,
                          max_triplets: int = 8, limit: int | None = None, url: str = "",
                          overwrite: bool = False, log: Log = _quiet, executor: Any = None,
                          **hyperparameters: Any) -> Path:
    """Run one retargeting baseline over the edition's pairs into a submission folder.

    ``executor`` (:mod:`dressmeup.executors`) runs one job per pair (default: in this
    process); training, when any, runs here first.

    The one path from a retargeting method to a submission: ``dressmeup baseline retarget``,
    ``dressmeup demo`` and ``benchmarks/run_baselines.py`` all come here, so every
    submission records its hardware (:func:`dressmeup.bench.scoring.provenance.hardware`) and
    hyperparameters the same way.

    Trainable methods (with ``fit``) use the weights they ship for the dataset's body model,
    or ``weights=`` given as a hyperparameter; without either they are first trained
    self-supervised on the ``train`` split (``train_steps`` steps over ``max_triplets``
    triplets; no ground truth is read), or skipped when ``train_steps`` is 0.

    Parameters
    ----------
    method_name : a name of :func:`dressmeup.methods.retarget.get_method` (``+`` chains).
    edition, data_root, out : the edition, its data and the submission folder to write.
    train_steps, max_triplets : training of trainable methods without weights (see above).
    limit : only the first ``limit`` pairs (an incomplete submission, for smoke tests).
    url : ``submission.json`` ``url``.
    overwrite : write into a non-empty ``out``.
    log : called with one line per thing done.
    **hyperparameters : passed to the method (recorded with ``repr``).

    Raises
    ------
    SkippedBaseline
        A trainable method without weights while training is off (the message says how
        to train it).
    """
    ed = load_edition(edition)
    ds = Dataset(data_root)
    method = get_method(method_name, **hyperparameters)
    trained = ""
    if hasattr(method, "fit") and "weights" not in hyperparameters:
        body_model = ds[0].body().model
        shipped = shipped_weights(method, body_model)
        if shipped is not None:
            trained = f", shipped weights {shipped.name}"
        elif train_steps <= 0:
            raise SkippedBaseline(
                f"trainable and no shipped weights for the {body_model} body; training is off "
                f"here (train with 'dressmeup baseline train-retarget --data {data_root} "
                f"--out w.pt', then '--weights w.pt')")
        else:
            names = getattr(type(method), "hyperparameter_names", None)  # a chain has none
            takes = names() if names else inspect.signature(type(method).__init__).parameters
            if "steps" in takes and "steps" not in hyperparameters:
                method = get_method(method_name, steps=train_steps, **hyperparameters)
            t0 = time.perf_counter()
            supervised = bool(getattr(getattr(method, "method", method), "supervised", False))
            triplets, model = training_triplets(ds, "train", max_triplets, seed=0, with_truth=supervised)
            method.fit(triplets, model)
            trained = (f", trained {train_steps} steps ({time.perf_counter() - t0:.0f} s) on "
                       f"{len(triplets)} train-split triplets")
    if executor is not None:
        require_shared(executor, data_root)
    preds, seconds = predict_pairs(method, edition_pairs(ed, ds), limit=limit,
                                   executor=executor)
    runtime = float(np.mean(seconds)) if seconds else 0.0
    path = write_submission(out, preds, edition=ed, method=method_name,
                            authors=BASELINE_AUTHORS, url=url,
                            hardware=hardware(), runtime_per_sample_s=runtime,
                            extra={"hyperparameters": {k: repr(v)
                                                       for k, v in hyperparameters.items()}},
                            overwrite=overwrite)
    log(f"  {method_name}: {len(preds)} pairs, {runtime:.2f} s/pair{trained}")
    return path
