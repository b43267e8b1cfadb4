"""A `synth` run killed after any single write resumes into exactly the dataset of an
uninterrupted run: same files, same manifest, same summary report."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from dressmeup.data import Dataset, validate_dataset
from dressmeup.data.synth import DrapeSettings, generate_dataset

# the write order is what is tested, not the cloth: the cheapest settings that still drape
KW = {"subjects": 1, "garments": 1, "poses": 1, "seed": 5, "body_model": "procedural",
      "edge_length": 0.05, "texture_size": 8, "write_scan": False,
      "drape_settings": DrapeSettings(outer_iterations=1, inner_iterations=2)}
CHECKSUMS = ["sample_id", "garment_sha256", "body_sha256", "texture_sha256"]


class Killed(BaseException):
    """Stands for SIGKILL: nothing after it runs, no ``except Exception`` catches it."""


def _snapshot(root: Path) -> dict:
    info = json.loads((root / "dataset.json").read_text())
    stats = {p.name: p.read_text() for p in sorted((root / "generator" / "stats").iterdir())}
    manifest = Dataset(root).manifest[CHECKSUMS].sort_values("sample_id").values.tolist()
    return {"report": info.get("report"), "n_samples": info.get("n_samples"),
            "complete": info.get("complete"), "stats": stats, "manifest": manifest}


def _kill_after_write(monkeypatch, k: int) -> list[str]:
    """Make the k-th atomic rename (1-based) the last thing the process does; like a kill in
    the middle of the next write, leave a 0-byte hidden temporary file beside it."""
    real = os.replace
    done: list[str] = []

    def replace(src, dst):
        real(src, dst)
        done.append(str(dst))
        if len(done) == k:
            d = Path(dst)
            (d.parent / f".{d.stem}.killed.tmp{d.suffix}").write_bytes(b"")
            raise Killed(str(dst))

    monkeypatch.setattr(os, "replace", replace)
    return done


def test_kill_after_every_write_then_resume_matches_an_uninterrupted_run(tmp_path,
                                                                          monkeypatch):
    ref = generate_dataset(tmp_path / "ref", **KW)
    expected = _snapshot(ref)
    assert expected["report"]["n"] == 1 and len(expected["stats"]) == 1

    with monkeypatch.context() as m:
        writes = _kill_after_write(m, 10 ** 9)
        generate_dataset(tmp_path / "count", **KW)
    n_writes = len(writes)
    assert n_writes >= 8

    for k in range(1, n_writes + 1):
        run = tmp_path / f"run{k}"
        with monkeypatch.context() as m:
            _kill_after_write(m, k)
            with pytest.raises(Killed):
                generate_dataset(run, **KW)
        generate_dataset(run, **KW)  # resume
        got = _snapshot(run)
        assert got == expected, f"killed after write {k} of {n_writes}: {writes[k - 1]}"
        rep = validate_dataset(run)
        assert rep.ok, rep.format()
        assert not [p for p in run.rglob(".*") if p.is_file()], "temporary files left"
        shutil.rmtree(run)
