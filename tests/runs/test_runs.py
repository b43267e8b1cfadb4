"""One path from a method to a submission: the baseline CLIs go through dressmeup.runs, record
the one hardware string and parse --param by the one rule."""

from __future__ import annotations

import json

import pytest

from dressmeup.bench import validate_submission
from dressmeup.bench.scoring.provenance import hardware
from dressmeup.cli import main


@pytest.fixture(scope="module")
def uv_mesh_set(tmp_path_factory):
    from dressmeup import runs

    root = tmp_path_factory.mktemp("uvset")
    ed = root / "uv.json"
    ed.write_text(json.dumps({
        "name": "uv-runs-v1", "version": 1, "task": "uvparam",
        "dataset": {"kind": "generated", "generator": "dressmeup-uvparam-shapes",
                    "generator_version": "uvparam-shapes-v1",
                    "params": {"mesh_ids": ["sheet-300", "sphere-300"]}, "seed": 0},
        "split": "test", "metrics": ["qce", "ase", "flip", "overlap", "time"],
        "options": {"overlap_resolution": 128}}))
    return ed, runs.build_data(ed, root / "meshes")


def test_uvparam_cli_runs_an_edition_mesh_set_through_runs(uv_mesh_set, tmp_path):
    ed, data = uv_mesh_set
    out = tmp_path / "sub"
    assert main(["baseline", "uvparam", "--method", "lscm", "--edition", str(ed), "--data",
                 str(data), "--out", str(out), "--param", "pack=true", "--param", "cone_angle=40"]) == 0
    assert validate_submission(out, ed, data).ok
    info = json.loads((out / "submission.json").read_text())
    assert info["hardware"] == hardware()
    assert info["hyperparameters"] == {"pack": "True", "cone_angle": "40"}
    assert sorted(p.stem for p in out.glob("*.npz")) == ["sheet-300", "sphere-300"]


def test_uvparam_cli_data_needs_an_edition(uv_mesh_set, tmp_path, capsys):
    _, data = uv_mesh_set
    assert main(["baseline", "uvparam", "--method", "lscm", "--data", str(data),
                 "--out", str(tmp_path / "s")]) == 2
    assert "--data needs --edition" in capsys.readouterr().err


def test_retarget_cli_records_hardware_and_parsed_params(bench_data, bench_edition, tmp_path):
    out = tmp_path / "sub"
    assert main(["baseline", "retarget", "--method", "skinning", "--data", str(bench_data),
                 "--edition", str(bench_edition), "--out", str(out),
                 "--param", "smooth_iterations=3", "--param", "normal_check=false"]) == 0
    info = json.loads((out / "submission.json").read_text())
    assert info["hardware"] == hardware()
    assert info["hyperparameters"] == {"smooth_iterations": "3", "normal_check": "False"}
    assert validate_submission(out, bench_edition, bench_data).ok
