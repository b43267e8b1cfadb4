"""The 3D view of the report site without a browser: the vendored three.js against its
recorded sums, the module-to-classic-script conversion, the per-vertex error against its
exact value, the display simplification, and what a method page carries."""

from __future__ import annotations

import base64
import hashlib
import json
import re

import numpy as np
import pytest

from dressmeup.viz import site_viewer
from dressmeup.viz.result_images import vertex_distances_mm


def test_vendored_three_matches_its_recorded_sums():
    readme = (site_viewer.VENDOR / "README.md").read_text()
    assert f"three@{site_viewer.THREE_VERSION}" in readme and "MIT" in readme
    rows = dict(re.findall(r"\| `([^`]+)` \| `[^`]+` \| `([0-9a-f]{64})` \|", readme))
    assert set(rows) == {*site_viewer.THREE_FILES, "LICENSE"}
    for name, digest in rows.items():
        assert hashlib.sha256((site_viewer.VENDOR / name).read_bytes()).hexdigest() == digest
    assert "MIT License" in (site_viewer.VENDOR / "LICENSE").read_text()


def test_modules_become_classic_scripts():
    src = ("import { A, B as C } from './core.js';\nexport { D } from './core.js';\n"
           "const x = C + A;\nexport { x, x as y };\n")
    out = site_viewer.classic_script(src)
    assert "import" not in out and "export" not in out
    assert "const { A, B: C } = THREE;" in out
    assert "Object.assign( THREE, { x, y: x } );" in out
    assert out.startswith("( function ( THREE ) {\n'use strict';")
    with pytest.raises(ValueError, match="export default"):
        site_viewer.classic_script("export default 1;\n")
    three = site_viewer.three_script()
    assert not re.search(r"^\s*(import|export)\b", three, re.M)
    assert "WebGLRenderer: WebGLRenderer" in three or "WebGLRenderer," in three
    assert "OrbitControls" in three


def _plane(n: int = 12):
    """A 1 m square in z = 0 as an (n x n)-vertex grid: (V, F)."""
    u = np.linspace(0.0, 1.0, n)
    X, Y = np.meshgrid(u, u, indexing="ij")
    V = np.stack([X.ravel(), Y.ravel(), np.zeros(n * n)], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), \
        idx[:-1, 1:].ravel()
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return V, F


def test_vertex_error_is_the_distance_to_the_truth_surface():
    """Every vertex of a prediction lifted off a flat truth by a known height is exactly
    that far from it (its foot lies inside the square)."""
    V, F = _plane()
    rng = np.random.default_rng(0)
    lift = rng.uniform(-0.02, 0.02, len(V))
    pred = V.copy()
    pred[:, 2] = lift
    assert np.allclose(vertex_distances_mm(pred, V, F), 1000 * np.abs(lift), atol=1e-6)


def test_display_simplification_keeps_the_shape_and_error():
    V, F = _plane(80)                                 # 12,482 faces
    err = 10.0 * V[:, 0]                              # an error growing along x
    V2, F2, e2 = site_viewer.cluster_simplify(V, F, err, max_faces=2000)
    assert 0 < len(F2) <= 2000 and F2.max() < len(V2) and len(e2) == len(V2)
    assert np.allclose(V2.min(0), V.min(0), atol=0.03) and np.allclose(V2.max(0), V.max(0),
                                                                      atol=0.03)
    assert np.allclose(e2, 10.0 * V2[:, 0], atol=1e-9)        # mean of a linear field
    same = site_viewer.cluster_simplify(V, F, err, max_faces=20_000)
    assert same[0] is V and len(same[1]) == len(F)


def _decode(mesh: dict, item: dict) -> tuple[np.ndarray, np.ndarray]:
    q = np.frombuffer(base64.b64decode(mesh["pos"]), "<u2").reshape(-1, 3)
    V = np.asarray(item["lo"]) + q * np.asarray(item["step"])
    F = np.frombuffer(base64.b64decode(mesh["idx"]), "<u4" if mesh["idx32"] else "<u2")
    return V, F.reshape(-1, 3)


def test_view_data_round_trips_within_quantisation():
    V, F = _plane()
    pred = V + [0.0, 0.0, 0.01]
    item = site_viewer.ItemView("a <b>", pred, F, vertex_distances_mm(pred, V, F), V, F,
                                V - [0, 0, 0.1], F)
    data = site_viewer.view_data([item], 10.0, "P2S", "ground truth")
    it = data["items"][0]
    PV, PF = _decode(it["pred"], it)
    assert np.abs(PV - pred).max() < 1.1 / 65535 and np.array_equal(PF, F)
    err = np.frombuffer(base64.b64decode(it["pred"]["err"]), "<f4")
    assert np.allclose(err, 10.0, atol=1e-4)
    assert len(base64.b64decode(data["lut"])) == 256 * 3 and data["vmax"] == 10.0
    assert "body" in it and it["caption"] == "a <b>"


def test_method_pages_carry_a_3d_view(site):
    root = site.index.parent
    assert (root / "_static" / f"three-{site_viewer.THREE_VERSION}.js").is_file()
    noisy = next(p for p in site.method_pages if p.stem == "noisy")
    text = noisy.read_text()
    assert 'id="viewer3d"' in text and 'data-layer="gt"' in text and 'data-layer="body"' in text
    js = (noisy.parent / "img" / "noisy-3d.js").read_text()
    data = json.loads(js[js.index("=") + 1:].rstrip().rstrip(";"))
    assert 2 <= len(data["items"]) <= 4                         # 2 best + 2 worst at most
    assert data["vmax"] > 0 and data["unit"] == "mm"
    options = re.findall(r"<option [^>]*>([^<]*)</option>", text)
    assert len(options) == len(data["items"])
    gone = next(p for p in site.method_pages if p.stem == "gone").read_text()
    assert 'id="viewer3d"' not in gone                           # no submission: no view
