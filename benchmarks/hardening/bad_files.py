"""Makers of bad input files: truncated, empty, random, of the wrong kind, bombed.

Each maker writes one file and returns its path; bombs are small on disk and declare or
inflate to gigabytes.
"""

from __future__ import annotations

import io
import json
import os
import pickle
import shutil
import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np


def copy_tree(src: Path, dst: Path) -> Path:
    """A private copy of a fixture folder (a case damages its own copy)."""
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst, symlinks=True)
    return dst


def truncated(src: Path, dst: Path, keep: float = 0.5) -> Path:
    raw = Path(src).read_bytes()
    dst.write_bytes(raw[: int(len(raw) * keep)])
    return dst


def empty(dst: Path) -> Path:
    dst.write_bytes(b"")
    return dst


def random_bytes(dst: Path, n: int = 4096, seed: int = 0) -> Path:
    dst.write_bytes(np.random.default_rng(seed).integers(0, 256, n, dtype=np.uint8).tobytes())
    return dst


def png(dst: Path, width: int = 8, height: int = 8) -> Path:
    """A valid small PNG (a wrong-kind input for mesh and JSON readers)."""
    return png_bomb(dst, width, height, real=True)


def png_bomb(dst: Path, width: int = 40000, height: int = 40000, real: bool = False) -> Path:
    """A PNG whose header declares width x height RGB pixels; the image data is one
    compressed stream of zero rows (40000 x 40000: 4.8 GB decoded, about 5 MB on disk)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    row = b"\x00" + b"\x00" * (3 * width)
    comp = zlib.compressobj(9)
    body = b"".join(comp.compress(row) for _ in range(height if real else min(height, 2000)))
    body += comp.flush()
    dst.write_bytes(b"\x89PNG\r\n\x1a\n"
                    + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                    + chunk(b"IDAT", body) + chunk(b"IEND", b""))
    return dst


def npy_header_bomb(dst: Path, shape=(1 << 33, 3), dtype="<f8") -> Path:
    """A ``.npy`` whose header declares ``shape`` (2^33 x 3 float64: 206 GB) with no data."""
    header = {"descr": dtype, "fortran_order": False, "shape": tuple(shape)}
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, header)
    dst.write_bytes(buf.getvalue())
    return dst


def npy_objects(dst: Path) -> Path:
    np.save(dst, np.array([{"a": 1}, None], dtype=object), allow_pickle=True)
    return dst


def npz_inflating(dst: Path, name: str = "vertices", mbytes: int = 1024) -> Path:
    """An ``.npz`` whose member holds a valid (3, 3) header followed by ``mbytes`` MB of
    zeros: the header declares 72 bytes, the member inflates to a gigabyte."""
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.zeros((3, 3)))
    head = buf.getvalue()
    with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as z, \
            z.open(name + ".npy", "w", force_zip64=True) as fh:
        fh.write(head)
        block = b"\x00" * (1 << 20)
        for _ in range(mbytes):
            fh.write(block)
    return dst


def npz_declared(dst: Path, name: str = "vertices", rows: int = 100_000_000) -> Path:
    """An ``.npz`` whose member declares (rows, 3) float64 and holds that many zeros,
    compressed (2.4 GB declared, a few MB on disk)."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": "<f8", "fortran_order": False, "shape": (rows, 3)})
    with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as z, \
            z.open(name + ".npy", "w", force_zip64=True) as fh:
        fh.write(buf.getvalue())
        block = b"\x00" * (1 << 20)
        left = rows * 24
        while left > 0:
            fh.write(block[: min(left, len(block))])
            left -= len(block)
    return dst


def npz_many(dst: Path, n: int = 100_000, valid: dict | None = None) -> Path:
    """An ``.npz`` of ``n`` tiny members (plus the arrays of ``valid``)."""
    with zipfile.ZipFile(dst, "w", zipfile.ZIP_STORED) as z:
        for k, v in (valid or {}).items():
            b = io.BytesIO()
            np.lib.format.write_array(b, np.asarray(v))
            z.writestr(k + ".npy", b.getvalue())
        b = io.BytesIO()
        np.lib.format.write_array(b, np.zeros(1))
        one = b.getvalue()
        for i in range(n):
            z.writestr(f"m{i}.npy", one)
    return dst


def laughs_pickle(dst: Path, depth: int = 9, fan: int = 10, wrap: str = "dict") -> Path:
    """A "billion laughs" pickle: ``depth`` levels of lists holding ``fan`` references to
    the level below (10^9 leaves from about 200 bytes), under a dict key when asked."""
    ops = [b"\x80\x02", b"]", b"q\x00", b"X\x03\x00\x00\x00lol", b"a"]  # l0 = ["lol"]
    for level in range(1, depth + 1):
        ops += [b"]", b"q" + bytes([level]), b"("]
        ops += [b"h" + bytes([level - 1])] * fan
        ops += [b"e"]
    body = b"".join(ops)
    if wrap == "dict":
        body = b"\x80\x02}q\xff(X\x0b\x00\x00\x00scan_labels" + body[2:] + b"u"
    dst.write_bytes(body + b".")
    return dst


def deep_pickle(dst: Path, depth: int = 200_000) -> Path:
    """Lists nested ``depth`` deep (a recursion bomb for recursive walkers)."""
    dst.write_bytes(b"\x80\x02" + b"]" * depth + b"a" * (depth - 1) + b".")
    return dst


def pickle_of(dst: Path, obj) -> Path:
    dst.parent.mkdir(parents=True, exist_ok=True)
    with open(dst, "wb") as fh:
        pickle.dump(obj, fh, protocol=2)
    return dst


def big_json(dst: Path, mbytes: int = 80) -> Path:
    """A valid JSON object of ``mbytes`` MB (one long string field)."""
    with open(dst, "w") as fh:
        fh.write('{"name": "x", "pad": "')
        block = "a" * (1 << 20)
        for _ in range(mbytes):
            fh.write(block)
        fh.write('"}')
    return dst


def deep_json(dst: Path, depth: int = 100_000) -> Path:
    dst.write_text("[" * depth + "]" * depth)
    return dst


def json_file(dst: Path, value) -> Path:
    dst.write_text(json.dumps(value))
    return dst


def parquet_rows(dst: Path, template: Path, rows: int = 2_000_000) -> Path:
    """A manifest of ``rows`` copies of ``template``'s first row (dictionary-encoded and
    compressed: a couple of hundred KB on disk)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = pq.read_table(template)
    first = t.slice(0, 1)
    idx = pa.array(np.zeros(rows, dtype=np.int64))
    big = first.take(idx)
    if "sample_id" in big.column_names:
        ids = pa.array([f"S{i}" for i in range(rows)])
        big = big.set_column(big.column_names.index("sample_id"), "sample_id", ids)
    pq.write_table(big, dst, compression="zstd")
    return dst


def symlink_loop(folder: Path) -> Path:
    a, b = folder / "loop_a", folder / "loop_b"
    os.symlink(b, a)
    os.symlink(a, b)
    return a
