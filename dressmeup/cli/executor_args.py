"""The one switch for every command that runs many jobs: ``--executor {local,dask}``,
``--workers N`` and ``--scheduler ADDRESS`` (see docs/scale-out.md)."""

from __future__ import annotations

import argparse
from typing import Any

from dressmeup.executors import make_executor


def add_executor_args(parser: argparse.ArgumentParser, default_workers: int | None = None,
                      what: str = "jobs") -> None:
    """Add ``--executor``, ``--workers/-j`` and ``--scheduler`` to ``parser``.

    Parameters
    ----------
    parser : the subcommand's parser.
    default_workers : local workers when ``--workers`` is not given (None: every core;
        1: in this process, the command's serial behaviour).
    what : what the jobs are, for the help text ("pairs", "sessions", ...).
    """
    default = ("every core" if default_workers is None else
               "1 = in this process" if default_workers == 1 else str(default_workers))
    g = parser.add_argument_group(
        "where the jobs run", f"one job per {what}; see docs/scale-out.md")
    g.add_argument("--executor", choices=("local", "dask"), default=None,
                   help="local: a process pool on this machine (default); dask: Dask "
                        "distributed (a LocalCluster on 127.0.0.1 of --workers processes, or "
                        "the cluster of --scheduler); needs the 'distributed' extra")
    g.add_argument("--workers", "-j", type=int, default=None,
                   help=f"worker processes: the local pool, or the LocalCluster's size "
                        f"(default: {default})")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address (tcp://host:8786) or scheduler file of an existing Dask "
                        "scheduler; implies --executor dask; data and outputs must be on a "
                        "filesystem every worker shares")


def executor_from_args(args: argparse.Namespace, default_workers: int | None = None) -> Any:
    """The :class:`dressmeup.executors.Executor` that ``args`` ask for."""

    return make_executor(args.executor, args.workers, args.scheduler,
                         default_workers=default_workers)
