"""Known bad inputs of the bench side: submissions that inflate or hold
100,000 members, predictions in millimetres, editions created over tampered, unfinished or
foreign data or under a shipped name, result folders that are lists or random bytes,
checkpoints that are not weights, a Dask scheduler file that is not one."""

from __future__ import annotations

import io
import json
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from dressmeup.bench import validate_submission
from dressmeup.bench.edition_create import create_edition
from dressmeup.cli import main
from dressmeup.data.integrity import ChecksumError
from dressmeup.errors import InputError
from dressmeup.limits import LimitError


@pytest.fixture
def sub_copy(scored, tmp_path):
    out = tmp_path / "sub"
    shutil.copytree(scored["gt"]["sub"], out)
    return out


def _first(folder):
    return sorted(folder.glob("*.npz"))[0]


def _npy(a) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.asarray(a))
    return buf.getvalue()


@pytest.mark.parametrize("damage, says", [
    ("inflating", "stores"), ("members", "npz_members"), ("millimetres", "millimetres"),
])
def test_validate_submission_refuses_bombs_and_units(sub_copy, bench_edition, bench_data,
                                                     damage, says):
    target = _first(sub_copy)
    if damage == "inflating":
        with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as z, \
                z.open("vertices.npy", "w", force_zip64=True) as fh:
            fh.write(_npy(np.zeros((3, 3))))
            for _ in range(32):
                fh.write(b"\x00" * (1 << 20))
    elif damage == "members":
        with zipfile.ZipFile(target, "w") as z:
            for i in range(20_000):
                z.writestr(f"m{i}.npy", _npy(np.zeros(1)))
    else:
        with np.load(target) as z:
            V = z["vertices"]
        np.savez(target, vertices=V * 1000.0)
    report = validate_submission(sub_copy, bench_edition, bench_data)
    assert not report.ok and target.stem in report.summary()
    assert says in report.summary(), report.summary()


@pytest.fixture
def data_copy(bench_data, tmp_path):
    out = tmp_path / "data"
    shutil.copytree(bench_data, out)
    return out


def test_edition_create_refuses_tampered_unfinished_and_foreign_data(data_copy):
    garment = sorted(data_copy.glob("samples/*/*/*/garment.ply"))[0]
    raw = garment.read_bytes()
    garment.write_bytes(raw[:-8] + b"\x00" * 8)
    with pytest.raises(ChecksumError, match="garment.ply"):
        create_edition(data_copy, "retarget", "lab-v1")
    garment.write_bytes(raw)
    info = json.loads((data_copy / "dataset.json").read_text())
    (data_copy / "dataset.json").write_text(json.dumps({**info, "complete": False}))
    with pytest.raises(InputError, match="not finished"):
        create_edition(data_copy, "retarget", "lab-v1")
    (data_copy / "dataset.json").write_bytes(b"\xff\xfe{}")
    with pytest.raises(InputError, match="not UTF-8"):
        create_edition(data_copy, "retarget", "lab-v1")
    (data_copy / "dataset.json").write_text("[1, 2]")
    with pytest.raises(InputError, match="a JSON list"):
        create_edition(data_copy, "retarget", "lab-v1")
    (data_copy / "dataset.json").write_text(json.dumps(info))
    with pytest.raises(InputError, match="is a garment dataset, but uvparam editions"):
        create_edition(data_copy, "uvparam", "lab-uv-v1")
    with pytest.raises(InputError, match="shipped edition's name"):
        create_edition(data_copy, "retarget", "synth-retarget-v3")
    assert create_edition(data_copy, "retarget", "lab-v1").name == "lab-v1"


def test_two_edition_creates_of_one_file_cannot_both_succeed(bench_data, tmp_path):
    out = tmp_path / "lab.json"
    argv = [sys.executable, "-m", "dressmeup", "edition", "create", "--data", str(bench_data),
            "--task", "retarget", "--name", "lab-v1", "--out", str(out)]
    procs = [subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    results = [(p.wait(), p.stderr.read()) for p in procs]
    codes = sorted(c for c, _ in results)
    assert codes[0] == 0 and codes[1] == 2, results
    err = next(e for c, e in results if c)
    assert "being written by another dressmeup run" in err or "already exists" in err


@pytest.mark.parametrize("damage, says", [
    ("list", "a JSON list"), ("random", "not UTF-8"),
    ("per_sample", "not a readable Parquet table"),
])
def test_leaderboard_and_report_refuse_damaged_results(scored, tmp_path, capsys, damage,
                                                       says):
    res = tmp_path / "res"
    shutil.copytree(scored["gt"]["res"].path, res)
    if damage == "list":
        (res / "summary.json").write_text("[1, 2]")
    elif damage == "random":
        (res / "summary.json").write_bytes(b"\xff" + np.random.default_rng(0).bytes(300))
    else:
        (res / "per_sample.parquet").write_bytes(np.random.default_rng(0).bytes(3000))
    for argv in (["leaderboard", str(res)],
                 ["report", str(res), "--out", str(tmp_path / "site"), "--max-images", "0"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and says in err, err


def test_score_refuses_a_scheduler_file_that_is_not_one(scored, bench_edition, bench_data,
                                                        tmp_path, capsys):
    pytest.importorskip("distributed")
    status = main(["score", str(scored["gt"]["sub"]), "-e", str(bench_edition), "-d",
                   str(bench_data), "--out", str(tmp_path / "res"), "--scheduler",
                   str(bench_edition)])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err and "--scheduler" in err, err
    assert not (tmp_path / "res").exists()


@pytest.mark.parametrize("content", ["random", "laughs"])
def test_retarget_weights_that_are_not_weights_are_named(bench_data, bench_edition, tmp_path,
                                                         capsys, content):
    from tests.io.test_io_bombs import laughs

    weights = tmp_path / "w.pt"
    weights.write_bytes(laughs() if content == "laughs"
                        else np.random.default_rng(0).bytes(4000))
    status = main(["baseline", "retarget", "--method", "isomap-refine", "--data",
                   str(bench_data), "--edition", str(bench_edition), "--out",
                   str(tmp_path / "sub"), "--weights", str(weights)])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err and "w.pt" in err, err


def test_limit_errors_are_input_errors():
    assert issubclass(LimitError, InputError)


def test_scheduler_file_gives_its_address(tmp_path):
    from dressmeup.executors.dask_executor import _scheduler_address

    f = tmp_path / "scheduler.json"
    f.write_text(json.dumps({"type": "Scheduler", "address": "tcp://127.0.0.1:8786"}))
    assert _scheduler_address(str(f)) == "tcp://127.0.0.1:8786"
    assert _scheduler_address("tcp://10.0.0.1:8786") == "tcp://10.0.0.1:8786"
    f.write_text("[]")
    with pytest.raises(InputError, match="not a Dask scheduler file"):
        _scheduler_address(str(f))
