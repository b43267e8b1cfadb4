"""Garment extraction: label voting accuracy, cut-out, colour fallback, texture baking."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.capture.camera import Camera
from dressmeup.capture.rig import Rig
from dressmeup.capture.synthetic import SyntheticSubject, render_frames
from dressmeup.extraction.cutout import cut_garment, remove_ears
from dressmeup.extraction.labels import ColorFallbackWarning, cluster_colors, label_mesh
from dressmeup.extraction.texture import bake_texture, uv_atlas
from dressmeup.fusion.evaluate import face_label_accuracy
from dressmeup.fusion.pipeline import FusionConfig, fuse_frames


@pytest.fixture(scope="module")
def fused(mannequin, small_rig, clean_frames):
    return fuse_frames(clean_frames, small_rig, FusionConfig(voxel_size=0.008))


def test_label_voting_matches_ground_truth(fused, mannequin, small_rig):
    fl = label_mesh(fused.vertices, fused.faces, fused.frames, small_rig, 4)
    acc = face_label_accuracy(fused.vertices, fused.faces, fl, mannequin.vertices, mannequin.faces,
                              mannequin.face_labels)
    assert acc > 0.95
    for lab in (2, 3):
        V, F, ids = cut_garment(fused.vertices, fused.faces, fl, lab)
        assert np.all(fl[ids] == lab)
        # the garment lies on the right band of heights
        lo, hi = {2: (0.9, 1.55), 3: (0.28, 1.02)}[lab]
        assert np.mean((V[:, 1] > lo) & (V[:, 1] < hi)) > 0.97
    with pytest.raises(ValueError, match="label 7"):
        cut_garment(fused.vertices, fused.faces, fl, 7)


def test_colour_fallback_warns_and_separates_plain_colours():
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=4)
    V, F = np.asarray(m.vertices), np.asarray(m.faces)
    C = np.where((V[:, 1] > 0.2)[:, None], [[30, 60, 200]], [[225, 170, 140]]).astype(np.uint8)
    with pytest.warns(ColorFallbackWarning):
        fl = cluster_colors(V, F, C, [2])
    cy = V[F].mean(axis=1)[:, 1]
    truth = np.where(cy > 0.2, 2, 1)
    assert np.mean(fl == truth) > 0.95


def test_remove_ears_drops_dangling_triangles():
    # a strip of two triangles plus an ear hanging on one edge
    F = np.array([[0, 1, 2], [1, 3, 2], [2, 3, 4]])
    keep = remove_ears(F, max_rounds=1)
    assert keep.tolist() == [False, True, False]


def test_baked_texture_reproduces_a_known_pattern():
    # a plane in front of one camera with a colour that depends on x
    n = 20
    xs, ys = np.meshgrid(np.linspace(-0.5, 0.5, n), np.linspace(-0.5, 0.5, n))
    V = np.stack([xs.ravel(), ys.ravel(), np.full(n * n, 2.0)], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    F = np.concatenate([np.stack([idx[:-1, :-1], idx[1:, :-1], idx[:-1, 1:]], -1).reshape(-1, 3),
                        np.stack([idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]], -1).reshape(-1, 3)])

    def color_fn(p, f):
        return np.where((p[:, 0] > 0)[:, None], [[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])

    subj = SyntheticSubject(V, F, np.full(len(F), 2, np.uint8), [], color_fn=color_fn)
    cam = Camera("c", 160, 160, 200.0, 200.0, 79.5, 79.5, np.eye(4))
    rig = Rig([cam])
    frames = render_frames(subj, rig, None, light=[0, 0, -1])
    uv, uvf = uv_atlas(V, F, resolution=256)
    tex, cov = bake_texture(V, F, uv, uvf, frames, rig, size=256)
    assert cov.mean() > 0.3
    # sample the texture at the UV of points well inside each half
    for x, expect in ((-0.3, [0, 0, 255]), (0.3, [255, 0, 0])):
        f = int(np.argmin(np.linalg.norm(V[F].mean(axis=1) - [x, 0.0, 2.0], axis=1)))
        c = uv[uvf[f]].mean(axis=0)
        px = tex[int((1 - c[1]) * 256), int(c[0] * 256)]
        assert np.abs(px.astype(int) - expect).max() < 40
