"""Building the data an edition pins (the synthetic generator, UV mesh sets) and telling
whether data on disk are the pinned ones."""

from __future__ import annotations

import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

from dressmeup.bench.edition import (
    ALL_SPLITS,
    Edition,
    edition_secret,
    load_edition,
    secret_test_split_note,
    splits_to_generate,
)
from dressmeup.bench.parts import export_parts
from dressmeup.bench.tasks.common import manifest_sha256, other_data_reason
from dressmeup.data.parts import part_of
from dressmeup.data.synth import generate_dataset
from dressmeup.data.uvmeshes import build_mesh_set
from dressmeup.errors import InputError
from dressmeup.runs.common import Log, _quiet

#: the most worker processes ``build_data`` starts by itself (each loads the body model
#: and torch: several hundred MB)
MAX_AUTO_WORKERS = 8


def build_data(edition: str | Edition, root: str | os.PathLike, log: Log = _quiet,
               secret_file: str | os.PathLike | None = None,
               workers: int | None = None) -> Path:
    """Generate (or resume) the data an edition pins into ``root``.

    ``workers``: processes computing garments in parallel for generators 2.x, 3.x and 4.x
    (default: every core of this machine, at most :data:`MAX_AUTO_WORKERS`; the data do not
    depend on it).

    ``retarget`` editions of the synthetic generator call
    :func:`dressmeup.data.synth.generate_dataset` with the pinned parameters and seed;
    ``uvparam`` editions build their mesh set. Real datasets cannot be generated.

    An edition whose test split is seeded by a secret (``dataset.test_split``) is generated
    whole with its secret (``secret_file``, or the one the edition publishes); without it,
    train and val only (one line logged says where the test split's public part comes from).

    Raises
    ------
    InputError
        For editions of real datasets or unknown generators, and before any work for a
        ``secret_file`` that is not the edition's secret (:func:`~dressmeup.bench.edition.
        edition_secret`) or a generator that cannot build a secret test split.
    """
    ed = load_edition(edition)
    root = Path(root)
    pin = ed.dataset
    if pin.kind != "generated":
        raise InputError(f"edition {ed.name} is scored on a real dataset (manifest "
                         f"{pin.manifest_sha256[:12]}...); it cannot be generated")
    secret = edition_secret(ed, secret_file)
    splits = splits_to_generate(ed, secret)
    if ed.task == "uvparam" and pin.test_split_commitment:
        raise InputError(f"edition {ed.name}: a uvparam mesh set has no secret test split "
                         "(dataset.test_split)")
    t0 = time.perf_counter()
    if ed.task == "uvparam":
        build_mesh_set(root, mesh_ids=pin.params.get("mesh_ids", ()),
                       garments=pin.params.get("garments"), seed=pin.seed)
    else:
        try:
            generate_dataset(root, seed=pin.seed, **pin.params, secret=secret, splits=splits,
                             workers=workers or min(os.cpu_count() or 1, MAX_AUTO_WORKERS))
        except InputError as exc:  # e.g. a parameter this toolkit's generator does not know
            raise InputError(f"edition {ed.name}: {exc}") from exc
    log(f"data for {ed.name}: {root} ({time.perf_counter() - t0:.0f} s)")
    if splits != ALL_SPLITS:  # not the data the edition's manifest pins: nothing to compare
        log(secret_test_split_note(ed))
        return root
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


@dataclass(frozen=True)
class DataParts:
    """An edition's data as built by :func:`build_parts`: the full data (the generator's
    working folder), the public part methods run on and the private part scoring reads."""

    full: Path
    public: Path
    private: Path


def build_parts(edition: str | Edition, root: str | os.PathLike, log: Log = _quiet,
                allow_other_data: bool = False,
                secret_file: str | os.PathLike | None = None,
                workers: int | None = None) -> DataParts:
    """Generate (or resume) an edition's data into ``root/full`` and export its public and
    private parts into ``root/public`` and ``root/private`` (kept when already complete).

    ``allow_other_data`` exports data this machine generated differently from the pin (the
    parts are then marked by their own manifests; scores on them are not comparable).
    An edition with a secret test split needs its secret (``secret_file`` or published):
    without it there is no test split to export, and it is refused before any work.
    ``workers`` as for :func:`build_data`.
    """
    ed = load_edition(edition)
    root = Path(root)
    if splits_to_generate(ed, edition_secret(ed, secret_file)) != ALL_SPLITS:
        raise InputError(f"{secret_test_split_note(ed)}; its parts are built by whoever holds "
                         "the secret (--secret FILE)")
    full = build_data(ed, root / "full", log=log, secret_file=secret_file, workers=workers)
    public, private = root / "public", root / "private"
    if part_of(public) != "public" or part_of(private) != "private":
        for p in (public, private):
            if p.exists():
                shutil.rmtree(p)
        res = export_parts(ed, full, public, private, allow_other_data=allow_other_data)
        note = (f"; {len(res.public_answers)} scored item(s) have a public answer (a target "
                "is also a source)" if res.public_answers else "")
        log(f"public part {public} ({res.parts.public_files} files), private part {private} "
            f"({res.parts.private_files} files){note}")
    return DataParts(full=full, public=public, private=private)
