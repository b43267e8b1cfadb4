"""Mesh files: round trips of geometry, per-vertex and per-corner UVs, textures, colours;
clear errors for missing, unreadable and empty files."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from dressmeup.errors import InputError
from dressmeup.io.mesh import load_mesh, save_mesh


def seam_mesh():
    """A cube whose UVs are per corner: each face of the cube is its own chart (seams)."""
    m = trimesh.creation.box()
    V, F = np.asarray(m.vertices), np.asarray(m.faces)
    rng = np.random.default_rng(0)
    uv = rng.random((F.size, 2))
    uv_faces = np.arange(F.size).reshape(-1, 3)
    return V, F, uv, uv_faces


@pytest.mark.parametrize("ext", ["obj", "ply"])
def test_round_trip_per_corner_uv_texture_colours(tmp_path, ext):
    V, F, uv, uvf = seam_mesh()
    tex = np.random.default_rng(1).integers(0, 256, (16, 8, 3), dtype=np.uint8)
    colors = np.random.default_rng(2).integers(0, 256, (len(V), 3), dtype=np.uint8)
    path = save_mesh(
        tmp_path / f"m.{ext}", V, F, uv=uv, uv_faces=uvf, texture=tex, vertex_colors=colors
    )
    m = load_mesh(path)
    assert m.vertices.shape == V.shape and np.array_equal(m.vertices, V)
    assert np.array_equal(m.faces, F)
    assert m.uv_faces is not None
    np.testing.assert_array_equal(m.uv[m.uv_faces], uv[uvf])  # every corner keeps its UV
    assert m.texture_path == tmp_path / "m.png"
    from PIL import Image

    assert np.array_equal(np.asarray(Image.open(m.texture_path)), tex)
    assert np.array_equal(m.vertex_colors, colors)
    # no temporary files left behind
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


@pytest.mark.parametrize("ext", ["obj", "ply"])
def test_round_trip_per_vertex_uv(tmp_path, ext):
    V, F, _, _ = seam_mesh()
    uv = V[:, :2] * 0.5 + 0.5
    m = load_mesh(save_mesh(tmp_path / f"m.{ext}", V, F, uv=uv))
    if ext == "ply":
        assert m.uv_faces is None and np.array_equal(m.uv, uv)
    else:  # OBJ always reads per corner, as the file says
        np.testing.assert_array_equal(m.uv[m.uv_faces], uv[F])
    assert m.texture_path is None


def test_obj_reader_polygons_negative_indices_and_texture_by_path(tmp_path):
    (tmp_path / "t.png").write_bytes(b"")  # placeholder file; only its existence matters
    (tmp_path / "q.mtl").write_text("newmtl a\nmap_Kd -s 1 1 1 t.png\n")
    (tmp_path / "q.obj").write_text(
        "mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
        "usemtl a\nf -4/-4 -3/-3 -2/-2 -1/-1\n"
    )
    m = load_mesh(tmp_path / "q.obj")
    assert m.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert m.uv_faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert m.texture_path == tmp_path / "t.png"


def test_texture_from_path_is_copied(tmp_path):
    from PIL import Image

    src = tmp_path / "src.jpg"
    Image.fromarray(np.full((4, 4, 3), 200, np.uint8)).save(src)
    V, F, uv, uvf = seam_mesh()
    m = load_mesh(save_mesh(tmp_path / "out" / "g.obj", V, F, uv, uvf, texture=src))
    assert m.texture_path == tmp_path / "out" / "g.png"


def test_errors_name_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.ply"):
        load_mesh(tmp_path / "nope.ply")
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"this is not a ply file")
    with pytest.raises(InputError, match="bad.ply"):
        load_mesh(bad)
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing\n")
    with pytest.raises(InputError, match="empty.obj.*no vertices"):
        load_mesh(empty)
    pts = tmp_path / "pts.obj"
    pts.write_text("v 0 0 0\nv 1 0 0\n")
    with pytest.raises(InputError, match="pts.obj.*no triangle faces"):
        load_mesh(pts)
    garbage = tmp_path / "g.obj"
    garbage.write_text("v 0 0 zero\n")
    with pytest.raises(InputError, match="g.obj: line 1"):
        load_mesh(garbage)
    out_of_range = tmp_path / "r.obj"
    out_of_range.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with pytest.raises(InputError, match="r.obj"):
        load_mesh(out_of_range)
    with pytest.raises(InputError, match="unsupported"):
        (tmp_path / "x.stl").write_text("solid")
        load_mesh(tmp_path / "x.stl")


@pytest.mark.parametrize("damage", [b"f\0", b"f\x01", b"\0f", b"f\xff"])
def test_obj_face_lines_with_control_bytes_are_errors_not_dropped(tmp_path, damage):
    """A damaged ``f`` line (``f\\0 1 2 3``) named by file and line, never skipped."""
    m = trimesh.creation.icosphere(subdivisions=1)
    save_mesh(tmp_path / "ok.obj", m.vertices, m.faces)
    lines = (tmp_path / "ok.obj").read_bytes().split(b"\n")
    faces = [i for i, line in enumerate(lines) if line.startswith(b"f ")]
    for i in faces[3:]:
        lines[i] = damage + lines[i][1:]
    bad = tmp_path / "bad.obj"
    bad.write_bytes(b"\n".join(lines))
    with pytest.raises(InputError, match=rf"bad.obj: line {faces[3] + 1}: .*not an OBJ statement"):
        load_mesh(bad)


def test_obj_statements_not_used_are_skipped_and_unknown_words_warned(tmp_path, caplog):
    obj = tmp_path / "n.obj"
    obj.write_bytes(b"\xef\xbb\xbfo thing\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\ng grp\n"
                    b"s off\nl 1 2\nweird 1 2\nf 1//1 2//1 3//1\n")
    with caplog.at_level("WARNING"):
        mesh = load_mesh(obj)
    assert mesh.faces.tolist() == [[0, 1, 2]]
    assert "'weird' (first on line 9)" in caplog.text


def test_save_rejects_bad_arrays(tmp_path):
    V, F, uv, uvf = seam_mesh()
    with pytest.raises(ValueError, match="uv"):
        save_mesh(tmp_path / "a.obj", V, F, uv=uv)  # per-corner count without uv_faces
    with pytest.raises(ValueError, match="faces"):
        save_mesh(tmp_path / "a.ply", V, F + 100)
    with pytest.raises(ValueError, match="texture"):
        save_mesh(tmp_path / "a.obj", V, F, uv, uvf, texture=np.zeros((4, 4, 3)))
    with pytest.raises(ValueError, match="unsupported"):
        save_mesh(tmp_path / "a.stl", V, F)
    assert not any(tmp_path.iterdir())


@pytest.mark.realdata
def test_shared_meshes_load(shared_meshes, tmp_path):
    spot = load_mesh(shared_meshes / "spot.obj")
    assert spot.vertices.shape == (2930, 3) and spot.faces.shape == (5856, 3)
    assert spot.uv.shape == (3225, 2) and spot.uv_faces.shape == (5856, 3)
    t = trimesh.load(shared_meshes / "cow.obj", process=False)
    cow = load_mesh(shared_meshes / "cow.obj")
    np.testing.assert_allclose(cow.vertices, t.vertices)
    assert np.array_equal(cow.faces, t.faces)
    again = load_mesh(
        save_mesh(tmp_path / "spot.obj", spot.vertices, spot.faces, spot.uv, spot.uv_faces)
    )
    np.testing.assert_array_equal(again.uv[again.uv_faces], spot.uv[spot.uv_faces])


def test_write_ply_compact_roundtrip_with_colours_and_labels(tmp_path):
    import json
    from dataclasses import dataclass
    from pathlib import Path

    from dressmeup.io.jsonable import json_default
    from dressmeup.io.mesh import load_mesh
    from dressmeup.io.ply import write_ply

    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    F = np.array([[0, 1, 2], [0, 1, 3]])
    C = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [9, 9, 9]], dtype=np.uint8)
    p = write_ply(tmp_path / "m.ply", V, F, colors=C, face_labels=np.array([3, 7]))
    head = p.read_bytes().split(b"end_header")[0].decode()
    assert "property float x" in head and "property uchar label" in head
    m = load_mesh(p)
    np.testing.assert_array_equal(m.vertices, V)
    np.testing.assert_array_equal(m.faces, F)
    np.testing.assert_array_equal(m.vertex_colors[:, :3], C)

    @dataclass
    class Rec:
        a: int

    s = json.dumps({"n": np.int64(3), "x": np.arange(2.0), "p": Path("a/b"), "r": Rec(1)},
                   default=json_default)
    assert json.loads(s) == {"n": 3, "x": [0.0, 1.0], "p": "a/b", "r": {"a": 1}}
    with pytest.raises(TypeError, match="not JSON serialisable: object"):
        json.dumps(object(), default=json_default)
