"""Training a refinement network on a dataset's split: the library side of
``dressmeup baseline train-retarget`` (the training loop itself is
:func:`dressmeup.methods.retarget.train.train_network`)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.data import Dataset
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.io.hashing import sha256_file
from dressmeup.methods.nn.record import training_machine
from dressmeup.methods.retarget import get_method
from dressmeup.methods.retarget.run import check_split_leakage, training_triplets
from dressmeup.methods.retarget.train import plot_history


def train_from_dataset(data, out, method: str = "isomap-refine", params: dict | None = None, split: str = "train",
                       val_split: str | None = "val", steps: int = 300, max_triplets: int | None = None,
                       max_val: int = 16, seed: int = 0, wall_minutes: float | None = None,
                       checkpoint=None, val_every: int = 50, checkpoint_every: int = 50, half: bool = False,
                       curves=None, exclude_garments=(), callback=None,
                       until_converged: bool = False) -> dict[str, Any]:
    """Train a refinement network on a dataset's split and save it: the library side of
    ``dressmeup baseline train-retarget``.

    Checks first that no training garment appears, by content, in another split
    (:func:`~dressmeup.methods.retarget.run.check_split_leakage`). Validation pairs (their
    ground truth included) score the validation curve and choose the kept step; the test split
    is never read. The checkpoint (default ``<out>.ckpt``) is resumed from when it exists.

    Parameters
    ----------
    data : dataset root; out : checkpoint path (.pt) to write.
    method : "isomap-refine" (self-supervised) or "isomap-refine-sup" (supervised).
    params : hyperparameters of the method (``steps`` and ``seed`` come from the arguments).
    split, val_split : training and validation splits (``val_split=None``: no validation).
    steps : total training steps; max_triplets : cap on training pairs (None: all);
    max_val : validation pairs used (seeded choice); seed : everything random.
    wall_minutes : wall budget of this invocation (None: none).
    checkpoint, val_every, checkpoint_every : see :func:`train_network`.
    half : store the weights as float16; curves : PNG path of the learning curves (None: none).
    exclude_garments : garment ids not to train on.
    until_converged : stop on the convergence rule (``steps`` is then the most steps; see
        :func:`~dressmeup.methods.retarget.train.train_network`).

    Returns
    -------
    dict: the ``training`` record stored in the checkpoint (steps and passes over the training
    pairs (one pair a step), wall and CPU seconds, where it stopped, kept step, data and
    garments, leakage check, the machine (:func:`~dressmeup.methods.nn.record.training_machine`),
    file size).
    """
    ds = Dataset(data)
    present = set(ds.manifest["split"].unique()) if "split" in ds.manifest else set()
    others = [s for s in ("val", "test") if s in present and s != split]
    leakage = check_split_leakage(ds, split, others)
    supervised = method.endswith("-sup")
    params = dict(params or {})
    params.update(steps=int(steps), seed=int(seed))
    m = get_method(method, **params)
    triplets, model = training_triplets(ds, split, max_triplets, seed=seed, exclude_garments=exclude_garments,
                                        with_truth=supervised)
    val = []
    if val_split and val_split in present:
        val, _ = training_triplets(ds, val_split, max_val, seed=seed + 1, with_truth=True)
    t0 = time.perf_counter()
    samples = m.prepare_many(triplets, model, "preparing training samples")
    val_samples = m.prepare_many(val, model, "preparing validation samples")
    prep_seconds = time.perf_counter() - t0
    out = Path(out)
    ckpt = Path(checkpoint) if checkpoint else out.with_suffix(out.suffix + ".ckpt")
    m.fit_samples(samples, model.name, callback=callback, val_samples=val_samples,
                  wall_seconds=None if wall_minutes is None else 60.0 * float(wall_minutes),
                  checkpoint=ckpt, val_every=val_every, checkpoint_every=checkpoint_every,
                  until_converged=until_converged)
    h = m.history_
    train_ids = sorted({p for p in leakage["train_garments"]} - set(exclude_garments))
    steps_done = len(h.train) and h.train[-1][0] + 1
    info = {
        "method": method, "data_manifest_sha256": sha256_file(Path(ds.root) / "manifest.parquet"),
        "split": split, "val_split": val_split if val else None, "train_pairs": len(triplets),
        "val_pairs": len(val), "train_garments": train_ids, "steps_done": steps_done,
        "passes": round(steps_done / len(triplets), 2),
        "steps_requested": int(steps), "stopped_by": h.stopped_by, "kept_step": h.best_step,
        "wall_seconds": round(h.wall_seconds, 1), "cpu_seconds": round(h.cpu_seconds, 1),
        "preparation_seconds": round(prep_seconds, 1), "machine": training_machine(),
        "leakage_check": {"compared_garments": leakage["compared_garments"],
                          "closest_same_topology_edge_difference": leakage["closest"]},
        "val_curve": [[s, lo, ed] for s, lo, ed in h.val],
        "hyperparameters": {k: v for k, v in m.get_params().items() if k not in ("weights", "device")},
    }
    _write_outputs(m, out, info, half, curves, f"{method}: {info['steps_done']} steps on "
                   f"{len(triplets)} train pairs")
    return info


def _write_outputs(m: Any, out: Path, info: dict[str, Any], half: bool, curves: Any,
                   caption: str) -> None:
    """The trained network with its ``training`` record (``info`` gains ``file_mb``), the
    history beside it (``<out>.history.json``) and, when ``curves`` names a PNG, the learning
    curves captioned ``caption`` plus times and the kept step."""
    h = m.history_
    m.save(out, half=half, info=info)
    info["file_mb"] = round(out.stat().st_size / 1e6, 2)
    hist_path = out.with_suffix(".history.json")
    atomic_write_bytes(hist_path, json.dumps({"training": info, "history": h.as_dict()}, indent=1,
                                             default=float).encode())
    if curves:
        vals = [r for r in h.val if np.isfinite(r[2])]
        plot_history(h, curves, title=f"{caption}, "
                                      f"{h.wall_seconds / 60:.0f} min wall / {h.cpu_seconds / 60:.0f} min CPU; "
                                      f"kept step {h.best_step}" + (f" (val ED {1000 * min(r[2] for r in vals):.1f} mm)"
                                                                   if vals else ""))
