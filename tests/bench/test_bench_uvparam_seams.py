"""uvparam task: seam metrics in the scores, the QCE-vs-seams Pareto front, tracks."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dressmeup.bench.tasks.uvparam.evaluate import evaluate_uv, submission_track
from dressmeup.bench.tasks.uvparam.render import pareto_front
from dressmeup.errors import InputError


def _grid(k):
    s = np.linspace(0.0, 1.0, k)
    X, Y = np.meshgrid(s, s, indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), np.zeros(k * k)], 1)
    idx = np.arange(k * k).reshape(k, k)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return V, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_cutting_every_face_wins_nothing_on_seams():
    V, F = _grid(5)
    metrics = ["qce", "seam_length", "charts", "packing"]
    whole = evaluate_uv(V, F, V[:, :2], None, metrics, {})
    UF = np.arange(3 * len(F)).reshape(-1, 3)
    UV = V[F.reshape(-1), :2] + np.repeat(np.arange(len(F)), 3)[:, None] * [0.5, 0.0]
    cut = evaluate_uv(V, F, UV, UF, metrics, {})
    assert whole["qce"] == pytest.approx(cut["qce"])            # same distortion ...
    assert whole["seam_length"] == 0.0 and cut["seam_length"] > 5.0  # ... bought by cutting
    assert (whole["charts"], cut["charts"]) == (1.0, float(len(F)))
    assert cut["packing"] < whole["packing"] == pytest.approx(1.0)


def test_pareto_front():
    scores = {"cut-all": {"qce": 1.00, "seam_length": 9.0},
              "lscm": {"qce": 1.01, "seam_length": 3.0},
              "worse": {"qce": 1.20, "seam_length": 3.5},     # dominated by lscm
              "seamless": {"qce": 1.50, "seam_length": 0.0},
              "broken": {"qce": float("nan"), "seam_length": 0.0}}
    assert pareto_front(scores) == {"cut-all", "lscm", "seamless"}
    assert pareto_front({"a": {"qce": 1.0, "seam_length": 1.0},
                         "b": {"qce": 1.0, "seam_length": 1.0}}) == {"a", "b"}


def test_submission_track(tmp_path):
    tracks = ("pretrained", "per-mesh")
    assert submission_track(tmp_path, tracks) == "per-mesh"      # no submission.json
    (tmp_path / "submission.json").write_text(json.dumps({"track": "pretrained"}))
    assert submission_track(tmp_path, tracks) == "pretrained"
    (tmp_path / "submission.json").write_text(json.dumps({"track": "cheat"}))
    with pytest.raises(InputError, match="track"):
        submission_track(tmp_path, tracks)


@pytest.mark.slow  # generates five garments (~70 s on a loaded 2-core machine)
def test_garment_edition_builds_splits_scores_seams_and_tracks(tmp_path):
    from dressmeup import runs
    from dressmeup.bench.scoring.score import score_submission
    from dressmeup.bench.tasks.uvparam.data import meshes

    ed_path = tmp_path / "uv2.json"
    ed_path.write_text(json.dumps({
        "name": "uv-garments-test-v2", "version": 2, "task": "uvparam",
        "dataset": {"kind": "generated", "generator": "dressmeup-uvparam-shapes",
                    "generator_version": "uvparam-meshes-v2",
                    "params": {"mesh_ids": ["sheet-300"],
                               "garments": {"subjects": 1, "garments": 5, "poses": 1,
                                            "seed": 3, "body_model": "procedural",
                                            "write_scan": False, "texture_size": 16}},
                    "seed": 0},
        "split": "test", "metrics": ["qce", "seam_length", "charts", "packing", "flip"],
        "options": {"overlap_resolution": 256}, "tracks": ["pretrained", "per-mesh"],
        "primary": {"metric": "qce", "track": "pretrained"}}))
    data = runs.build_data(ed_path, tmp_path / "meshes")
    allm = meshes(data)
    assert {m.category for m in allm} >= {"shapes"} and len(allm) == 6
    test = meshes(data, "test")
    assert any(m.mesh_id == "sheet-300" for m in test) and len(test) < len(allm)
    sub = runs.run_uvparam_baseline("lscm", ed_path, data, tmp_path / "lscm")
    assert json.loads((sub / "submission.json").read_text())["track"] == "per-mesh"
    res = score_submission(sub, ed_path, data, tmp_path / "r", workers=1, show_progress=False)
    t = res.table.set_index("sample_id")
    assert set(t.index) == {m.mesh_id for m in test}
    garments = [i for i in t.index if i != "sheet-300"]
    assert (t.loc[garments, "seam_length"] > 0).all() and (t["charts"] >= 1).all()
    assert t.loc["sheet-300", "seam_length"] >= 0.0
    assert (t["track"] == "per-mesh").all()
