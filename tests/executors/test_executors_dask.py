"""DaskExecutor details: the worker-environment check and in-order delivery."""

from __future__ import annotations

import pytest

from dressmeup.errors import InputError
from dressmeup.executors import in_order


def test_workers_without_the_needed_environment_are_refused(dask_cluster):
    ex = dask_cluster
    ex.worker_env = {"DRESSMEUP_TEST_NEEDED": "1"}
    try:
        with pytest.raises(InputError, match=r"Dask worker tcp://127\.0\.0\.1:\d+ .*"
                                             r"DRESSMEUP_TEST_NEEDED='1'"):
            ex.check_worker_env()
    finally:
        ex.worker_env = {}


def test_in_order_holds_early_results_until_their_turn():
    got = list(in_order(iter([(2, "c"), (0, "a"), (3, "d"), (1, "b")])))
    assert got == [(0, "a"), (1, "b"), (2, "c"), (3, "d")]
