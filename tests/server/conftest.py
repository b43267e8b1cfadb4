"""Fixtures of the evaluation server's tests: the tiny edition's private and public parts, a
baseline's submission, servers on SQLite and on PostgreSQL (a private cluster started here
when ``DRESSMEUP_TEST_POSTGRES`` does not name one)."""

from __future__ import annotations

import io
import os
import shutil
import socket
import subprocess
import tempfile
import time
import zipfile
from pathlib import Path

import pytest

from dressmeup import runs
from dressmeup.bench import load_edition

#: generator 4.0.0 (portable: the same bytes on every x86 CPU), so that the server adds its
#: private part as the pinned one on any machine
EDITION = "synth-retarget-tiny-v5"


@pytest.fixture(scope="session")
def tiny_parts(other_data):
    """(edition, public part, private part, data differs from the pin)."""
    from dressmeup.cache import cache_dir

    ed = load_edition(EDITION)
    parts = runs.build_parts(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}",
                             allow_other_data=True)
    other = other_data(ed, parts.full) is not None  # any other manifest fails here
    return ed, parts.public, parts.private, other


@pytest.fixture(scope="session")
def submission(tiny_parts, tmp_path_factory):
    """The ``rigid`` baseline's submission folder for the tiny edition."""
    ed, public, _, _ = tiny_parts
    return runs.run_retarget_baseline("rigid", ed, public,
                                      tmp_path_factory.mktemp("server-sub") / "rigid")


def zip_folder(folder: Path) -> bytes:
    """A submission folder as a zip archive in memory."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for p in sorted(Path(folder).iterdir()):
            z.write(p, p.name)
    return buf.getvalue()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="session")
def postgres_url():
    """A PostgreSQL URL: ``$DRESSMEUP_TEST_POSTGRES`` (CI starts the system cluster), else a
    private cluster in a temporary folder (Debian's postgresql binaries, run as the
    ``postgres`` user when the tests run as root); skipped when neither is available."""
    url = os.environ.get("DRESSMEUP_TEST_POSTGRES")
    if url:
        yield url
        return
    bindir = next((Path(p) for p in sorted(Path("/usr/lib/postgresql").glob("*/bin"),
                                           reverse=True)), None) \
        if Path("/usr/lib/postgresql").is_dir() else None
    if bindir is None or not (bindir / "initdb").is_file():
        pytest.skip("PostgreSQL is not installed (Debian: apt-get install postgresql)")
    # a folder the postgres user can reach (pytest's own are private to root)
    base = Path(tempfile.mkdtemp(prefix="dressmeup-pg-"))
    data = base / "data"
    as_user: list[str] = []
    if os.geteuid() == 0:
        if shutil.which("runuser") is None:
            pytest.skip("running as root without runuser: cannot start PostgreSQL")
        as_user = ["runuser", "-u", "postgres", "--"]
        base.chmod(0o777)
    port = _free_port()
    run = lambda *cmd: subprocess.run([*as_user, *cmd], check=True, capture_output=True,  # noqa: E731
                                      timeout=120)
    run(str(bindir / "initdb"), "-D", str(data), "-A", "trust", "-U", "postgres")
    # the server logs to a file: a child holding this process's pipes would keep run() waiting
    run(str(bindir / "pg_ctl"), "-D", str(data), "-l", str(base / "server.log"), "-o",
        f"-p {port} -k {base} -c listen_addresses=127.0.0.1", "-w", "start")
    try:
        for _ in range(50):
            if subprocess.run([str(bindir / "pg_isready"), "-h", "127.0.0.1", "-p", str(port)],
                              capture_output=True).returncode == 0:
                break
            time.sleep(0.2)
        run(str(bindir / "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", "postgres",
            "dressmeup_test")
        yield f"postgresql+psycopg://postgres@127.0.0.1:{port}/dressmeup_test"
    finally:
        subprocess.run([*as_user, str(bindir / "pg_ctl"), "-D", str(data), "-m", "fast",
                        "stop"], capture_output=True, timeout=120)
        shutil.rmtree(base, ignore_errors=True)
