"""LocalExecutor: workers die with their parent and the switch's rules."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest

from dressmeup.errors import InputError
from dressmeup.executors import LocalExecutor, make_executor

linux_only = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")


def _children(pid: int) -> list[int]:
    """Pids whose parent is ``pid`` (from /proc)."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(d.name))
    return out


def _alive(pid: int) -> bool:
    """Running (a zombie waiting for a reaper counts as dead)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


SCRIPT = textwrap.dedent("""
    import sys, time
    from dressmeup.executors import LocalExecutor

    def nap(i):
        time.sleep(60)
        return i

    if __name__ == "__main__":
        print("started", flush=True)
        for _ in LocalExecutor(2).run(nap, [0, 1, 2, 3]):
            pass
""")


@linux_only
def test_pool_workers_and_resource_tracker_die_with_a_killed_parent(tmp_path):
    script = tmp_path / "parent.py"
    script.write_text(SCRIPT)
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    kids: list[int] = []
    try:
        assert parent.stdout.readline().strip() == "started"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # resource tracker + 2 workers
            kids = _children(parent.pid)
            if len(kids) >= 3:
                break
            time.sleep(0.2)
        assert len(kids) >= 3, f"expected a resource tracker and 2 workers, saw {kids}"
        time.sleep(1.0)  # the workers have run their initializer and sleep in a job
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(10)
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline and any(_alive(k) for k in kids):
            time.sleep(0.2)
        assert not [k for k in kids if _alive(k)], "orphans left after kill -9 of the parent"
    finally:
        for k in kids:  # clean up after a failure: our own processes, by pid
            if _alive(k):
                os.kill(k, signal.SIGKILL)
        if parent.poll() is None:
            parent.kill()


def _pid(_job):
    return os.getpid()


def test_local_pool_runs_jobs_in_other_processes():
    got = dict(LocalExecutor(2).run(_pid, [0, 1, 2]))
    assert sorted(got) == [0, 1, 2] and os.getpid() not in got.values()


def test_make_executor_follows_the_switch():
    assert isinstance(make_executor(), LocalExecutor)
    assert make_executor(default_workers=1).workers == 1
    assert make_executor("local", 3).workers == 3
    with pytest.raises(InputError, match="--scheduler"):
        make_executor("local", scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(InputError, match="--workers"):
        make_executor("local", 0)
    with pytest.raises(InputError, match="--executor"):
        make_executor("ray")


def _die(job):
    if job == "die":
        os.kill(os.getpid(), signal.SIGKILL)
    return os.getpid()


def test_a_kept_pool_serves_many_runs_and_starts_again_after_a_dead_worker():
    with LocalExecutor(2, keep_pool=True) as ex:
        first = {pid for _, pid in ex.run(_pid, [0, 1, 2, 3])}
        second = {pid for _, pid in ex.run(_pid, [0, 1, 2, 3])}
        assert first | second <= set(ex._pool._processes) and os.getpid() not in first
        out = dict(ex.run(_die, ["die", 1]))
        assert any(isinstance(r, BrokenProcessPool) for r in out.values())
        assert ex._pool is None                      # broken: dropped
        again = {pid for _, pid in ex.run(_pid, [0, 1])}
        assert not again & first
    assert ex._pool is None
    # without keep_pool every run starts its own workers
    plain = LocalExecutor(2)
    a = {pid for _, pid in plain.run(_pid, [0, 1])}
    b = {pid for _, pid in plain.run(_pid, [0, 1])}
    assert not a & b
