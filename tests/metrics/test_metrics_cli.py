"""``dressmeup metrics PRED GT``: figures equal the library's, units and arrows shown,
unreadable files give a non-zero exit and name the file."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from dressmeup import metrics as M
from dressmeup.cli import main
from dressmeup.io.mesh import save_mesh


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    m = trimesh.creation.icosphere(subdivisions=3)
    V, F = np.asarray(m.vertices) * 0.3, np.asarray(m.faces)
    pred = V * 1.01 + 0.001
    save_mesh(d / "gt.ply", V, F)
    save_mesh(d / "pred.obj", pred, F, uv=V[:, :2] * [1, 0.5] + [0.5, 0.25])
    save_mesh(d / "body.ply", V * 0.97, F)
    other = trimesh.creation.icosphere(subdivisions=2)
    save_mesh(d / "other.ply", np.asarray(other.vertices) * 0.3, np.asarray(other.faces))
    return d, (pred, F), (V, F)


def test_json_matches_library(files, capsys):
    d, pred, gt = files
    code = main(
        [
            "metrics",
            str(d / "pred.obj"),
            str(d / "gt.ply"),
            "--body",
            str(d / "body.ply"),
            "--samples",
            "3000",
            "--seed",
            "4",
            "--json",
        ]
    )
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    m = doc["metrics"]
    assert doc["samples"] == 3000 and doc["seed"] == 4
    assert m["P2S (bidirectional)"]["value"] == pytest.approx(
        M.p2s_bidirectional(pred, gt, n_samples=3000, seed=4), rel=1e-12
    )
    fq = M.fusion_quality(pred, gt, n_samples=3000, seed=4)
    assert m["P2S"]["value"] == pytest.approx(fq.accuracy, rel=1e-12)
    assert m["Chamfer-L1"]["value"] == pytest.approx(fq.chamfer_l1, rel=1e-12)
    assert m["F-score@5mm"]["value"] == pytest.approx(fq.fscore[0.005])
    assert m["ED"]["value"] == pytest.approx(M.euclidean(pred[0], gt[0]))
    assert m["ED"]["unit"] == "m" and m["ED"]["better"] == "lower"
    assert m["NC"]["value"] == pytest.approx(M.normal_consistency(pred, gt))
    assert m["IR"]["value"] == 0.0
    V = pred[0]
    assert m["QCE"]["value"] == pytest.approx(
        M.qce(V, pred[1], gt[0][:, :2] * [1, 0.5] + [0.5, 0.25])
    )
    assert {"Chamfer", "ASE", "UV flipped", "UV overlap", "Penetrating vertices"} <= set(m)


def test_table_in_mm_with_arrows_and_na_for_ed(files, capsys):
    d, _, _ = files
    code = main(["metrics", str(d / "other.ply"), str(d / "gt.ply"), "--samples", "2000"])
    assert code == 0
    out = capsys.readouterr().out
    ed = next(line for line in out.splitlines() if line.startswith("ED"))
    assert "n/a" in ed and "topology" in ed
    p2s = next(line for line in out.splitlines() if line.startswith("P2S "))
    assert "mm" in p2s and "\u2193" in p2s
    assert "\u2191" in next(line for line in out.splitlines() if line.startswith("NC"))
    assert "IR" not in out.split("note")[1]  # no body given


def test_unreadable_files_exit_nonzero_naming_the_file(files, capsys, tmp_path):
    d, _, _ = files
    assert main(["metrics", str(tmp_path / "missing.ply"), str(d / "gt.ply")]) != 0
    assert "missing.ply" in capsys.readouterr().err
    bad = tmp_path / "broken.obj"
    bad.write_text("v 1 2 x\n")
    assert main(["metrics", str(d / "gt.ply"), str(bad)]) != 0
    assert "broken.obj" in capsys.readouterr().err
    assert (
        main(
            [
                "metrics",
                str(d / "gt.ply"),
                str(d / "gt.ply"),
                "--body",
                str(tmp_path / "nobody.ply"),
            ]
        )
        != 0
    )
    assert "nobody.ply" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:  # a usage error found while parsing the options
        main(["metrics", str(d / "gt.ply"), str(d / "gt.ply"), "--samples", "0"])
    assert exc.value.code == 2
    assert "--samples" in capsys.readouterr().err
