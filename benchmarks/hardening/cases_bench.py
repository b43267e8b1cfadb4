"""Bad files of the bench side: submissions (members that inflate or number 100,000,
declared gigabytes, objects, predictions in millimetres, broken submission.json), result
folders (summaries that are lists, random, forged or carry a script; per-item tables of
random bytes or two million rows), edition files and network checkpoints that are not.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import bad_files as bf
from cases_common import _fx, _standard
from runner import Case

F, W = "{F}", "{W}"


def _result_copy(damage):
    def setup(w: Path) -> None:
        d = bf.copy_tree(_fx(w) / "res", w / "res")
        damage(d)
    return setup


def _summary_edit(fn):
    def damage(d: Path) -> None:
        s = json.loads((d / "summary.json").read_text())
        fn(s)
        (d / "summary.json").write_text(json.dumps(s))
    return damage


def _sub_copy(damage):
    def setup(w: Path) -> None:
        d = bf.copy_tree(_fx(w) / "sub", w / "sub")
        damage(d)
    return setup


def _first_npz(d: Path) -> Path:
    return sorted(d.glob("*.npz"))[0]


def submission_cases() -> list[Case]:
    out = []
    v = ["validate-submission", f"{W}/sub", "--data", f"{F}/data", "--edition", f"{F}/ed.json"]
    s = ["score", f"{W}/sub", "--data", f"{F}/data", "--edition", f"{F}/ed.json", "--out",
         f"{W}/res", "--workers", "1"]
    damages = {
        "a member inflating to 1 GB": lambda d: bf.npz_inflating(_first_npz(d)),
        "100,000 members": lambda d: bf.npz_many(_first_npz(d)),
        "declares 2.4 GB": lambda d: bf.npz_declared(_first_npz(d)),
        "random bytes": lambda d: bf.random_bytes(_first_npz(d)),
        "truncated": lambda d: bf.truncated(_first_npz(d), _first_npz(d)),
        "objects": lambda d: _np_savez(_first_npz(d), vertices=[{"a": 1}]),
        "prediction in millimetres": _mm_prediction,
        "submission.json a list": lambda d: bf.json_file(d / "submission.json", [1]),
        "submission.json 80 MB": lambda d: bf.big_json(d / "submission.json"),
        "submission.json not UTF-8": lambda d: (d / "submission.json").write_bytes(b"\xff{"),
    }
    for label, damage in damages.items():
        for argv in (v, s):
            out.append(Case("files", f"{argv[0]}: {label}", argv, "refuse",
                            setup=_sub_copy(damage), timeout=90))
    return out


def _np_savez(p: Path, **arrays) -> Path:
    import numpy as np

    np.savez(p, **{k: np.asarray(a, dtype=object) for k, a in arrays.items()})
    return p


def _mm_prediction(d: Path) -> None:
    import numpy as np

    for p in sorted(d.glob("*.npz")):
        with np.load(p) as z:
            arrays = {k: z[k] for k in z.files}
        arrays["vertices"] = arrays["vertices"] * 1000.0
        np.savez(p, **arrays)


def result_cases() -> list[Case]:
    lb = ["leaderboard", f"{W}/res", f"{F}/res-noisy"]
    rp = ["report", f"{W}/res", f"{F}/res-noisy", "--out", f"{W}/site", "--max-images", "0"]
    damages = {
        "summary.json a list": lambda d: bf.json_file(d / "summary.json", [1]),
        "summary.json 80 MB": lambda d: bf.big_json(d / "summary.json"),
        "summary.json random bytes": lambda d: bf.random_bytes(d / "summary.json"),
        "bootstrap resamples a string": _summary_edit(
            lambda s: s.setdefault("bootstrap", {}).__setitem__("resamples", "many")),
        "n_units a script": _summary_edit(lambda s: [
            m.__setitem__("n_units", "<script>alert(3)</script>")
            for m in s.get("metrics", {}).values() if isinstance(m, dict)]),
        "forged interval ci95 [0, 0]": _summary_edit(lambda s: [
            m.update(ci95=[0.0, 0.0], mean=0.0) for m in s.get("metrics", {}).values()
            if isinstance(m, dict)]),
        "not comparable edited to comparable": _summary_edit(
            lambda s: s.get("dataset", {}).update(comparable=True, manifest_sha256="0" * 64)),
        "per_sample random bytes": lambda d: bf.random_bytes(d / "per_sample.parquet"),
        "per_sample truncated": lambda d: bf.truncated(d / "per_sample.parquet",
                                                       d / "per_sample.parquet"),
        "per_sample 2 million rows": lambda d: bf.parquet_rows(d / "per_sample.parquet",
                                                               d / "per_sample.parquet"),
        "edition.json random bytes": lambda d: bf.random_bytes(d / "edition.json"),
        "a symlink loop as the folder": lambda d: (shutil.rmtree(d), bf.symlink_loop(d.parent),
                                                   d.symlink_to(d.parent / "loop_a")),
    }
    out = []
    for label, damage in damages.items():
        for argv in (lb, rp):
            out.append(Case("files", f"{argv[0]}: {label}", argv, "refuse",
                            setup=_result_copy(damage), check=_no_script, timeout=90))
    for argv in (lb, rp):
        out.append(Case("files", f"{argv[0]}: a result folder that is a file",
                        argv, "refuse", setup=lambda w: bf.empty(w / "res")))
    return out


def _no_script(w: Path, results) -> str | None:
    for page in (w / "site").rglob("*.html") if (w / "site").exists() else ():
        if "<script>alert(3)" in page.read_text(errors="replace"):
            return f"{page.name} carries the injected script"
    for r in results:
        if "<script>alert(3)" in r.stdout:
            return "the leaderboard prints the injected script"
    return None


def edition_file_cases() -> list[Case]:

    out = _standard("files", ["editions", "@"], "ed.json", "ed.json", [
        ("80 MB", lambda w: bf.big_json(w / "ed.json")),
        ("nested deep", lambda w: bf.deep_json(w / "ed.json")),
        ("a list", lambda w: bf.json_file(w / "ed.json", [1])),
    ])
    out += _standard("files", ["baseline", "retarget", "--method", "isomap-refine", "--data",
                               f"{F}/data", "--edition", f"{F}/ed.json", "--out", f"{W}/sub",
                               "--weights", "@"], "w.pt", "body.npz", [
        ("a pickle of a billion laughs", lambda w: bf.laughs_pickle(w / "w.pt")),
        ("an npz", lambda w: shutil.copy(_fx(w) / "body.npz", w / "w.pt")),
    ])
    out += _standard("files", ["baseline", "uvparam", "--method", "neural", "--meshes",
                               f"{F}/garment.ply", "--out", f"{W}/sub", "--checkpoint", "@"],
                     "c.pt", "body.npz", [
        ("a pickle of a billion laughs", lambda w: bf.laughs_pickle(w / "c.pt")),
    ])
    return out


def cases() -> list[Case]:
    """Every bad-file case of the bench side."""
    return submission_cases() + result_cases() + edition_file_cases()
