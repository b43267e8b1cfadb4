"""The generators' job runner for items that become ready while others run."""

from __future__ import annotations

import pytest

from dressmeup.data.synth.jobs import run_ready_jobs
from dressmeup.executors import LocalExecutor


def test_ready_items_run_in_spawned_workers_as_they_come():
    handed = {"first": False}
    seen = []

    def ready():
        if not handed["first"]:
            handed["first"] = True
            return [((1, 0), -1), ((1, 1), -2)]
        if (-2, 2) in seen and -10 not in [i for i, _ in seen] and not handed.get("late"):
            handed["late"] = True
            return [((0, 0), -10)]  # made ready by -2's result
        return []

    for item, res in run_ready_jobs(abs, ready, workers=2):
        seen.append((item, res))
    assert sorted(seen) == [(-10, 10), (-2, 2), (-1, 1)]


class _Serial:
    """An executor of the :mod:`dressmeup.executors` protocol, in this process."""

    name, workers = "serial", 1

    def __init__(self):
        self.calls = []

    def run(self, fn, jobs):
        self.calls.append(list(jobs))
        for i, job in reversed(list(enumerate(jobs))):
            yield i, fn(job)


def test_waves_on_an_executor_and_the_first_error_raised():
    waves = [[((1,), "1"), ((0,), "2")], [((0,), "3")], []]
    ex = _Serial()
    out = [res for _item, res in run_ready_jobs(int, lambda: waves.pop(0) if waves else [],
                                               executor=ex)]
    assert out == [2, 1, 3] and ex.calls == [["2", "1"], ["3"]]
    waves = [[((1,), "4")]]
    out = [res for _item, res in run_ready_jobs(int, lambda: waves.pop(0) if waves else [],
                                               executor=LocalExecutor(1))]
    assert out == [4]
    with pytest.raises(ValueError):
        list(run_ready_jobs(int, iter([[((0,), "x")], []]).__next__, workers=1))
