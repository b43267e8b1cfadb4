"""Running methods: the one path from a reference baseline to a submission and its scores,
shared by ``dressmeup baseline``, ``dressmeup demo`` and ``benchmarks/run_baselines.py``.

This layer sits above the evaluation devkit (:mod:`dressmeup.bench`), which never imports a
method: ``bench`` scores files, ``runs`` makes them. Each step logs one line per thing done
or skipped through ``log`` (the CLI prints them). Baselines are discovered through the method
registries (``dressmeup.methods.retarget`` / ``dressmeup.methods.uvparam``).

- :mod:`~dressmeup.runs.data`: :func:`build_data` (the data an edition pins), :func:`data_differs`;
- :mod:`~dressmeup.runs.retarget`, :mod:`~dressmeup.runs.uvparam`,
  :mod:`~dressmeup.runs.registration`: one baseline over an edition into a submission;
- :func:`run_baselines` (every baseline of a task), :func:`score_many`.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from dressmeup.bench.boards.leaderboard import format_summary
from dressmeup.bench.edition import Edition, load_edition
from dressmeup.bench.scoring.score import score_submission
from dressmeup.executors.local import LocalExecutor
from dressmeup.runs.common import (
    BASELINE_AUTHORS,
    Log,
    SkippedBaseline,
    _quiet,
    registration_methods,
    retarget_methods,
    uvparam_methods,
)
from dressmeup.runs.data import DataParts, build_data, build_parts, data_differs
from dressmeup.runs.registration import RegisterJob, run_registration_baseline
from dressmeup.runs.retarget import run_retarget_baseline
from dressmeup.runs.uvparam import UVMeshJob, run_uvparam_baseline


def run_baselines(edition: str | Edition, data_root: str | os.PathLike,
                  sub_dir: str | os.PathLike, methods: Sequence[str] | None = None,
                  log: Log = _quiet, **kw: Any) -> dict[str, Path]:
    """Run every available baseline of the edition's task (or ``methods``); a method that
    fails is reported and skipped. Returns method name -> submission folder."""
    ed = load_edition(edition)
    if ed.task == "retarget":
        names, runner = retarget_methods(), run_retarget_baseline
    elif ed.task == "uvparam":
        names, runner = uvparam_methods(), run_uvparam_baseline
    elif ed.task == "registration":
        names, runner = registration_methods(), run_registration_baseline
    else:
        log(f"no reference baselines for task {ed.task} in this toolkit: skipped")
        return {}
    if not names:
        log(f"no {ed.task} baselines installed (dressmeup.methods.{ed.task}): skipped")
        return {}
    chosen = list(methods) if methods is not None else names
    subs: dict[str, Path] = {}
    for name in chosen:
        try:
            subs[name] = runner(name, ed, data_root, Path(sub_dir) / name.replace("+", "_"),
                                log=log, **kw)
        except SkippedBaseline as exc:
            log(f"  {name}: skipped ({exc})")
        except Exception as exc:  # noqa: BLE001 - one broken baseline must not stop the others
            log(f"  {name}: FAILED ({type(exc).__name__}: {exc}); skipped")
    return subs


def score_many(subs: dict[str, Path], edition: str | Edition, data_root: str | os.PathLike,
               results_dir: str | os.PathLike, workers: int | None = None, executor: Any = None,
               log: Log = _quiet, allow_other_data: bool = False) -> list[Path]:
    """Score each submission into ``results_dir/<name>`` (new folders); return the folders.
    ``allow_other_data``: score data that differ from the edition's pin, marked not
    comparable (see :func:`~dressmeup.bench.scoring.score.score_submission`)."""
    out = []
    # one pool for every submission (its workers start once, not once a submission)
    with contextlib.nullcontext(executor) if executor is not None else LocalExecutor(
            workers, keep_pool=True) as ex:
        for sub in subs.values():
            res = score_submission(sub, edition, data_root, Path(results_dir) / sub.name,
                                   executor=ex, allow_other_data=allow_other_data)
            log(format_summary(res.summary))
            out.append(res.path)
    return out


__all__ = ["BASELINE_AUTHORS", "DataParts", "RegisterJob", "SkippedBaseline", "UVMeshJob", "build_data",
           "build_parts", "data_differs", "registration_methods", "retarget_methods", "run_baselines",
           "run_registration_baseline", "run_retarget_baseline", "run_uvparam_baseline",
           "score_many", "uvparam_methods"]
