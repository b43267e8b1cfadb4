"""Run one command line of the sweep in a forked child and classify what happened.

The parent imports the toolkit and its heavy dependencies once; each case runs
``dressmeup.cli.main(argv)`` in a forked child with an address-space limit, a wall-clock
limit, its own working folder and its stdout/stderr in files. Outcomes:

- ``clear error``: exit status 1 or 2 with a message and no traceback, on an input that
  should be refused (or may be);
- ``correct``: exit status 0 on an input that should be accepted (or may be), passing the
  case's own check of the output;
- ``traceback``: a Python traceback (status 70, the CLI's internal error, or an uncaught
  exception);
- ``crash``: killed by a signal, out of memory (MemoryError or the address-space limit) or
  still running at the time limit;
- ``accepted``: exit status 0 on an input that should be refused, or a warning the case
  expects is missing;
- ``damaged``: the case's check of the outputs failed (two writers both succeeded, records
  lost, ...);
- ``refused valid``: a clear error on an input that should be accepted.
"""

from __future__ import annotations

import os
import re
import resource
import signal
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

OUTCOMES = ("clear error", "correct", "traceback", "crash", "accepted", "damaged",
            "refused valid")


@dataclass
class Case:
    """One command line of the sweep.

    ``argv`` may hold ``{F}`` (the fixtures folder) and ``{W}`` (the case's own working
    folder); ``setup(W)`` makes the case's input files before it runs; ``check(W, results)``
    returns a problem with the outputs (``damaged``) or None. ``expect``: ``refuse``,
    ``ok``, ``either`` or ``warn:<regex>`` (status 0 and the regex in the output).
    ``parallel``: how many copies run at once (writers racing for one output).
    """

    group: str
    name: str
    argv: list[str]
    expect: str = "refuse"
    setup: Callable[[Path], None] | None = None
    check: Callable[[Path, list], str | None] | None = None
    parallel: int = 1
    timeout: float = 60.0
    env: dict = field(default_factory=dict)
    timeout_outcome: str = "crash"


@dataclass
class Result:
    """What one child did: exit status (negative: signal), seconds, output tails."""

    status: int
    seconds: float
    timed_out: bool
    stdout: str
    stderr: str


def _child(argv: list[str], workdir: Path, tag: str, mem_bytes: int, env: dict) -> None:
    """Runs in the forked child; never returns."""
    try:
        os.setpgid(0, 0)
        os.chdir(workdir)
        for fd, name in ((1, f".{tag}.out"), (2, f".{tag}.err")):
            f = os.open(workdir / name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(f, fd)
            os.close(f)
        sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115 - the child's own streams
        sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115
        os.environ.update(env)
        soft = resource.getrlimit(resource.RLIMIT_AS)[1]
        resource.setrlimit(resource.RLIMIT_AS, (mem_bytes, soft))
        from dressmeup.cli import main

        status = main(argv)
    except SystemExit as exc:  # argparse
        status = exc.code if isinstance(exc.code, int) else 2
    except BaseException:  # noqa: BLE001 - report everything the CLI let through
        traceback.print_exc()
        status = 71
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(int(status or 0) & 0xFF)


def _vm_bytes() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    return 0


def run_case(case: Case, workdir: Path, fixtures: Path, mem_gb: float,
             timeout: float | None = None) -> list[Result]:
    """Run ``case`` (``parallel`` copies at once) and return one Result per copy."""
    workdir.mkdir(parents=True, exist_ok=True)
    if case.setup is not None:
        case.setup(workdir)
    argv = [a.replace("{F}", str(fixtures)).replace("{W}", str(workdir)) for a in case.argv]
    mem = _vm_bytes() + int(mem_gb * (1 << 30))
    limit = timeout or case.timeout
    children = {}
    for i in range(case.parallel):
        tag = f"run{i}"
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            _child(argv, workdir, tag, mem, case.env)
        children[pid] = (tag, time.monotonic())
    results = {}
    deadline = time.monotonic() + limit
    while children:
        pid, wstatus = os.waitpid(-1, os.WNOHANG)
        if pid == 0:
            if time.monotonic() > deadline:
                for p in list(children):
                    try:
                        os.killpg(p, signal.SIGKILL)
                    except ProcessLookupError:
                        pass
                for p in list(children):
                    _, ws = os.waitpid(p, 0)
                    tag, t0 = children.pop(p)
                    results[tag] = (-9, time.monotonic() - t0, True)
                break
            time.sleep(0.05)
            continue
        if pid not in children:
            continue
        tag, t0 = children.pop(pid)
        code = (os.WEXITSTATUS(wstatus) if os.WIFEXITED(wstatus)
                else -os.WTERMSIG(wstatus))
        results[tag] = (code, time.monotonic() - t0, False)
    out = []
    for i in range(case.parallel):
        tag = f"run{i}"
        code, secs, to = results[tag]
        text = [(workdir / f".{tag}.{s}").read_text(errors="replace")
                if (workdir / f".{tag}.{s}").exists() else "" for s in ("out", "err")]
        out.append(Result(code, secs, to, text[0][-4000:], text[1][-4000:]))
    return out


def classify(case: Case, results: list[Result], workdir: Path) -> tuple[str, str]:
    """The outcome of a case and a one-line note."""
    for r in results:
        if r.timed_out:
            return case.timeout_outcome, f"still running after {r.seconds:.0f} s"
        if r.status < 0:
            return "crash", f"killed by signal {-r.status}"
        if "MemoryError" in r.stderr or "std::bad_alloc" in r.stderr:
            return "crash", "out of memory"
        if "Traceback (most recent call last)" in r.stderr or r.status in (70, 71):
            last = [ln for ln in r.stderr.splitlines() if ln.strip()
                    and not ln.startswith(("dressmeup", " "))]
            return "traceback", (last[-1] if last else r.stderr[-200:]).strip()[:200]
    if case.check is not None:
        problem = case.check(workdir, results)
        if problem:
            return "damaged", problem
    r = results[0]
    msg = (r.stderr.strip().splitlines() or r.stdout.strip().splitlines() or [""])[-1][:200]
    ok = all(x.status == 0 for x in results)
    if len(results) > 1:  # writers racing for one output: exactly one must succeed
        if not any(x.status == 0 for x in results):
            return "refused valid", "no writer succeeded: " + msg
        return "clear error", next(
            (x.stderr.strip().splitlines() or [""])[-1][:200] for x in results if x.status)
    if case.expect == "ok":
        return ("correct", "") if ok else ("refused valid", msg)
    if case.expect == "either":
        return ("correct", "") if ok else ("clear error", msg)
    if case.expect.startswith("warn:"):
        if not ok:
            return "clear error", msg
        pattern = re.compile(case.expect[5:], re.I)
        if all(pattern.search(x.stdout + x.stderr) for x in results):
            return "correct", ""
        return "accepted", "no warning"
    if ok:
        return "accepted", (r.stdout.strip().splitlines() or [""])[-1][:200]
    return "clear error", msg
