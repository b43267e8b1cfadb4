"""One writer per output (dressmeup.io.outlock): a second process writing the same output
is refused at once, naming the holder; the lock is re-entrant in one process and dies with
its process."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from dressmeup.errors import InputError
from dressmeup.io.outlock import lock_path, output_lock


def _hold(target, seconds: float) -> subprocess.Popen:
    code = textwrap.dedent(f"""
        import sys, time
        from dressmeup.io.outlock import output_lock
        with output_lock({str(target)!r}):
            print("held", flush=True)
            time.sleep({seconds})
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_a_second_writer_is_refused_while_the_first_holds(tmp_path):
    out = tmp_path / "site"
    holder = _hold(out, 30)
    try:
        with pytest.raises(InputError, match=rf"is being written by another dressmeup run "
                                             rf"\(process {holder.pid}\)"):
            with output_lock(out, "--out"):
                pass
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    with output_lock(out):  # the kernel dropped the killed holder's lock
        assert lock_path(out).exists()
    assert not lock_path(out).exists()


def test_reentrant_in_one_process(tmp_path):
    out = tmp_path / "data"
    with output_lock(out), output_lock(out):
        with output_lock(str(out)):
            pass
        assert lock_path(out).exists()
    assert not lock_path(out).exists()


def test_cli_a_second_writer_of_one_out_fails(tmp_path):
    """Two runs of one writing command on one --out: the second fails naming the first."""
    out = tmp_path / "sub"
    holder = _hold(out, 30)
    try:
        env = {**os.environ, "DRESSMEUP_NO_PROGRESS": "1"}
        t0 = time.monotonic()
        proc = subprocess.run([sys.executable, "-m", "dressmeup", "baseline", "uvparam",
                               "--method", "xatlas", "--meshes", "sphere-2k", "--out",
                               str(out)], capture_output=True, text=True, env=env)
        assert proc.returncode == 2, proc.stderr
        assert "being written by another dressmeup run" in proc.stderr
        assert time.monotonic() - t0 < 60 and not out.exists()
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
