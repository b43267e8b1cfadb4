"""Load on the evaluation server: concurrent clients on 127.0.0.1 mixing leaderboard reads,
status polls and uploads for a fixed time; then every accepted submission must be scored
exactly once.

    python benchmarks/perf/server_load.py --clients 50 --seconds 60 [--max-uploads 20]
        [--servers auto,h11] [--profile PREFIX]

Builds the tiny retargeting edition's parts and the ``rigid`` baseline's submission (in the
toolkit cache), starts the server (``dressmeup serve``'s application on uvicorn) in a
subprocess with a fresh folder, one team per client and two published results, then runs
the clients as threads. Prints, with the load average: requests and errors per kind,
p50/p95/max latency per kind (a leaderboard read is a full GET without ``If-None-Match``,
the worst case), the server's own CPU share over the run (its process and its scoring
workers, from ``/proc/<pid>/stat`` or psutil: CPU seconds per wall second, and as a share
of the machine's cores), uploads accepted, and after the queue drained how many were
scored, failed, and scored more than once.

``--servers`` runs the load once per server setting, one after the other, and prints the
ratios: ``auto`` is what ``dressmeup serve`` runs (httptools and uvloop, dependencies of
the toolkit; submissions scored in the server's scoring process), ``h11`` uvicorn's
pure-Python HTTP parser on asyncio's loop, ``h11-inproc`` that with submissions scored in
the server's own process (``ServerConfig.score_in_process``).
``--profile PREFIX`` profiles each server with yappi (CPU clock, every thread; ``pip
install yappi``) and writes its 60 costliest functions (with and without callees) to
``PREFIX-<setting>.txt``.
Goals: 0 errors, p95 of a leaderboard page <= 100 ms, every accepted upload scored once.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
import zipfile
from pathlib import Path


def _zip(folder: Path) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for p in sorted(folder.iterdir()):
            z.write(p, p.name)
    return buf.getvalue()


def _prepare(work: Path, clients: int) -> tuple[Path, dict[str, str], bytes]:
    from dressmeup import runs
    from dressmeup.bench import load_edition
    from dressmeup.bench.parts import export_parts
    from dressmeup.cache import cache_dir
    from dressmeup.server.accounts import add_team
    from dressmeup.server.config import ServerConfig
    from dressmeup.server.editions import add_edition
    from dressmeup.server.service import EvaluationServer

    ed = load_edition("synth-retarget-tiny-v3")
    full = runs.build_data(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}")
    other = runs.data_differs(ed, full) is not None
    export_parts(ed, full, work / "public", work / "private", allow_other_data=other)
    sub = runs.run_retarget_baseline("rigid", ed, work / "public", work / "sub")
    root = work / "server"
    srv = EvaluationServer(ServerConfig(root, daily_limit=100_000))
    tokens = {}
    with srv.sessions() as s:
        for i in range(clients):
            tokens[f"team-{i:03d}"] = add_team(s, f"team-{i:03d}")[1]
        add_edition(s, ed.name, work / "private")
    srv.engine.dispose()
    return root, tokens, _zip(sub)


#: The server process: ``dressmeup serve``'s application on uvicorn with the given HTTP
#: parser and event loop, optionally profiled by yappi until SIGTERM ends it.
SERVE = r"""
import signal
import sys
import uvicorn
from dressmeup.server.app import create_app
from dressmeup.server.config import ServerConfig
from dressmeup.server.service import EvaluationServer
root, port, http, loop, profile, in_process = sys.argv[1:7]
app = create_app(EvaluationServer(ServerConfig(root, daily_limit=100000, workers=1,
                                               score_in_process=in_process == "1")))
def _end(*_args):  # uvicorn re-raises the SIGTERM it caught once it has shut down
    raise SystemExit(0)
signal.signal(signal.SIGTERM, _end)
if profile:
    import yappi
    yappi.set_clock_type("cpu")
    yappi.start()
try:
    uvicorn.run(app, host="127.0.0.1", port=int(port), http=http, loop=loop,
                log_level="warning")
finally:
    if profile:
        yappi.stop()
        def short(path):  # a module path without the machine's folders
            for cut in ("site-packages/", "/dressmeup/", "/lib/python3"):
                if cut in path:
                    tail = path.split(cut, 1)[1]
                    return ("dressmeup/" + tail if cut == "/dressmeup/" else
                            tail.split("/", 1)[-1] if cut == "/lib/python3" else tail)
            return path
        stats = yappi.get_func_stats()
        with open(profile, "w") as f:
            f.write("yappi, CPU clock, every thread of the server process (not its scoring "
                    "process); seconds\n")
            for key in ("ttot", "tsub"):
                f.write(f"\nthe 60 functions with the most {key} "
                        "(ttot: with callees, tsub: own)\n")
                f.write(f"{'ncall':>9} {'tsub':>9} {'ttot':>9}  function\n")
                for st in list(stats.sort(key))[:60]:
                    f.write(f"{st.ncall:>9} {st.tsub:9.3f} {st.ttot:9.3f}  "
                            f"{short(st.module)}:{st.lineno} "
                            f"{st.name}\n")
"""

#: ``--servers`` settings: uvicorn's (http, loop) and whether submissions are scored in the
#: server's own process (``ServerConfig.score_in_process``).
SETTINGS = {"auto": ("auto", "auto", False), "h11": ("h11", "asyncio", False),
            "h11-inproc": ("h11", "asyncio", True)}


def _start(root: Path, port: int, setting: str, profile: str) -> subprocess.Popen:
    http, loop, in_process = SETTINGS[setting]
    proc = subprocess.Popen([sys.executable, "-c", SERVE, str(root), str(port), http, loop,
                             profile, str(int(in_process))], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    for _ in range(600):
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/api/editions", timeout=1)
            return proc
        except OSError:
            time.sleep(0.1)
    raise SystemExit("the server did not start")


def _call(url: str, token: str | None = None, data: bytes | None = None) -> tuple[int, float]:
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    req = urllib.request.Request(url, data=data, headers=headers,
                                 method="POST" if data is not None else "GET")
    t0 = time.perf_counter()
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            r.read()
            code = r.status
    except urllib.error.HTTPError as exc:
        code = exc.code
    except OSError:
        code = 0
    return code, time.perf_counter() - t0


def _cpu_seconds(pid: int) -> float:
    """CPU seconds (user + system) of process ``pid``, its live descendants and the children
    it has waited for."""
    try:
        import psutil
    except ImportError:      # Linux without psutil: the process and its waited-for children
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return sum(int(x) for x in fields[11:15]) / os.sysconf("SC_CLK_TCK")
    proc = psutil.Process(pid)
    total = 0.0
    for p in [proc, *proc.children(recursive=True)]:
        try:
            t = p.cpu_times()
        except psutil.Error:        # a worker that ended meanwhile
            continue
        total += t.user + t.system + (t.children_user + t.children_system if p is proc else 0)
    return total


def _pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))] * 1000 if xs else float("nan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--max-uploads", type=int, default=20)
    ap.add_argument("--drain-timeout", type=float, default=1800.0)
    ap.add_argument("--servers", default="auto",
                    help="comma-separated uvicorn settings, run one after the other: "
                         f"{', '.join(SETTINGS)}")
    ap.add_argument("--profile", default="", metavar="PREFIX",
                    help="profile each server with yappi into PREFIX-<setting>.txt")
    args = ap.parse_args(argv)
    settings = [x for x in args.servers.split(",") if x]
    bad = [x for x in settings if x not in SETTINGS]
    if bad or not settings:
        ap.error(f"--servers: expected some of {', '.join(SETTINGS)}, got {args.servers!r}")
    p95, ok = {}, True
    for setting in settings:
        profile = f"{args.profile}-{setting}.txt" if args.profile else ""
        if profile:
            Path(profile).resolve().parent.mkdir(parents=True, exist_ok=True)
            profile = str(Path(profile).resolve())
        http, loop, in_process = SETTINGS[setting]
        print(f"server: {setting} (uvicorn http={http}, loop={loop}; scoring in "
              f"{'the server process' if in_process else 'its scoring process'})")
        p95[setting], good = _run(args, setting, profile)
        ok = ok and good
    if len(p95) > 1:
        base = settings[0]
        print("leaderboard p95 ratios to " + base + ": " + ", ".join(
            f"{k} {v / p95[base]:.2f}" for k, v in p95.items() if k != base))
    print("goals met" if ok else "goals NOT met")
    return 0 if ok else 1


def _run(args: argparse.Namespace, setting: str, profile: str) -> tuple[float, bool]:
    """One load run against a fresh server: (leaderboard p95 ms, goals met)."""
    work = Path(tempfile.mkdtemp(prefix="dressmeup-load-"))
    root, tokens, body = _prepare(work, args.clients)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    base = f"http://127.0.0.1:{port}"
    proc = _start(root, port, setting, profile)
    names = list(tokens)
    # two published results so that the leaderboard has rows
    for team in names[:2]:
        code, _ = _call(f"{base}/api/submissions?edition=synth-retarget-tiny-v3",
                        tokens[team], body)
        assert code == 201, code
    while True:
        states = [json.loads(urllib.request.urlopen(urllib.request.Request(
            f"{base}/api/submissions", headers={"Authorization": f"Bearer {tokens[t]}"}))
            .read()) for t in names[:2]]
        if all(s and s[0]["status"] == "scored" for s in states):
            break
        time.sleep(0.5)
    for t, st in zip(names[:2], states, strict=True):
        req = urllib.request.Request(f"{base}/api/submissions/{st[0]['id']}/publish",
                                     data=json.dumps({"method": f"rigid-{t}"}).encode(),
                                     headers={"Authorization": f"Bearer {tokens[t]}",
                                              "Content-Type": "application/json"})
        urllib.request.urlopen(req).read()
    stats: dict[str, list] = {k: [] for k in ("leaderboard", "status", "upload")}
    errors: dict[str, int] = {k: 0 for k in stats}
    lock = threading.Lock()
    uploads = {"n": 2}
    stop = time.monotonic() + args.seconds

    def client(i: int) -> None:
        rng = random.Random(i)
        token = tokens[names[i % len(names)]]
        while time.monotonic() < stop:
            r = rng.random()
            if r < 0.05:
                with lock:
                    go = uploads["n"] < args.max_uploads
                    uploads["n"] += go
                kind = "upload" if go else "status"
            else:
                kind = "leaderboard" if r < 0.75 else "status"
            if kind == "upload":
                code, dt = _call(f"{base}/api/submissions?edition=synth-retarget-tiny-v3",
                                 token, body)
                ok = code == 201
            elif kind == "status":
                code, dt = _call(f"{base}/api/submissions", token)
                ok = code == 200
            else:
                code, dt = _call(f"{base}/leaderboard/", None)
                ok = code == 200
            with lock:
                stats[kind].append(dt)
                errors[kind] += not ok

    threads = [threading.Thread(target=client, args=(i,)) for i in range(args.clients)]
    cpu0 = _cpu_seconds(proc.pid)
    t0 = time.monotonic()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.monotonic() - t0
    cpu = _cpu_seconds(proc.pid) - cpu0
    load = os.getloadavg()
    print(f"{args.clients} clients for {wall:.0f} s on 127.0.0.1 (load average "
          f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, {os.cpu_count()} cores)")
    print(f"  server CPU   {cpu:.1f} s over {wall:.1f} s: {cpu / wall:.2f} cores, "
          f"{100 * cpu / wall / (os.cpu_count() or 1):.0f} % of the machine")
    for kind, xs in stats.items():
        print(f"  {kind:12s} {len(xs):6d} requests, {errors[kind]} errors, p50 "
              f"{_pct(xs, 0.5):.0f} ms, p95 {_pct(xs, 0.95):.0f} ms, max "
              f"{max(xs) * 1000 if xs else float('nan'):.0f} ms")
    t_drain = time.monotonic()
    from dressmeup.server.config import ServerConfig
    from dressmeup.server.db import Submission
    from dressmeup.server.service import EvaluationServer

    srv = EvaluationServer(ServerConfig(root))
    while True:
        with srv.sessions() as s:
            subs = list(s.query(Submission))
        pending = [x for x in subs if x.status in ("queued", "scoring")]
        if not pending or time.monotonic() - t_drain > args.drain_timeout:
            break
        time.sleep(2)
    results = [p for p in (root / "results").iterdir() if not p.name.startswith(".")]
    scored = [x for x in subs if x.status == "scored"]
    print(f"  accepted {len(subs)} uploads; scored {len(scored)}, failed "
          f"{sum(x.status == 'failed' for x in subs)}, pending {len(pending)}; result folders "
          f"{len(results)}; scored more than once: "
          f"{sum(x.attempts > 1 for x in scored)} (drained in {time.monotonic() - t_drain:.0f} s)")
    os.killpg(proc.pid, signal.SIGTERM)
    proc.wait(timeout=60)
    ok = (sum(errors.values()) == 0 and _pct(stats["leaderboard"], 0.95) <= 100
          and len(scored) == len(subs) == len(results))
    if profile:
        print(f"  profile      {profile}")
    return _pct(stats["leaderboard"], 0.95), ok


if __name__ == "__main__":
    sys.exit(main())
