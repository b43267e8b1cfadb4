"""``lscm-on-charts`` flattens the neural method's own charts with LSCM (equal seams)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

from dressmeup.data.shapes import make_test_mesh  # noqa: E402
from dressmeup.methods.uvparam import get_method  # noqa: E402
from dressmeup.metrics.uv import uv_validity  # noqa: E402


def test_same_charts_as_the_neural_method_and_a_valid_layout():
    V, F = make_test_mesh("skirt-3k")
    neural = get_method("neural", pretrained="bottomwear").parameterize(V, F)
    res = get_method("lscm-on-charts", pretrained="bottomwear").parameterize(V, F)
    assert np.array_equal(res.chart_ids, neural.chart_ids)
    assert res.info["track"] == neural.info["track"] == "pretrained"
    assert res.uv_faces.shape == F.shape and np.isfinite(res.uv).all()
    assert res.uv.min() >= -1e-9 and res.uv.max() <= 1 + 1e-9      # packed into the unit square
    v = uv_validity(V, F, res.uv, res.uv_faces)
    assert v.flipped_fraction < 0.05
