"""Tiny retargeting data on the procedural body: a 'shirt' cut from the torso skin, offset
1 cm along the normals, and its analytic ground truth on a target body (the same cut of the
target skin, offset the same way)."""

from __future__ import annotations

import numpy as np
import pytest

FAST = dict(dim=32, embedding_method="landmark", n_landmarks=150)


@pytest.fixture(scope="session")
def body_model():
    from dressmeup.body import get_body_model

    return get_body_model("procedural")


def _cut(model, params, sel, offset):
    from dressmeup.methods.retarget.base import body_context

    ctx = body_context(model, params)
    idx = np.flatnonzero(sel)
    remap = -np.ones(model.n_vertices, dtype=np.int64)
    remap[idx] = np.arange(len(idx))
    F = remap[model.faces[sel[model.faces].all(axis=1)]]
    V = ctx.vertices[idx] + offset * ctx.skin_normals()[idx]
    return V, F


@pytest.fixture(scope="session")
def tiny(body_model):
    """dict with garment V, F on the source body, source/target BodyParams and ground truth."""
    m = body_model
    src = m.default_params()
    tgt = src.copy()
    tgt.pose[16] = [0.0, 0.0, -0.6]
    tgt.pose[17] = [0.0, 0.0, 0.6]
    tgt.pose[0] = [0.0, 0.4, 0.0]
    tgt.shape[3] = 0.7
    tgt.transl[:] = [0.1, 0.0, -0.2]
    y = m.template_vertices[:, 1]
    sel = (y > np.percentile(y, 50)) & (y < np.percentile(y, 75))
    V, F = _cut(m, src, sel, 0.01)
    GT, _ = _cut(m, tgt, sel, 0.01)
    return {"V": V, "F": F, "source": src, "target": tgt, "gt": GT}


@pytest.fixture(scope="session")
def tiny_retarget_data():
    """The full synth-retarget-tiny-v5 data (procedural body, 2 test bottoms, 8 samples),
    built once into the test cache where the journey, parts and server tests keep them."""
    pytest.importorskip("dressmeup.runs")
    from dressmeup.bench import load_edition
    from dressmeup.cache import cache_dir
    from dressmeup.runs import build_data

    ed = load_edition("synth-retarget-tiny-v5")
    return build_data(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}" / "full")
