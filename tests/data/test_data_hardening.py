"""Known bad inputs of the data side: texture bombs and junk, a manifest of two
million rows, symlink loops, published datasets whose files are bombs or hold strings,
out-of-range faces or missing keys, THuman ids that collapse, resumed builds that lose
their records, two writers of one dataset."""

from __future__ import annotations

import json
import os
import pickle
import re
import shutil
import time

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import trimesh

from dressmeup.cli import main
from dressmeup.data.validate import validate_dataset
from dressmeup.errors import InputError
from dressmeup.io.hashing import sha256_file
from dressmeup.limits import LimitError

from ..bench.conftest import build_fixture_dataset
from ..io.test_io_bombs import _png, laughs
from .test_data_adapters import _dress4d_take, _pkl, _tri_mesh


@pytest.fixture(scope="module")
def fixture_data(tmp_path_factory):
    return build_fixture_dataset(tmp_path_factory.mktemp("hard") / "data")


@pytest.fixture
def data(fixture_data, tmp_path):
    out = tmp_path / "data"
    shutil.copytree(fixture_data, out)
    return out


def _give_texture(root, data: bytes):
    tex = next(root.glob("samples/*/*/*/garment.ply")).with_name("texture.png")
    tex.write_bytes(data)
    t = pq.read_table(root / "manifest.parquet")
    paths, hashes = t.column("texture_path").to_pylist(), t.column("texture_sha256").to_pylist()
    paths[0], hashes[0] = str(tex.relative_to(root)), sha256_file(tex)
    for name, values in (("texture_path", paths), ("texture_sha256", hashes)):
        t = t.set_column(t.column_names.index(name), t.schema.field(name),
                         pa.array(values, pa.string()))
    pq.write_table(t, root / "manifest.parquet")
    return tex


@pytest.mark.parametrize("texture, says", [
    (_png(40000, 40000, 50), "image_pixels"),
    (np.random.default_rng(0).bytes(5000), "not a readable image"),
], ids=["png-bomb", "random-bytes"])
def test_validate_dataset_refuses_texture_bombs_and_junk(data, texture, says):
    _give_texture(data, texture)
    t0 = time.perf_counter()
    rep = validate_dataset(data, check_hashes=False)
    assert time.perf_counter() - t0 < 30
    assert not rep.ok and any(says in p and "texture.png" in p for p in rep.problems), \
        rep.problems


def test_a_manifest_of_two_million_rows_is_refused_from_its_footer(data, capsys):
    t = pq.read_table(data / "manifest.parquet")
    big = t.take(pa.array(np.zeros(2_000_000, np.int64)))
    pq.write_table(big, data / "manifest.parquet", compression="zstd")
    t0 = time.perf_counter()
    assert main(["validate-dataset", str(data), "--no-meshes"]) == 1
    out = capsys.readouterr().out
    assert time.perf_counter() - t0 < 30 and "table_rows" in out and "2,000,000" in out


def test_symlink_loops_are_problems_not_tracebacks(data, tmp_path, capsys):
    os.symlink(data / "samples" / "loop_b", data / "samples" / "loop_a")
    os.symlink(data / "samples" / "loop_a", data / "samples" / "loop_b")
    rep = validate_dataset(data, check_meshes=False)
    assert any("loop_a" in p and "symbolic link" in p for p in rep.problems), rep.problems
    os.symlink(tmp_path / "root_b", tmp_path / "root_a")
    os.symlink(tmp_path / "root_a", tmp_path / "root_b")
    assert main(["validate-dataset", str(tmp_path / "root_a")]) == 1
    assert "not a folder" in capsys.readouterr().out


def _take(root):
    return _dress4d_take(root, "00122", "Inner", "Take2", ["00011"], [["upper", "lower"]],
                         seed=1)


@pytest.mark.parametrize("damage, says", [
    ("laughs", "pickle_objects"),
    ("string labels", "expected whole numbers"),
    ("missing key", "'scan_labels'"),
    ("faces out of range", "'faces' must be (m, 3) triangles"),
    ("no faces", "with 'vertices' and 'faces'"),
    ("vertices as text", "not numeric"),
])
def test_4ddress_damaged_files_are_named(tmp_path, damage, says):
    from dressmeup.data.importing import import_dataset

    take = _take(tmp_path / "src")
    labels = take / "Semantic" / "labels" / "label-f00011.pkl"
    mesh = take / "Meshes_pkl" / "mesh-f00011.pkl"
    cloth = take / "Semantic" / "clothes" / "cloth-f00011.pkl"
    m = pickle.loads(mesh.read_bytes())
    if damage == "laughs":
        labels.write_bytes(laughs())
    elif damage == "string labels":
        _pkl(labels, {"scan_labels": ["upper"] * len(m["vertices"])})
    elif damage == "missing key":
        _pkl(labels, {"labels": [1]})
    else:
        if damage == "faces out of range":
            m["faces"][0] = [0, 1, 10**6]
        elif damage == "no faces":
            m.pop("faces")
        else:
            m["vertices"] = "abc"
        _pkl(mesh, m)
    cloth.unlink()  # garments cut from the scan by its labels: every file is read
    with pytest.raises(InputError, match=re.escape(says)):
        import_dataset("4ddress", tmp_path / "src", tmp_path / "out")


def test_thuman_ids_that_clean_to_the_same_text_stay_two_samples(tmp_path, capsys):
    V, F = _tri_mesh()
    from dressmeup.io.mesh import save_mesh

    for name in ("a b", "a_b"):
        save_mesh(tmp_path / "scans" / name / f"{name}.obj", V, F)
    assert main(["import-dataset", "thuman", str(tmp_path / "scans"), "--no-body", "--out",
                 str(tmp_path / "out")]) == 0
    rows = pq.read_table(tmp_path / "out" / "manifest.parquet").column("sample_id")
    assert sorted(rows.to_pylist())[0] == "a_b" and len(rows) == 2


def test_thuman_billion_laughs_fit_is_refused(tmp_path):
    from dressmeup.data.importing import import_dataset
    from dressmeup.io.mesh import save_mesh

    V, F = _tri_mesh()
    save_mesh(tmp_path / "scans" / "0007" / "0007.obj", V, F)
    (tmp_path / "fits" / "0007").mkdir(parents=True)
    (tmp_path / "fits" / "0007" / "smplx_param.pkl").write_bytes(laughs())
    with pytest.raises(LimitError, match="smplx_param.pkl.*pickle_objects"):
        import_dataset("thuman", tmp_path / "scans", tmp_path / "out",
                       smplx=tmp_path / "fits")


def test_a_resumed_build_keeps_every_session_record(tmp_path):
    sessions = tmp_path / "sessions"
    for name, seed in (("s1", "1"), ("s2", "2")):
        assert main(["synth-capture", "mannequin", "--out", str(sessions / name), "--scale",
                     "0.2", "--seed", seed]) == 0
        info = json.loads((sessions / name / "session.json").read_text())
        info["subject_id"] = f"M{seed}"  # two subjects: two sets of samples
        (sessions / name / "session.json").write_text(json.dumps(info))
    root = tmp_path / "dataset"
    common = ["--out", str(root), "--voxel", "0.02", "--body", "none", "--target-faces",
              "500", "--no-texture"]
    assert main(["build-dataset", str(sessions / "s1"), *common]) == 0
    first = json.loads((root / "dataset.json").read_text())["build"]["sessions"]
    assert list(first) == ["s1"]
    # every sample present: the re-run writes nothing and keeps the record
    assert main(["build-dataset", str(sessions / "s1"), *common]) == 0
    assert json.loads((root / "dataset.json").read_text())["build"]["sessions"] == first
    # a later run adds its session beside the earlier one
    assert main(["build-dataset", str(sessions), *common]) == 0
    sessions_after = json.loads((root / "dataset.json").read_text())["build"]["sessions"]
    assert sorted(sessions_after) == ["s1", "s2"] and sessions_after["s1"] == first["s1"]


def test_a_second_dataset_writer_is_refused_while_the_first_writes(tmp_path):
    import subprocess
    import sys
    import textwrap

    from dressmeup.data.writer import DatasetWriter

    code = textwrap.dedent(f"""
        import time
        from dressmeup.data.writer import DatasetWriter
        w = DatasetWriter({str(tmp_path / 'd')!r}, {{"name": "x"}})
        print("open", flush=True)
        time.sleep(30)
    """)
    holder = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "open"
        with pytest.raises(InputError, match="being written by another dressmeup run"):
            DatasetWriter(tmp_path / "d", {"name": "x"})
    finally:
        holder.kill()
        holder.wait()
    w = DatasetWriter(tmp_path / "d", {"name": "x"})  # the dead writer's lock is gone
    assert w.previous_info["name"] == "x"


def test_thuman_scan_in_millimetres_among_metres_is_refused_naming_it(tmp_path):
    from dressmeup.data.importing import import_dataset
    from dressmeup.io.mesh import save_mesh

    body = trimesh.creation.capsule(height=1.2, radius=0.25)  # a person-sized scan, metres
    V, F = np.asarray(body.vertices), np.asarray(body.faces)
    save_mesh(tmp_path / "scans" / "0000" / "0000.obj", V, F)
    save_mesh(tmp_path / "scans" / "0001" / "0001.obj", V * 1000.0, F)  # millimetres
    save_mesh(tmp_path / "scans" / "0002" / "0002.obj", V * 1.1, F)
    with pytest.raises(InputError, match=r"The sample 0001 \(.*0001.obj\) spans 1841 units, "
                                         r"the sample 0000 .* 1.841 \(1e\+03 times\)"):
        import_dataset("thuman", tmp_path / "scans", tmp_path / "out", with_body=False)
    # scans of one unit import (people of different sizes are not a unit mismatch)
    (tmp_path / "scans" / "0001" / "0001.obj").unlink()
    save_mesh(tmp_path / "scans" / "0001" / "0001.obj", V * 0.8, F)
    assert import_dataset("thuman", tmp_path / "scans", tmp_path / "out",
                          with_body=False).written == 2
