"""The bad-input campaign as regression tests: every case ends in a named error
(no traceback), a refusal, or a validation problem — never silent acceptance."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from dressmeup.cli import main
from dressmeup.errors import InputError


@pytest.fixture
def data_copy(bench_data, tmp_path):
    root = tmp_path / "data"
    shutil.copytree(bench_data, root)
    return root


def _run(capsys, *argv):
    try:
        status = main(list(map(str, argv)))
    except SystemExit as exc:  # a usage error found while parsing the options
        status = exc.code
    out = capsys.readouterr()
    assert "Traceback" not in out.err, out.err
    return status, out.out + out.err


@pytest.mark.parametrize("info, field", [
    ({}, "name"), ({"name": 3, "format": "dressmeup-dataset", "manifest_version": "1.0"}, "name"),
    ({"name": "x", "format": "zip", "manifest_version": "1.0"}, "format"),
    ({"name": "x", "format": "dressmeup-dataset", "manifest_version": "9.0"},
     "manifest_version"),
])
def test_validate_dataset_refuses_bad_dataset_json(data_copy, capsys, info, field):
    (data_copy / "dataset.json").write_text(json.dumps(info))
    status, text = _run(capsys, "validate-dataset", data_copy, "--no-hashes", "--no-meshes")
    assert status != 0 and f"field {field}" in text


def test_dataset_info_on_bad_json_is_named(data_copy):
    from dressmeup.data import Dataset

    (data_copy / "dataset.json").write_bytes(b'{"name": "\xff"}')
    with pytest.raises(InputError, match="dataset.json"):
        _ = Dataset(data_copy).info


def test_duplicate_sample_ids_are_refused(data_copy):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from dressmeup.data import Dataset

    t = pq.read_table(data_copy / "manifest.parquet")
    pq.write_table(pa.concat_tables([t, t.slice(0, 1)]), data_copy / "manifest.parquet")
    with pytest.raises(InputError, match="duplicate sample_id"):
        Dataset(data_copy)


@pytest.mark.parametrize("bad", ["int64", "float16", "huge", "truncated", "npy"])
def test_validate_submission_refuses_bad_predictions(scored, bench_edition, bench_data,
                                                     tmp_path, capsys, bad):
    sub = tmp_path / "sub"
    shutil.copytree(scored["gt"]["sub"], sub)
    victim = sorted(sub.glob("*.npz"))[0]
    V = np.load(victim)["vertices"]
    if bad == "int64":
        np.savez(victim, vertices=V.astype(np.int64))
    elif bad == "float16":
        np.savez(victim, vertices=V.astype(np.float16))
    elif bad == "huge":
        V = V.copy()
        V[0, 0] = 1e300
        np.savez(victim, vertices=V)
    elif bad == "truncated":
        victim.write_bytes(victim.read_bytes()[:100])
    else:
        np.save(tmp_path / "v.npy", V)
        victim.write_bytes((tmp_path / "v.npy").read_bytes())
    status, text = _run(capsys, "validate-submission", sub, "--edition", bench_edition,
                        "--data", bench_data)
    assert status == 1 and victim.name in text


def test_leaderboard_with_malformed_summary_is_one_line(scored, tmp_path, capsys):
    res = tmp_path / "res"
    shutil.copytree(scored["gt"]["res"].path, res)
    s = json.loads((res / "summary.json").read_text())
    s["edition"] = 5
    (res / "summary.json").write_text(json.dumps(s))
    status, text = _run(capsys, "leaderboard", res)
    assert status == 2 and "summary.json" in text and "edition" in text


def test_register_checks_keypoints_and_out_before_working(tmp_path, capsys):
    kp = tmp_path / "kp.json"
    kp.write_text("[[0, 1, 2]]")
    status, text = _run(capsys, "register", tmp_path / "scan.ply", "--model", "procedural",
                        "--out", tmp_path / "p.npz", "--keypoints", kp)
    assert status == 2 and "kp.json" in text
    status, text = _run(capsys, "register", tmp_path / "scan.ply", "--model", "procedural",
                        "--out", tmp_path)
    assert status == 2 and "is a folder" in text


def test_register_refuses_a_scan_in_millimetres():
    from dressmeup.body.registration.scan import prepare_scan

    pts = np.random.default_rng(0).uniform(0, 1.7, (500, 3))
    assert prepare_scan(pts).shape == (500, 3)
    with pytest.raises(InputError, match="millimetres"):
        prepare_scan(pts * 1000)


def test_fuse_checks_out_before_fusing(tmp_path, capsys):
    out = tmp_path / "scan.ply"
    out.write_text("x")
    status, text = _run(capsys, "fuse", tmp_path / "no-session", "--out", out)
    assert status == 2 and "existing file" in text
    folder = tmp_path / "scan"
    folder.mkdir()
    (folder / "scan.ply").write_text("x")
    status, text = _run(capsys, "fuse", tmp_path / "no-session", "--out", folder)
    assert status == 2 and "--overwrite" in text


@pytest.mark.parametrize("kind", ["fifo", "symlink-out", "symlink-in"])
def test_validate_submission_refuses_fifos_and_escaping_symlinks(scored, bench_edition,
                                                                 bench_data, tmp_path, kind):
    import os

    from dressmeup.bench.scoring.validate import validate_submission

    sub = tmp_path / "sub"
    shutil.copytree(scored["gt"]["sub"], sub)
    victim = sorted(sub.glob("*.npz"))[0]
    outside = tmp_path / "outside.npz"
    shutil.move(victim, outside)
    if kind == "fifo":
        os.mkfifo(victim)
    elif kind == "symlink-out":
        victim.symlink_to(outside)
    else:
        inside = sub / ".keep"
        inside.mkdir()
        shutil.move(outside, inside / victim.name)
        victim.symlink_to(inside / victim.name)
    import signal

    def hang(*_):
        raise TimeoutError("validate_submission blocked on a FIFO")

    old = signal.signal(signal.SIGALRM, hang)
    signal.alarm(120)  # fail instead of hanging CI forever
    try:
        report = validate_submission(sub, bench_edition, bench_data)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    if kind == "symlink-in":
        assert report.ok, report.summary()
    else:
        assert not report.ok and victim.name in report.summary()


def test_non_numeric_manifest_column_is_named(data_copy):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from dressmeup.data import Dataset

    t = pq.read_table(data_copy / "manifest.parquet")
    i = t.column_names.index("garment_vertices")
    t = t.set_column(i, "garment_vertices", pa.array(["many"] * len(t)))
    pq.write_table(t, data_copy / "manifest.parquet")
    with pytest.raises(InputError, match="manifest.parquet: manifest column 'garment_vertices'"):
        Dataset(data_copy)


def test_sample_garment_on_a_folder_is_named(data_copy):
    from dressmeup.data import Dataset

    ds = Dataset(data_copy)
    s = ds[0]
    path = data_copy / s.row["garment_path"]
    path.unlink()
    path.mkdir()
    with pytest.raises(InputError, match="not a regular file"):
        s.garment()


def test_session_json_with_garments_not_a_list_is_named(tmp_path):
    from dressmeup.capture.session import SessionInfo

    with pytest.raises(InputError, match="field garments"):
        SessionInfo.from_dict({"subject_id": "S1", "pose_id": "P1", "garments": 5},
                              "session.json")


def test_validate_dataset_flags_a_garment_in_millimetres(data_copy, capsys):
    from dressmeup.data import Dataset
    from dressmeup.io.mesh import load_mesh, save_mesh

    path = data_copy / Dataset(data_copy).manifest.iloc[0]["garment_path"]
    m = load_mesh(path)
    save_mesh(path, m.vertices * 1000.0, m.faces, uv=m.uv, uv_faces=m.uv_faces)
    status, text = _run(capsys, "validate-dataset", data_copy, "--no-hashes")
    assert status != 0 and "millimetres" in text


def test_non_utf8_edition_and_unreadable_scans_are_one_line(tmp_path, capsys):
    ed = tmp_path / "bad.json"
    ed.write_bytes(b"\xff\xfe{")
    status, text = _run(capsys, "validate-submission", tmp_path, "--edition", ed,
                        "--data", tmp_path)
    assert status == 2 and "bad.json" in text and "UTF-8" in text
    scan = tmp_path / "scan.ply"
    scan.write_bytes(b"garbage")
    status, text = _run(capsys, "register", scan, "--model", "procedural",
                        "--out", tmp_path / "p.npz")
    assert status == 2 and "scan.ply: not a PLY file" in text
    scan = tmp_path / "scan.obj"
    scan.write_text("v 1 2\nf 1 2 3\n")
    status, text = _run(capsys, "register", scan, "--model", "procedural",
                        "--out", tmp_path / "p.npz")
    assert status == 2 and "scan.obj" in text
