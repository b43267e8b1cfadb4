"""`dressmeup edition pin`: a generated edition pinned to the manifest of its data, checked
to be that edition's generation first (the real synth-retarget-tiny-v5 data, built once into
the test cache where the parts and journey tests keep them)."""

from __future__ import annotations

import json
import shutil
from importlib import resources
from pathlib import Path

import pytest

from dressmeup.bench import load_edition
from dressmeup.bench.edition_create import pin_expected_manifest
from dressmeup.bench.tasks.common import manifest_sha256
from dressmeup.cli import main
from dressmeup.errors import InputError

EDITION = "synth-retarget-tiny-v5"


@pytest.fixture(scope="module")
def tiny_data():
    pytest.importorskip("dressmeup.runs")
    from dressmeup import runs
    from dressmeup.cache import cache_dir

    ed = load_edition(EDITION)
    return runs.build_data(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}" / "full")


def _shipped(name: str = EDITION) -> Path:
    return Path(str(resources.files("dressmeup.bench") / "editions" / f"{name}.json"))


def _unpinned(tmp_path: Path, name: str = EDITION) -> tuple[Path, str]:
    """A copy of the shipped edition without its pin, and the pin it had."""
    raw = json.loads(_shipped(name).read_text(encoding="utf-8"))
    sha = raw["dataset"].pop("expected_manifest_sha256")
    out = tmp_path / f"{name}.json"
    out.write_text(json.dumps(raw, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    return out, sha


def test_pin_restores_the_shipped_file_bit_for_bit(tiny_data, tmp_path, capsys):
    path, shipped_sha = _unpinned(tmp_path)
    sha = manifest_sha256(tiny_data)
    assert load_edition(path).hash != load_edition(EDITION).hash
    assert main(["edition", "pin", str(path), "--data", str(tiny_data)]) == 0
    out = capsys.readouterr().out
    assert sha in out
    assert json.loads(path.read_text())["dataset"]["expected_manifest_sha256"] == sha
    if sha == shipped_sha:  # generator 4 is portable: the shipped pin on any x86 CPU
        assert load_edition(EDITION).hash in out
        assert path.read_bytes() == _shipped().read_bytes()
    # a second run changes nothing
    before = path.stat().st_mtime_ns
    assert main(["edition", "pin", str(path), "--data", str(tiny_data)]) == 0
    assert "unchanged" in capsys.readouterr().out and path.stat().st_mtime_ns == before


def test_a_different_pin_is_replaced_only_when_asked(tiny_data, tmp_path):
    path, _ = _unpinned(tmp_path)
    sha = manifest_sha256(tiny_data)
    raw = json.loads(path.read_text(encoding="utf-8"))
    raw["dataset"]["expected_manifest_sha256"] = "0" * 64
    path.write_text(json.dumps(raw, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match="--replace"):
        pin_expected_manifest(path, tiny_data)
    assert json.loads(path.read_text())["dataset"]["expected_manifest_sha256"] == "0" * 64
    res = pin_expected_manifest(path, tiny_data, replace=True)
    assert res.changed and res.previous == "0" * 64 and res.sha256 == sha
    assert res.new_hash == load_edition(path).hash != res.old_hash


def test_other_data_are_refused_naming_why(tiny_data, tmp_path):
    # another generator-4 edition's parameters (the mini edition: more bodies and garments)
    mini, _ = _unpinned(tmp_path, "synth-retarget-mini-v5")
    with pytest.raises(InputError, match="generator parameter 'plan'"):
        pin_expected_manifest(mini, tiny_data)
    # the test split seeded by another secret
    path, _ = _unpinned(tmp_path)
    raw = json.loads(path.read_text(encoding="utf-8"))
    raw["dataset"]["test_split"] = {"commitment": "1" * 64, "secret": None}
    other = tmp_path / "other-secret.json"
    other.write_text(json.dumps(raw), encoding="utf-8")
    with pytest.raises(InputError, match="commitment e1f18093"):
        pin_expected_manifest(other, tiny_data)
    # an unfinished build
    data = tmp_path / "data"
    shutil.copytree(tiny_data, data)
    info = json.loads((data / "dataset.json").read_text())
    (data / "dataset.json").write_text(json.dumps({**info, "complete": False}))
    with pytest.raises(InputError, match="not finished"):
        pin_expected_manifest(path, data)
    # a damaged file
    (data / "dataset.json").write_text(json.dumps(info))
    ply = next(data.glob("samples/*/*/*/garment.ply"))
    ply.write_bytes(ply.read_bytes()[:-8])
    with pytest.raises(InputError, match="garment.ply"):
        pin_expected_manifest(path, data)
    assert "expected_manifest_sha256" not in json.loads(path.read_text())["dataset"]


def test_refuses_editions_it_cannot_check(tiny_data, tmp_path):
    with pytest.raises(InputError, match="no such edition file"):
        pin_expected_manifest(tmp_path / "missing.json", tiny_data)
    older, _ = _unpinned(tmp_path, "synth-retarget-tiny-v4")
    with pytest.raises(InputError, match="generator-4"):
        pin_expected_manifest(older, tiny_data)
