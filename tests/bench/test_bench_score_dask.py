"""Scoring on Dask distributed (2-worker LocalCluster on loopback): the same numbers as the
serial path, every item exactly once even when a worker dies, and the shared-filesystem check."""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import pandas as pd
import pytest

pytest.importorskip("distributed")

import cloudpickle  # noqa: E402 - after the skip (installed with distributed)

from dressmeup.bench import score_submission  # noqa: E402
from dressmeup.errors import InputError  # noqa: E402
from dressmeup.executors.dask_executor import DaskExecutor, see_paths  # noqa: E402

# workers cannot import this test module by name: ship its helpers by value
cloudpickle.register_pickle_by_value(sys.modules[__name__])

METRICS = ["p2s", "p2s_bi", "chamfer", "ed", "nc", "ir"]


@pytest.fixture
def cluster(dask_cluster):
    """The run's 2-worker LocalCluster (tests/conftest.py)."""
    return dask_cluster


class KillWorkerOnce:
    """Score a job, except that the worker running ``item`` the first time kills itself
    (SIGKILL, like the OOM killer) mid-job; ``marker`` records that it happened."""

    def __init__(self, fn, item: str, marker: Path) -> None:
        self.fn, self.item, self.marker = fn, item, marker
        self.__name__ = "score_job"

    def __call__(self, job):
        if job["item_id"] == self.item and not self.marker.exists():
            self.marker.write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGKILL)
        return self.fn(job)


class Wrapped(DaskExecutor):
    """The module's cluster with a job-function wrapper."""

    def __init__(self, base: DaskExecutor, wrap) -> None:
        self.__dict__.update(base.__dict__)
        self.wrap = wrap

    def run(self, fn, jobs):
        yield from super().run(self.wrap(fn), jobs)


def test_dask_scores_bit_identical_to_serial(cluster, scored, bench_edition, bench_data,
                                             tmp_path):
    res = score_submission(scored["noisy"]["sub"], bench_edition, bench_data, tmp_path / "d",
                           executor=cluster, show_progress=False)
    serial = scored["noisy"]["res"]
    pd.testing.assert_frame_equal(res.table[["sample_id", "status", *METRICS]],
                                  serial.table[["sample_id", "status", *METRICS]],
                                  check_exact=True)
    assert res.summary["provenance"]["executor"] == "dask"
    assert res.summary["provenance"]["workers"] == 2


def test_a_killed_worker_loses_and_duplicates_nothing(cluster, scored, bench_edition,
                                                      bench_data, tmp_path):
    victim = "S01-G02-P1__to__S01-G02-P0"
    marker = tmp_path / "killed"
    ex = Wrapped(cluster, lambda fn: KillWorkerOnce(fn, victim, marker))
    pids_before = set(cluster.client.run(os.getpid).values())
    res = score_submission(scored["noisy"]["sub"], bench_edition, bench_data, tmp_path / "k",
                           executor=ex, show_progress=False)
    assert marker.exists() and int(marker.read_text()) in pids_before  # a worker did die
    t = res.table
    assert t["sample_id"].is_unique and len(t) == len(scored["noisy"]["res"].table)
    assert (t["status"] == "ok").all(), t.loc[t["status"] != "ok", ["sample_id", "error"]]
    pd.testing.assert_frame_equal(t[["sample_id", *METRICS]],
                                  scored["noisy"]["res"].table[["sample_id", *METRICS]],
                                  check_exact=True)


def _fail_on_odd(x):
    if x % 2:
        raise ValueError(f"odd {x}")
    return x * 10


def test_errors_come_back_per_item_and_each_index_once(cluster):
    cluster.max_pending = 1  # 2 tasks in flight for 9 jobs: exercises the refill
    try:
        got = list(cluster.run(_fail_on_odd, list(range(9))))
    finally:
        cluster.max_pending = 2
    assert sorted(i for i, _ in got) == list(range(9))
    for i, r in got:
        assert (isinstance(r, ValueError) and str(r) == f"odd {i}") if i % 2 else r == i * 10


class FakeClient:
    """Answers ``run(see_paths, ...)`` as two workers would, one seeing another folder."""

    def __init__(self, other: Path) -> None:
        self.other = other

    def run(self, fn, read, write):
        good = see_paths(read, write)
        bad = see_paths([str(self.other)] * len(read), write)
        bad["read"] = dict(zip(read, bad["read"].values(), strict=True))
        bad["host"] = "node7"
        return {"tcp://10.0.0.1:1": good, "tcp://10.0.0.2:1": bad}


def test_shared_filesystem_check_names_the_path_and_the_worker(tmp_path):
    data = tmp_path / "data"
    (data / "samples").mkdir(parents=True)
    other = tmp_path / "elsewhere"
    other.mkdir()
    ex = DaskExecutor(2, log=None)
    ex._client = FakeClient(other)
    ex.require_shared(data, writable=[tmp_path / "out"])
    with pytest.raises(InputError, match=r"data: on Dask worker tcp://10.0.0.2:1 \(host node7\)"):
        ex.check_shared()
    with pytest.raises(InputError, match="no such file"):
        ex.require_shared(tmp_path / "missing")
    ex._client = None


def test_require_shared_passes_on_a_real_local_cluster(cluster, bench_data, tmp_path):
    cluster.require_shared(bench_data, writable=[tmp_path / "new" / "out"])
    try:
        cluster.check_shared()
    finally:
        cluster.require_shared()


def test_score_command_on_an_existing_scheduler(cluster, scored, bench_edition, bench_data,
                                                tmp_path, capsys):
    from dressmeup.bench import load_result
    from dressmeup.cli import main

    addr = cluster.client.scheduler.address
    assert addr.startswith("tcp://127.0.0.1:")
    status = main(["score", str(scored["noisy"]["sub"]), "-e", str(bench_edition), "-d",
                   str(bench_data), "-o", str(tmp_path / "cli"), "--scheduler", addr,
                   "--no-progress"])
    assert status == 0
    assert f"dask: scheduler {addr}" in capsys.readouterr().err
    res = load_result(tmp_path / "cli")
    assert res.summary["provenance"]["executor"] == "dask"
    pd.testing.assert_frame_equal(res.table[["sample_id", *METRICS]].reset_index(drop=True),
                                  scored["noisy"]["res"].table[["sample_id", *METRICS]],
                                  check_exact=True)
    assert main(["score", str(scored["noisy"]["sub"]), "-e", str(bench_edition), "-d",
                 str(bench_data), "-o", str(tmp_path / "x"), "--scheduler", addr,
                 "--workers", "2"]) == 2
    assert "drop --workers" in capsys.readouterr().err


def test_score_asks_the_executor_for_every_folder_its_jobs_read(scored, bench_edition,
                                                               bench_data, tmp_path):
    from dressmeup.executors import LocalExecutor

    class Recording(LocalExecutor):
        def require_shared(self, *paths, writable=()):
            self.paths = [str(p) for p in paths]

    ex = Recording(1)
    score_submission(scored["noisy"]["sub"], bench_edition, bench_data, tmp_path / "r",
                     executor=ex, show_progress=False)
    assert str(bench_data) in ex.paths and str(scored["noisy"]["sub"]) in ex.paths
    # the posed target bodies the IR metric reads live in the toolkit cache: shared too
    assert any("bench-bodies" in p for p in ex.paths), ex.paths
