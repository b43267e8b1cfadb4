"""Does this machine compute generator 2.1.0's numbers as the machine that pinned its data?

Generator 2.1.0's bytes depend on the CPU: its cloth solver (torch float64, L-BFGS) calls
MKL for dot and matrix-vector products and elementwise functions even with torch's portable
kernels, and MKL picks its code by the CPU's maker; the solver turns the last-bit differences
into millimetres. The AMD EPYC machines that pinned the v3 editions write the pinned data, an
Intel Xeon other data (docs/synthetic-data.md, "Reproducibility"). Everything before the first
solve (bodies, rest garments, a garment on its own design body) is the same everywhere; the
first garment fitted to *another* body is where machines part.

:func:`probe_v3` computes exactly that, the way the generator does (a fresh worker process
with the canonical numerics, :func:`~dressmeup.data.synth.jobs.run_jobs`): the first
sample the generator writes whose subject is not the garment's designer, i.e. that garment
built, fitted to the subject and draped in the pose (its pose path), with its scan, and hashes
the stored arrays. Comparing the digest with the one computed on the pinning machine tells,
in seconds (a few for the procedural body, tens for anny), whether generating the whole
edition here would reproduce its pinned manifest.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from dressmeup.data.synth.common import GarmentItem, GarmentResult, wearers
from dressmeup.data.synth.config import synth_config
from dressmeup.data.synth.generate import arguments_2x
from dressmeup.data.synth.generator2 import prepare_2x
from dressmeup.data.synth.jobs import run_jobs

#: format of the probe pins shipped beside the editions (``bench/editions/probes/``)
PROBE_FORMAT = "dressmeup-generator-probe/1"


@dataclass(frozen=True)
class ProbeResult:
    """The probe's sample (``S02-G01-P1``), the sha256 of its arrays and the wall seconds."""

    sample: str
    sha256: str
    seconds: float


def probe_sample(plan: dict[str, Any]) -> tuple[str, str, str]:
    """``(garment, subject, pose)`` of the probe in a generator-2.x ``plan``: the first garment
    the generator computes (test garments first, by id) and its first wearer who is not its
    design subject (the first wearer when there is none)."""
    rank = {"test": 0, "train": 1, "val": 2}
    gid = min(plan["garments"], key=lambda g: (rank[plan["garments"][g]["split"]], g))
    worn = wearers(plan, gid)
    design = plan["garments"][gid]["design_subject"]
    sid, pid = next(((s, p) for s, p in worn if s != design), worn[0])
    return gid, sid, pid


def sample_digest(res: GarmentResult) -> str:
    """sha256 of one garment job's stored arrays (float64 C order): each fitted garment, then
    per sample its garment and its scan's vertices and faces."""
    h = hashlib.sha256()
    for sid in sorted(res.fitted):
        h.update(np.ascontiguousarray(res.fitted[sid], np.float64).tobytes())
    for smp in res.samples:
        h.update(np.ascontiguousarray(smp.V, np.float64).tobytes())
        if smp.scan is not None:
            V, F = smp.scan[0], smp.scan[1]
            h.update(np.ascontiguousarray(V, np.float64).tobytes())
            h.update(np.ascontiguousarray(F, np.int64).tobytes())
    return h.hexdigest()


def probe_v3(params: dict[str, Any], seed: int) -> ProbeResult:
    """Compute the probe sample of the generator-2.x dataset that ``params`` (the generator
    parameters of an edition, ``version`` included) and ``seed`` define, in a fresh worker
    process with the canonical numerics, and hash it (:func:`sample_digest`).

    Raises
    ------
    ValueError, InputError
        ``params`` that are not those of generator 2.x (or invalid).
    """
    c = synth_config(seed=seed, **params)
    if not str(c.version).startswith("2."):
        raise ValueError(f"version: the probe is of generator 2.x, got {c.version!r}")
    plan, _, job = prepare_2x(**arguments_2x(c))
    gid, sid, pid = probe_sample(plan)
    t0 = time.perf_counter()
    [res] = run_jobs(job, [GarmentItem(gid, plan["garments"][gid], ((sid, pid),))])
    return ProbeResult(sample=f"{sid}-{gid}-{pid}", sha256=sample_digest(res),
                       seconds=time.perf_counter() - t0)
