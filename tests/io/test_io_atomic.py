"""Atomic writes: files get the umask's mode (not mkstemp's 0600); folders are built in a
hidden sibling and renamed into place, so a killed writer leaves nothing half-written."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from dressmeup.io.atomic import atomic_dir, atomic_path, atomic_write_text, current_umask


@pytest.fixture
def umask_022():
    old = os.umask(0o022)
    yield
    os.umask(old)


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_atomic_files_respect_the_umask(tmp_path, umask_022):
    assert current_umask() == 0o022
    atomic_write_text(tmp_path / "a.json", "{}")
    with atomic_path(tmp_path / "b.npz") as tmp:
        np.savez(tmp, x=np.zeros(3))
    assert _mode(tmp_path / "a.json") == 0o644
    assert _mode(tmp_path / "b.npz") == 0o644


def test_atomic_files_follow_a_stricter_umask(tmp_path):
    old = os.umask(0o077)
    try:
        atomic_write_text(tmp_path / "a.txt", "x")
    finally:
        os.umask(old)
    assert _mode(tmp_path / "a.txt") == 0o600


def test_atomic_dir_renames_into_place_and_cleans_up_on_error(tmp_path, umask_022):
    out = tmp_path / "res"
    with pytest.raises(RuntimeError), atomic_dir(out) as tmp:
        (tmp / "x.txt").write_text("half")
        raise RuntimeError("boom")
    assert not out.exists() and list(tmp_path.iterdir()) == []
    with atomic_dir(out) as tmp:
        (tmp / "x.txt").write_text("whole")
    assert (out / "x.txt").read_text() == "whole"
    assert _mode(out) == 0o755
    assert [p.name for p in tmp_path.iterdir()] == ["res"]


def test_a_killed_writer_leaves_no_folder_and_its_leftover_is_swept(tmp_path):
    out = tmp_path / "res"
    code = textwrap.dedent(f"""
        import os, signal
        from dressmeup.io.atomic import atomic_dir
        with atomic_dir({str(out)!r}) as tmp:
            (tmp / "a.npz").write_bytes(b"x")
            os.kill(os.getpid(), signal.SIGKILL)
    """)
    subprocess.run([sys.executable, "-c", code], check=False)
    assert not out.exists()
    leftovers = [p.name for p in tmp_path.iterdir()]
    assert len(leftovers) == 1 and leftovers[0].startswith(".res.partial-")
    with atomic_dir(out) as tmp:
        (tmp / "b.npz").write_bytes(b"y")
    assert [p.name for p in tmp_path.iterdir()] == ["res"]
