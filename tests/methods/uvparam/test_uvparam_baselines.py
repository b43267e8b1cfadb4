"""Classical UV baselines and the shared atlas helpers: valid UVs on closed and open meshes."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.data.shapes import make_test_mesh, parse_mesh_id
from dressmeup.geometry.uv_atlas import (
    chart_is_disk,
    make_disk_charts,
    orient_charts,
    pack_charts,
    parameterize_charts,
    signed_uv_areas,
    split_charts,
)
from dressmeup.methods.uvparam import get_method
from dressmeup.methods.uvparam.lscm import lscm_flatten
from dressmeup.methods.uvparam.segmentation import normal_cone_segmentation
from dressmeup.metrics import qce, uv_validity

MESHES = {"closed": "sphere-400", "closed-genus1": "torus-600", "open-disk": "sheet-400",
          "open-annulus": "skirt-600"}


@pytest.fixture(scope="module")
def meshes():
    return {k: make_test_mesh(v) for k, v in MESHES.items()}


def check_valid(V, F, res, closed):
    m = len(F)
    assert res.uv.ndim == 2 and res.uv.shape[1] == 2
    assert np.all(np.isfinite(res.uv))
    assert res.uv_faces.shape == (m, 3)
    assert res.uv_faces.min() >= 0 and res.uv_faces.max() < len(res.uv)
    assert res.chart_ids.shape == (m,)
    assert set(np.unique(res.chart_ids)) == set(range(res.n_charts))
    if closed:
        assert res.n_charts >= 2, "a closed surface cannot be flattened as one chart"
    area = signed_uv_areas(res.uv, res.uv_faces)
    assert np.count_nonzero(area == 0) == 0
    val = uv_validity(V, F, res.uv, res.uv_faces, resolution=512)
    assert val.flipped_fraction == 0.0
    assert val.overlap_fraction < 0.01
    # every chart is a topological disk in UV: its faces share UV rows only inside the chart
    for ch in split_charts(F, res.chart_ids):
        rows = np.unique(res.uv_faces[ch.faces])
        others = np.setdiff1d(np.arange(m), ch.faces)
        assert not np.isin(res.uv_faces[others], rows).any()
    assert res.seconds > 0


@pytest.mark.parametrize("method", ["xatlas", "lscm", "harmonic", "slim"])
@pytest.mark.parametrize("kind", list(MESHES))
def test_baselines_valid_uvs(meshes, method, kind):
    V, F = meshes[kind]
    res = get_method(method).parameterize(V, F)
    check_valid(V, F, res, closed=kind.startswith("closed"))
    assert res.uv.min() >= -1e-9 and res.uv.max() <= 1 + 1e-9  # packed


def test_lscm_on_a_plane_is_isometric_up_to_scale():
    # a flat, irregular planar grid: LSCM reproduces it up to a similarity -> QCE 1
    rng = np.random.default_rng(0)
    k = 12
    s = np.linspace(0, 1, k)
    X, Y = np.meshgrid(s, s, indexing="ij")
    P = np.stack([X, Y], -1).reshape(-1, 2) + rng.uniform(-0.02, 0.02, (k * k, 2))
    V = np.c_[P, np.zeros(len(P))] @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
    from dressmeup.data.shapes import _grid_faces

    F = _grid_faces(k, k, False, False)
    uv = lscm_flatten(V, F)
    assert qce(V, F, uv) == pytest.approx(1.0, abs=1e-6)


def test_unknown_method_and_bad_input():
    with pytest.raises(ValueError, match="method"):
        get_method("nope")
    with pytest.raises(ValueError, match="mesh"):
        get_method("lscm").parameterize(np.zeros((3, 2)), np.array([[0, 1, 2]]))
    with pytest.raises(Exception, match="shape"):
        parse_mesh_id("cube-3k")


def test_segmentation_gives_disks_within_the_cone():
    V, F = make_test_mesh("blob-2k")
    ids = normal_cone_segmentation(V, F, cone_angle=np.deg2rad(40), min_faces=1)
    from dressmeup.geometry.mesh import face_areas, face_normals

    N, A = face_normals(V, F), face_areas(V, F)
    worst = []
    for ch in split_charts(F, ids):
        assert chart_is_disk(ch.local_faces)
        m = (N[ch.faces] * A[ch.faces, None]).sum(0)
        m /= np.linalg.norm(m)
        worst.append(np.degrees(np.arccos(np.clip(N[ch.faces] @ m, -1, 1))).max())
    # every face joined within 40 deg of its region's running mean normal, so no face can be
    # more than 80 deg from the final mean; in practice the drift is small
    assert np.max(worst) < 80
    assert np.median(worst) < 50
    # a tighter cone gives more charts
    n_tight = normal_cone_segmentation(V, F, cone_angle=np.deg2rad(25), min_faces=1).max()
    n_wide = normal_cone_segmentation(V, F, cone_angle=np.deg2rad(70), min_faces=1).max()
    assert n_tight > ids.max() > n_wide


def test_make_disk_charts_cuts_a_closed_sphere_and_a_torus():
    for mid in ("sphere-300", "torus-300"):
        V, F = make_test_mesh(mid)
        ids = make_disk_charts(V, F, np.zeros(len(F), dtype=np.int64))
        assert ids.max() >= 1
        assert all(chart_is_disk(ch.local_faces) for ch in split_charts(F, ids))


def test_packing_keeps_chart_shapes_and_orientation():
    V, F = make_test_mesh("sphere-400")
    ids = normal_cone_segmentation(V, F)
    uv, uvf = parameterize_charts(V, F, ids, lscm_flatten)
    q0 = qce(V, F, uv, uvf)
    puv, puvf = pack_charts(uv, uvf)
    assert qce(V, F, puv, puvf) == pytest.approx(q0, rel=1e-4)
    assert np.all(signed_uv_areas(puv, puvf) > 0)
    # mirroring a chart by hand is undone by orient_charts, inside the chart's box
    mirrored = puv.copy()
    rows = np.unique(puvf[ids == 0])
    mirrored[rows, 0] = 1.0 - mirrored[rows, 0]
    fixed = orient_charts(mirrored, puvf)
    assert np.all(signed_uv_areas(fixed, puvf) > 0)
    assert fixed[rows, 0].min() >= mirrored[rows, 0].min() - 1e-12


def test_test_meshes_are_deterministic_and_sized():
    a = make_test_mesh("torus-3k")
    b = make_test_mesh("torus-3k")
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    for mid, lo, hi in (("sphere-2k", 1800, 2200), ("blob-30k", 28000, 32000), ("skirt-3k", 2700, 3300)):
        V, _ = make_test_mesh(mid)
        assert lo <= len(V) <= hi, mid


def test_shelf_pack_keeps_charts_apart_and_undistorted():
    from dressmeup.geometry.uv_atlas import shelf_pack, uv_components

    V, F = make_test_mesh("torus-600")
    ids = normal_cone_segmentation(V, F)
    uv, uvf = parameterize_charts(V, F, ids, lscm_flatten)
    comp = uv_components(uvf, len(uv))
    row_comp = np.zeros(len(uv), dtype=np.int64)
    row_comp[uvf.reshape(-1)] = np.repeat(comp, 3)
    out = shelf_pack(uv, row_comp, comp)
    assert out.min() >= 0 and out.max() <= 1 + 1e-12
    assert qce(V, F, out, uvf) == pytest.approx(qce(V, F, uv, uvf), rel=1e-9)
    assert uv_validity(V, F, out, uvf, resolution=512).overlap_fraction == 0.0
