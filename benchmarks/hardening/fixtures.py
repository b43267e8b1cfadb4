"""The sweep's valid starting files, built once into a folder (``F`` in the case lines).

Everything is small and made here or by the toolkit itself: the bench tests' tube dataset on
the procedural body (9 samples, one split) with an edition pinned to it, a ground-truth
submission and its scored result, meshes, point scans, body parameters, a synthetic capture
session, and tiny 4D-DRESS / THuman2 folders written in their published layouts by the
adapter tests' helpers.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]


def _module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def build(root: Path, log=print) -> Path:
    """Build the fixtures under ``root`` (kept when ``root/.done`` exists)."""
    if (root / ".done").exists():
        return root
    if root.exists():
        shutil.rmtree(root)
    root.mkdir(parents=True)
    bench = _module("sweep_bench_fixture", REPO / "tests" / "bench" / "conftest.py")
    adapters = _module("sweep_adapter_helpers", REPO / "tests" / "data" / "test_data_adapters.py")
    from dressmeup.bench import score_submission
    try:  # the sweep also measures toolkits from before edition_create existed
        from dressmeup.bench.edition_create import create_edition
    except ImportError:
        from dressmeup.bench.edition import create_edition
    from dressmeup.body import get_body_model
    from dressmeup.cli import main
    from dressmeup.io.mesh import load_mesh, save_mesh

    log("fixtures: dataset, edition, submission, result")
    data = bench.build_fixture_dataset(root / "data")
    ed = bench.write_edition(root / "ed.json")
    create_edition(data, "retarget", "sweep-pinned", split="test").save(root / "ed-pinned.json")
    preds = bench.gt_predictions(data, ed)
    sub = bench.make_submission(root / "sub", preds, ed, "GT")
    score_submission(sub, ed, data, root / "res", workers=1, show_progress=False)
    noisy = bench.make_submission(root / "sub-noisy",
                                  bench.perturbed_predictions(data, ed), ed, "noisy")
    score_submission(noisy, ed, data, root / "res-noisy", workers=1, show_progress=False)

    log("fixtures: meshes, scans, bodies")
    g = load_mesh(data / "samples" / "S01" / "G01" / "P0" / "garment.ply")
    save_mesh(root / "garment.ply", g.vertices, g.faces)
    save_mesh(root / "garment.obj", g.vertices, g.faces)
    save_mesh(root / "garment_mm.ply", g.vertices * 1000.0, g.faces)
    model = get_body_model("procedural")
    params = model.default_params()
    posed = model.posed(params)
    save_mesh(root / "body.ply", posed.vertices, model.faces)
    np.save(root / "scan.npy", posed.vertices)
    params.save(root / "body.npz")
    (root / "keypoints.json").write_text(json.dumps({"pelvis": [0.0, 0.9, 0.0]}))

    log("fixtures: capture session and scan")
    for argv in (["synth-capture", "mannequin", "--out", str(root / "session"), "--scale",
                  "0.2"],
                 ["fuse", str(root / "session"), "--out", str(root / "scan"), "--voxel",
                  "0.02"]):
        if main(argv) != 0:
            raise RuntimeError(f"fixture command failed: {argv}")

    log("fixtures: 4D-DRESS and THuman2 folders")
    adapters._dress4d_take(root / "4ddress", "00122", "Inner", "Take2", ["00011", "00012"],
                           [["upper", "lower"], ["upper", "lower"]], seed=1)
    V, F = adapters._tri_mesh()
    for sid in ("0007", "0008"):
        save_mesh(root / "thuman" / "scans" / sid / f"{sid}.obj", V, F)
        adapters._pkl(root / "thuman" / "fits" / sid / "smplx_param.pkl", {
            "betas": np.zeros((1, 10)), "global_orient": np.zeros((1, 3)),
            "body_pose": np.zeros((1, 63)), "transl": np.zeros((1, 3))})
    (root / ".done").write_text("ok\n")
    return root
