"""Mesh readers check headers and sizes before reading."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.errors import InputError
from dressmeup.io.mesh import load_mesh, save_mesh


def _sparse(path, size):
    with open(path, "wb") as fh:
        fh.truncate(size)


def test_sparse_zero_ply_is_refused_at_once(tmp_path, monkeypatch):
    """A 200 MB sparse file of zeros: refused from its first bytes, naming the file."""
    path = tmp_path / "garment.ply"
    _sparse(path, 200 << 20)
    with pytest.raises(InputError, match="garment.ply: not a PLY file"):
        load_mesh(path)


def test_ply_header_declaring_more_than_the_file_holds(tmp_path):
    path = tmp_path / "bomb.ply"
    path.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n"
                     b"property float x\nproperty float y\nproperty float z\n"
                     b"element face 0\nproperty list uchar int vertex_indices\nend_header\n"
                     + b"\0" * 1000)
    with pytest.raises(InputError, match="declares 1000000000 vertex"):
        load_mesh(path)


def test_oversized_mesh_files_are_refused_before_reading(tmp_path, monkeypatch):
    path = tmp_path / "big.obj"
    _sparse(path, 50 << 20)
    monkeypatch.setenv("DRESSMEUP_MAX_MESH_BYTES", str(10 << 20))
    with pytest.raises(InputError, match=r"over the limit of .*\(mesh_bytes\)"):
        load_mesh(path)


def test_validate_dataset_does_not_read_a_huge_fake_garment_whole(tmp_path):
    from dressmeup.data.dataset import read_dataset_ply

    path = tmp_path / "garment.ply"
    V = np.random.default_rng(0).random((10, 3))
    save_mesh(path, V, np.array([[0, 1, 2], [2, 3, 4]]))
    with open(path, "ab") as fh:  # a valid header followed by 100 MB of junk
        fh.truncate(path.stat().st_size + (100 << 20))
    assert read_dataset_ply(path) is None  # size disagrees with the header: not read


def test_quads_in_ply_are_triangulated(tmp_path):
    path = tmp_path / "quad.ply"
    path.write_text("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                    "property float y\nproperty float z\nelement face 1\n"
                    "property list uchar int vertex_indices\nend_header\n"
                    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
    m = load_mesh(path)
    assert m.faces.tolist() == [[0, 1, 2], [0, 2, 3]]


def test_fifo_mesh_is_refused(tmp_path):
    import os

    path = tmp_path / "garment.ply"
    os.mkfifo(path)
    with pytest.raises(InputError, match="not a regular file"):
        load_mesh(path)


def test_ply_with_unresolvable_texture_logs_no_trimesh_traceback(tmp_path, caplog):
    import logging

    path = tmp_path / "g.ply"
    save_mesh(path, np.eye(3), np.array([[0, 1, 2]]))
    text = path.read_bytes().replace(b"ply\n", b"ply\ncomment TextureFile missing.png\n", 1)
    path.write_bytes(text)
    with caplog.at_level(logging.DEBUG):
        m = load_mesh(path)
    assert m.texture_path is None
    assert not any("unable to load image" in r.getMessage() for r in caplog.records)


def test_obj_reader_memory_is_about_the_file_size(tmp_path):
    """Compact buffers: peak allocation stays within 3x the file (lists of floats took ~8x)."""
    import tracemalloc

    n = 20_000
    rng = np.random.default_rng(0)
    path = tmp_path / "big.obj"
    with open(path, "w") as fh:
        np.savetxt(fh, rng.random((n, 3)), fmt="v %.6f %.6f %.6f")
        np.savetxt(fh, rng.integers(1, n + 1, (2 * n, 3)), fmt="f %d %d %d")
    size = path.stat().st_size
    tracemalloc.start()
    try:
        m = load_mesh(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert m.vertices.shape == (n, 3) and m.faces.shape == (2 * n, 3)
    assert peak < 3 * size, (peak, size)
