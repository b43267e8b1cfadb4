"""Known bad inputs (each one command line: found by an earlier campaign on a fresh
install) that the option and file sweeps do not already hold, plus output folders: an
existing file as ``--out``, two writers into one folder, resumed builds."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import bad_files as bf
from cases_common import _fx
from cases_files import _dataset_copy, _garment
from runner import Case

F, W = "{F}", "{W}"
RET = ["--data", f"{F}/data", "--edition", f"{F}/ed.json"]

#: every writing command with its output option ({O} stands for the output path)
WRITERS: dict[str, list[str]] = {
    "synth": ["synth", "{O}", "--subjects", "1", "--garments", "1", "--poses", "2",
              "--body-model", "procedural", "--edge-length", "0.05"],
    "import-dataset": ["import-dataset", "4ddress", f"{F}/4ddress", "--out", "{O}"],
    "synth-capture": ["synth-capture", "mannequin", "--out", "{O}", "--scale", "0.2"],
    "fuse": ["fuse", f"{F}/session", "--out", "{O}", "--voxel", "0.02"],
    "build-dataset": ["build-dataset", f"{F}/session", "--out", "{O}", "--voxel", "0.02",
                      "--body", "none", "--target-faces", "2000", "--texture-size", "64"],
    "baseline retarget": ["baseline", "retarget", "--method", "rigid", *RET, "--out", "{O}"],
    "baseline uvparam": ["baseline", "uvparam", "--method", "xatlas", "--meshes",
                         f"{F}/garment.ply", "--out", "{O}"],
    "score": ["score", f"{F}/sub", *RET, "--out", "{O}", "--workers", "1"],
    "report": ["report", f"{F}/res", f"{F}/res-noisy", "--out", "{O}", "--max-images", "2"],
    "edition create": ["edition", "create", "--data", f"{F}/data", "--task", "retarget",
                       "--name", "sweep-made", "--out", "{O}"],
    "edition export": ["edition", "export", f"{F}/ed-pinned.json", "--data", f"{F}/data",
                       "--public", "{O}"],
    "register": ["register", f"{F}/scan.npy", "--model", "procedural", "--init",
                 f"{F}/body.npz", "--iterations", "1,1,1", "--no-picture", "--out", "{O}"],
}


def _argv(name: str, out: str) -> list[str]:
    return [a.replace("{O}", out) for a in WRITERS[name]]


def _not_both(w: Path, results) -> str | None:
    if all(r.status == 0 for r in results):
        return "both writers exited 0"
    return None


def output_cases() -> list[Case]:
    out = []
    for name in WRITERS:
        # register's --out is a file: writing over it is what it is for
        out.append(Case("outputs", f"{name}: --out an existing file", _argv(name, f"{W}/o"),
                        "either" if name == "register" else "refuse",
                        setup=lambda w: bf.empty(w / "o"), timeout=90))
        if name == "register":
            continue
        out.append(Case("outputs", f"{name}: two writers into one --out",
                        _argv(name, f"{W}/o"), "either", parallel=2, check=_not_both,
                        timeout=180))
    out.append(Case("outputs", "build-dataset: a re-run keeps the build records",
                    WRITERS["build-dataset"][:3] + [f"{W}/bd"] + WRITERS["build-dataset"][4:],
                    "ok", setup=_built_once, check=_records_kept, timeout=120))
    out.append(Case("outputs", "build-dataset: a second session keeps the first's records",
                    ["build-dataset", f"{W}/s1", f"{W}/s2", *WRITERS["build-dataset"][2:3],
                     f"{W}/bd", *WRITERS["build-dataset"][4:]],
                    "ok", setup=_built_first_of_two, check=_records_kept_two, timeout=180))
    return out


def _cli(argv: list[str]) -> None:
    """Run the command line in a child process (a setup step)."""
    subprocess.run([sys.executable, "-m", "dressmeup", *argv], check=True,
                   capture_output=True, env={**os.environ})


def _built_once(w: Path) -> None:
    _cli([a.replace("{F}", str(_fx(w))) for a in WRITERS["build-dataset"][:3]
          + [str(w / "bd")] + WRITERS["build-dataset"][4:]])


def _records_kept(w: Path, results) -> str | None:
    info = json.loads((w / "bd" / "dataset.json").read_text())
    sessions = (info.get("build") or {}).get("sessions") or {}
    return None if "session" in sessions else f"build records after the re-run: {sessions}"


def _built_first_of_two(w: Path) -> None:
    bf.copy_tree(_fx(w) / "session", w / "s1")
    bf.copy_tree(_fx(w) / "session", w / "s2")
    info = json.loads((w / "s2" / "session.json").read_text())
    info["subject_id"] = "S02"  # another subject: samples of its own
    (w / "s2" / "session.json").write_text(json.dumps(info))
    rest = [a.replace("{F}", str(_fx(w))) for a in WRITERS["build-dataset"][4:]]
    _cli(["build-dataset", str(w / "s1"), "--out", str(w / "bd"), *rest])


def _records_kept_two(w: Path, results) -> str | None:
    info = json.loads((w / "bd" / "dataset.json").read_text())
    sessions = (info.get("build") or {}).get("sessions") or {}
    return None if {"s1", "s2"} <= set(sessions) else f"build records: {sorted(sessions)}"


def edition_create_cases() -> list[Case]:
    c = ["edition", "create", "--data", f"{W}/data", "--task", "retarget", "--name",
         "sweep-made", "--out", f"{W}/ed.json"]

    def tamper(d: Path) -> None:
        p = _garment(d)
        p.write_bytes(p.read_bytes()[:-8] + b"\x00" * 8)

    def unfinished(d: Path) -> None:
        info = json.loads((d / "dataset.json").read_text())
        info["complete"] = False
        (d / "dataset.json").write_text(json.dumps(info))

    damages = {
        "tampered data": tamper, "unfinished data": unfinished,
        "dataset.json not UTF-8": lambda d: (d / "dataset.json").write_bytes(b"\xff\xfe{}"),
        "dataset.json a list": lambda d: bf.json_file(d / "dataset.json", [1]),
        "manifest random bytes": lambda d: bf.random_bytes(d / "manifest.parquet"),
    }
    out = [Case("known", f"edition create: {k}", c, "refuse", setup=_dataset_copy(v))
           for k, v in damages.items()]
    out.append(Case("known", "edition create: under a shipped edition's name",
                    ["edition", "create", "--data", f"{F}/data", "--task", "retarget", "--name",
                     "synth-retarget-v3", "--out", f"{W}/ed.json"], "refuse"))
    out.append(Case("known", "edition create: --task uvparam on garment data",
                    ["edition", "create", "--data", f"{F}/data", "--task", "uvparam", "--name",
                     "sweep-uv", "--out", f"{W}/ed.json"], "refuse"))
    return out


def known_cases() -> list[Case]:
    scan = ["register", f"{W}/scan.npy", "--model", "procedural", "--out", f"{W}/fit.npz",
            "--iterations", "20,20,0", "--no-picture"]
    out = [
        Case("known", "register --model smpl --gender robot",
             ["register", f"{F}/scan.npy", "--model", "smpl", "--gender", "robot", "--out",
              f"{W}/fit.npz"], "refuse"),
        Case("known", "register: an upside-down scan", scan, "refuse|warn",
             setup=lambda w: _rotated_scan(w, "x", 180), timeout=120),
        Case("known", "register: a y-up scan told --up z", scan + ["--up", "z"], "refuse",
             setup=lambda w: _rotated_scan(w, "x", 0), timeout=120),
        Case("known", "metrics --samples 2000000000",
             ["metrics", f"{F}/garment.ply", f"{F}/garment.ply", "--samples", "2000000000"]),
        Case("known", "synth --garments 1000000",
             ["synth", f"{W}/o", "--subjects", "1", "--garments", "1000000", "--poses", "2",
              "--body-model", "procedural"]),
        Case("known", "synth --edge-length 0.0001 (872 GiB of garments)",
             ["synth", f"{W}/o", "--subjects", "1", "--garments", "1", "--poses", "2",
              "--body-model", "procedural", "--edge-length", "0.0001"]),
        Case("known", "score --scheduler a file",
             ["score", f"{F}/sub", *RET, "--out", f"{W}/res", "--scheduler", f"{F}/ed.json"]),
        Case("known", "baseline retarget --help lists every method",
             ["baseline", "retarget", "--help"], "ok", check=_all_methods),
        Case("known", "submit to a server that does not answer",
             ["submit", f"{F}/sub", "--edition", f"{F}/ed.json", "--server",
              "http://127.0.0.1:9", "--token", "x"]),
        Case("known", "server list --root an existing file",
             ["server", "list", "--root", f"{F}/ed.json"]),
        Case("known", "server list --database not a URL",
             ["server", "list", "--root", f"{W}/srv", "--database", "nope://x"]),
        Case("known", "server add-team with an empty name",
             ["server", "add-team", "", "--root", f"{W}/srv"]),
        Case("known", "edition fetch: an index of random bytes",
             ["edition", "fetch", f"{F}/ed-pinned.json", "--from", f"{W}/src", "--out",
              f"{W}/o", "--unpinned"],
             setup=lambda w: ((w / "src").mkdir(), bf.random_bytes(
                 w / "src" / "sweep-pinned-public.index.json"))),
        Case("known", "edition fetch: an 80 MB index",
             ["edition", "fetch", f"{F}/ed-pinned.json", "--from", f"{W}/src", "--out",
              f"{W}/o", "--unpinned"],
             setup=lambda w: ((w / "src").mkdir(), bf.big_json(
                 w / "src" / "sweep-pinned-public.index.json"))),
        Case("known", "edition verify: a folder of random files",
             ["edition", "verify", f"{W}/d", "--edition", f"{F}/ed-pinned.json"],
             setup=lambda w: ((w / "d").mkdir(), bf.random_bytes(w / "d" / "dataset.json"))),
        Case("known", "edition verify: a file", ["edition", "verify", f"{F}/ed.json"]),
        Case("known", "edition pack: --out an existing file",
             ["edition", "pack", f"{F}/ed-pinned.json", "--data", f"{F}/data", "--out",
              f"{W}/o"], setup=lambda w: bf.empty(w / "o")),
        Case("known", "import-capture tum: a folder of junk",
             ["import-capture", "tum", f"{W}/tum", "--out", f"{W}/s"],
             setup=lambda w: ((w / "tum").mkdir(), bf.random_bytes(w / "tum" / "rgb.txt"),
                              bf.random_bytes(w / "tum" / "depth.txt"),
                              bf.random_bytes(w / "tum" / "groundtruth.txt"))),
        Case("known", "import-capture 7scenes: an empty folder",
             ["import-capture", "7scenes", f"{W}/seq", "--out", f"{W}/s"],
             setup=lambda w: (w / "seq").mkdir()),
        Case("known", "import-capture redwood --intrinsics with NaN",
             ["import-capture", "redwood", f"{W}/rw", "--out", f"{W}/s", "--intrinsics",
              "nan,1,1,1"], setup=lambda w: (w / "rw").mkdir()),
        Case("known", "import-capture arkitscenes --frames ::0",
             ["import-capture", "arkitscenes", f"{W}/ark", "--out", f"{W}/s", "--frames",
              "::0"], setup=lambda w: (w / "ark").mkdir()),
        Case("known", "validate-session: a folder that does not exist",
             ["validate-session", f"{W}/nothing"]),
        Case("known", "validate-dataset: a dataset under a symlink loop",
             ["validate-dataset", f"{W}/loop_a"], setup=lambda w: bf.symlink_loop(w)),
    ]
    for c in out:
        if c.expect == "refuse|warn":
            c.expect = "warn:upside|--up"
    return out + edition_create_cases() + output_cases()


def _rotated_scan(w: Path, axis: str, degrees: float) -> None:
    import numpy as np
    from scipy.spatial.transform import Rotation

    pts = np.load(_fx(w) / "scan.npy")
    R = Rotation.from_euler(axis, degrees, degrees=True).as_matrix()
    np.save(w / "scan.npy", pts @ R.T)


def _all_methods(w: Path, results) -> str | None:
    text = results[0].stdout
    want = ["rigid", "skinning", "isomap", "isomap-offset", "isomap-refine",
            "isomap-refine-fast", "isomap-refine-sup", "detail", "penetration"]
    missing = [m for m in want if m not in text.replace("\n", " ")]
    return f"--help does not name {missing}" if missing else None


def cases() -> list[Case]:
    return known_cases()
