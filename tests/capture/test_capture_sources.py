"""Subjects from dataset samples, and the optional Azure Kinect reader's absence message."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.capture.synthetic import label_faces_by_garments, place_subject, subject_from_sample
from dressmeup.errors import DressmeupError, InputError


def _sphere(r, n=3):
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=n, radius=r)
    return np.asarray(m.vertices), np.asarray(m.faces)


def test_scan_faces_on_a_garment_take_its_label():
    V, F = _sphere(1.0)
    cent = V[F].mean(axis=1)
    top = cent[:, 2] > 0.3
    # the garment is the scan's upper cap itself; the rest is skin
    used, inv = np.unique(F[top], return_inverse=True)
    labels = label_faces_by_garments(V, F, [(V[used], inv.reshape(-1, 3))], [5], tolerance=1e-3)
    np.testing.assert_array_equal(labels, np.where(top, 5, 1))


def test_subject_from_a_dataset_sample_folder(tmp_path):
    import trimesh

    V, F = _sphere(0.3)
    V = V * [1, 3, 1] + [0, 0.9, 0]  # a tall ellipsoid, y up
    cent = V[F].mean(axis=1)
    sel = cent[:, 1] > 1.2
    used, inv = np.unique(F[sel], return_inverse=True)
    d = tmp_path / "samples" / "S07" / "G03" / "P2"
    d.mkdir(parents=True)
    trimesh.Trimesh(V, F, process=False).export(d / "scan.ply")
    trimesh.Trimesh(V[used], inv.reshape(-1, 3), process=False).export(d / "garment.ply")
    s = subject_from_sample(d)
    assert (s.subject_id, s.pose_id) == ("S07", "P2")
    assert [g.id for g in s.garments] == ["G03"] and s.garments[0].label == 2
    np.testing.assert_array_equal(s.face_labels, np.where(sel, 2, 1))
    with pytest.raises(InputError, match="scan.ply"):
        subject_from_sample(tmp_path / "samples" / "S07" / "G03" / "P9")


def test_place_subject_stands_a_z_up_subject_on_a_y_up_floor(mannequin, small_rig):
    from dressmeup.capture.synthetic import SyntheticSubject

    V, F = _sphere(0.2)
    V = V * [1, 1, 4]  # long along z
    s = SyntheticSubject(V, F, np.ones(len(F), np.uint8), [])
    placed, T = place_subject(s, small_rig, "auto")
    ext = np.ptp(placed.vertices, axis=0)
    assert ext[1] == pytest.approx(1.6, rel=1e-6)
    assert placed.vertices[:, 1].min() == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(placed.vertices, V @ T[:3, :3].T + T[:3, 3])


def test_kinect_reader_without_pyk4a_says_how_to_install(monkeypatch):
    import builtins

    from dressmeup.capture import kinect

    real_import = builtins.__import__

    def fake(name, *a, **k):
        if name == "pyk4a":
            raise ImportError("No module named 'pyk4a'")
        return real_import(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", fake)
    with pytest.raises(DressmeupError, match=r"dressmeup\[kinect\]"):
        kinect.read_intrinsics("x.mkv")
