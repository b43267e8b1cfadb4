"""Building the data an edition pins (the synthetic generator, UV mesh sets) and telling
whether data on disk are the pinned ones."""

from __future__ import annotations

import inspect
import os
import time
from pathlib import Path

from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.score import other_data_reason
from dressmeup.bench.tasks.common import manifest_sha256
from dressmeup.data.synth import generate_dataset
from dressmeup.data.uvmeshes import build_mesh_set
from dressmeup.errors import InputError
from dressmeup.runs.common import Log, _quiet


def build_data(edition: str | Edition, root: str | os.PathLike, log: Log = _quiet) -> Path:
    """Generate (or resume) the data an edition pins into ``root``.

    ``retarget`` editions of the synthetic generator call
    :func:`dressmeup.data.synth.generate_dataset` with the pinned parameters and seed;
    ``uvparam`` editions build their mesh set. Real datasets cannot be generated.

    Raises
    ------
    InputError
        For editions of real datasets or unknown generators.
    """
    ed = load_edition(edition)
    root = Path(root)
    pin = ed.dataset
    if pin.kind != "generated":
        raise InputError(f"edition {ed.name} is scored on a real dataset (manifest "
                         f"{pin.manifest_sha256[:12]}...); it cannot be generated")
    t0 = time.perf_counter()
    if ed.task == "uvparam":
        build_mesh_set(root, mesh_ids=pin.params.get("mesh_ids", ()),
                       garments=pin.params.get("garments"), seed=pin.seed)
    else:
        accepted = set(inspect.signature(generate_dataset).parameters)
        unknown = sorted(set(pin.params) - accepted)
        if unknown:
            raise InputError(f"edition {ed.name}: generator parameters {unknown} are not "
                             f"accepted by this toolkit's generate_dataset")
        generate_dataset(root, seed=pin.seed, **pin.params)
    log(f"data for {ed.name}: {root} ({time.perf_counter() - t0:.0f} s)")
    other = data_differs(ed, root)
    if other:
        log(f"warning: {other}. This machine generates other data than the one that pinned "
            "the edition (docs/synthetic-data.md, 'Reproducibility'); scores on it are marked "
            "not comparable")
    return root


def data_differs(edition: str | Edition, root: str | os.PathLike) -> str | None:
    """Why the generated data at ``root`` are not the data ``edition`` pins (its
    ``expected_manifest_sha256``), or None when they are or the edition pins no manifest."""
    ed = load_edition(edition)
    if not (Path(root) / "manifest.parquet").is_file():
        return None
    return other_data_reason(ed, {"manifest_sha256": manifest_sha256(root)}, root)
