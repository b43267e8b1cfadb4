"""Bombs and damage in every shared reader, refused before the memory is spent: pickles
(billion laughs, deep nesting, self-reference, huge sparse matrices), ``.npz`` members that
inflate past their header or number 100,000, ``.npy`` headers declaring 206 GB, Parquet
tables of two million rows, PNGs of 40000 x 40000 pixels."""

from __future__ import annotations

import io
import pickle
import struct
import time
import zipfile
import zlib

import numpy as np
import pytest

from dressmeup.errors import InputError
from dressmeup.limits import LimitError


def laughs(depth: int = 9, fan: int = 10) -> bytes:
    """10^9 references from about 200 bytes: level k is a list of ``fan`` references to
    level k - 1."""
    ops = [b"\x80\x02", b"]", b"q\x00", b"X\x03\x00\x00\x00lol", b"a"]
    for level in range(1, depth + 1):
        ops += [b"]", b"q" + bytes([level]), b"("] + [b"h" + bytes([level - 1])] * fan
        ops += [b"e"]
    return b"".join(ops) + b"."


def test_billion_laughs_is_refused_by_its_opcodes_in_milliseconds(tmp_path):
    from dressmeup.body.safe_pickle import safe_load_pickle

    path = tmp_path / "smplx_param.pkl"
    path.write_bytes(laughs())
    assert path.stat().st_size < 300
    t0 = time.perf_counter()
    with pytest.raises(LimitError, match=r"pickle_objects.*DRESSMEUP_MAX_PICKLE_OBJECTS"):
        safe_load_pickle(path)
    assert time.perf_counter() - t0 < 5.0


def test_scan_counts_shared_references_and_passes_real_pickles():
    from dressmeup.io.pickles import scan_pickle

    small = scan_pickle(laughs(depth=3, fan=10))
    assert small.objects < 40 and small.expanded == 1 + 10 * (1 + 10 * (1 + 10 * 2))
    for obj in ({"v": np.zeros((100, 3)), "f": [1, 2, "x"], "t": (1.0, None)},
                list(range(1000)), {"nested": [[{"a": b"\x00" * 10}]]}):
        for proto in (2, 4, 5):
            assert scan_pickle(pickle.dumps(obj, protocol=proto)).expanded >= 1


@pytest.mark.parametrize("data, match", [
    (pickle.dumps([1, 2])[:-3], "readable"),
    (b"\x80\x02" + b"]" * 300_000 + b"a" * 299_999 + b".", None),
    (b"\x80\x05\x97.", "NEXT_BUFFER"),
    (b"", "readable"),
], ids=["truncated", "300000-deep", "out-of-band", "empty"])
def test_damaged_or_deep_pickles_are_input_errors(tmp_path, data, match):
    from dressmeup.body.safe_pickle import safe_load_pickle

    path = tmp_path / "x.pkl"
    path.write_bytes(data)
    with pytest.raises(InputError, match=match):
        safe_load_pickle(path)


def test_self_reference_is_refused():
    from dressmeup.io.pickles import scan_pickle

    a: list = []
    a.append(a)
    with pytest.raises(InputError, match="contains itself"):
        scan_pickle(pickle.dumps(a))


def test_sparse_matrix_too_large_to_densify_is_refused(tmp_path):
    import scipy.sparse as sp

    from dressmeup.body.safe_pickle import safe_load_pickle

    path = tmp_path / "model.pkl"
    path.write_bytes(pickle.dumps({"J_regressor": sp.csc_matrix((1_000_000, 1_000_000))},
                                  protocol=4))
    with pytest.raises(LimitError, match="sparse matrix of shape"):
        safe_load_pickle(path)


def _npy_bytes(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, a)
    return buf.getvalue()


def test_npz_member_inflating_past_its_header_is_refused_before_reading(tmp_path):
    from dressmeup.io.npz import load_npz

    path = tmp_path / "pred.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z, \
            z.open("vertices.npy", "w", force_zip64=True) as fh:
        fh.write(_npy_bytes(np.zeros((3, 3))))
        for _ in range(64):
            fh.write(b"\x00" * (1 << 20))
    with pytest.raises(InputError, match=r"stores 671\d+ bytes but its header declares 200"):
        load_npz(path)


def test_npz_of_100000_members_is_refused(tmp_path):
    from dressmeup.io.npz import load_npz

    path = tmp_path / "many.npz"
    one = _npy_bytes(np.zeros(1))
    with zipfile.ZipFile(path, "w") as z:
        for i in range(100_000):
            z.writestr(f"m{i}.npy", one)
    with pytest.raises(LimitError, match=r"arrays in one \.npz 100,000.*npz_members"):
        load_npz(path)


def test_npy_header_bomb_truncation_and_objects(tmp_path):
    from dressmeup.io.npz import load_npy

    bomb = tmp_path / "scan.npy"
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False,
                                               "shape": (1 << 33, 3)})
    bomb.write_bytes(buf.getvalue())
    with pytest.raises(LimitError, match=r"206,158,430,208 bytes .*array_bytes"):
        load_npy(bomb, "scan")
    good = tmp_path / "good.npy"
    np.save(good, np.arange(30.0).reshape(10, 3))
    np.testing.assert_array_equal(load_npy(good), np.arange(30.0).reshape(10, 3))
    cut = tmp_path / "cut.npy"
    cut.write_bytes(good.read_bytes()[:-5])
    with pytest.raises(InputError, match="truncated"):
        load_npy(cut)
    obj = tmp_path / "obj.npy"
    np.save(obj, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(InputError, match="Python objects"):
        load_npy(obj)
    junk = tmp_path / "junk.npy"
    junk.write_bytes(b"\x00" * 100)
    with pytest.raises(InputError, match="not a readable .npy"):
        load_npy(junk)


def test_parquet_rows_are_bounded_from_the_footer(tmp_path, monkeypatch):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from dressmeup.io.tables import read_table

    path = tmp_path / "manifest.parquet"
    pq.write_table(pa.table({"x": np.zeros(2_000_000, np.int8)}), path, compression="zstd")
    assert path.stat().st_size < 1_000_000
    with pytest.raises(LimitError, match=r"rows 2,000,000, over the limit of 1,000,000"):
        read_table(path, "manifest")
    monkeypatch.setenv("DRESSMEUP_MAX_TABLE_ROWS", "3M")
    assert read_table(path).num_rows == 2_000_000
    path.write_bytes(np.random.default_rng(0).bytes(5000))
    with pytest.raises(InputError, match="not a readable Parquet table"):
        read_table(path, "manifest")


def _png(width: int, height: int, rows: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    comp = zlib.compressobj(9)
    body = b"".join(comp.compress(b"\x00" * (3 * width + 1)) for _ in range(rows))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2,
                                                              0, 0, 0))
            + chunk(b"IDAT", body + comp.flush()) + chunk(b"IEND", b""))


def test_png_bomb_and_junk_are_refused_from_the_header(tmp_path):
    from dressmeup.io.images import image_header, read_image

    bomb = tmp_path / "texture.png"
    bomb.write_bytes(_png(40000, 40000, 10))
    with pytest.raises(LimitError, match="image_pixels"):
        image_header(bomb, "texture")
    with pytest.raises(LimitError):
        read_image(bomb, "texture")
    junk = tmp_path / "junk.png"
    junk.write_bytes(np.random.default_rng(1).bytes(4096))
    with pytest.raises(InputError, match="not a readable image"):
        image_header(junk, "texture", verify=True)
    ok = tmp_path / "ok.png"
    ok.write_bytes(_png(8, 4, 4))
    assert image_header(ok, verify=True).width == 8
    assert read_image(ok).shape == (4, 8, 3)
